#pragma once
// Mutable state of one swarm: one array per quantity (structure of arrays).
// Models may store the agents in any order (they keep them spatially sorted);
// the agent in slot i has the stable identifier id[i] in [0, n), which is what
// random streams and output rows are keyed on.
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

struct SwarmState {
  std::string name;
  std::vector<float> px, py, pz;  // position (n), metres
  std::vector<float> vx, vy, vz;  // velocity (n), metres per second
  std::vector<std::uint32_t> id;  // stable agent identifier (n)

  std::size_t size() const { return px.size(); }
  void resize(std::size_t n) {
    for (auto* a : {&px, &py, &pz, &vx, &vy, &vz}) a->assign(n, 0.0f);
    id.resize(n);
    for (std::size_t i = 0; i < n; ++i) id[i] = static_cast<std::uint32_t>(i);
  }
  // size the arrays without initialising ids (for a state that will be overwritten)
  void resizeStorage(std::size_t n) {
    for (auto* a : {&px, &py, &pz, &vx, &vy, &vz}) a->resize(n);
    id.resize(n);
  }
  // exchange the arrays (not the name) with another state; no allocation
  void swapStorage(SwarmState& o) {
    px.swap(o.px);
    py.swap(o.py);
    pz.swap(o.pz);
    vx.swap(o.vx);
    vy.swap(o.vy);
    vz.swap(o.vz);
    id.swap(o.id);
  }
  Vec3 position(std::size_t i) const { return {px[i], py[i], pz[i]}; }
  Vec3 velocity(std::size_t i) const { return {vx[i], vy[i], vz[i]}; }
  void setPosition(std::size_t i, const Vec3& p) {
    px[i] = p.x();
    py[i] = p.y();
    pz[i] = p.z();
  }
  void setVelocity(std::size_t i, const Vec3& v) {
    vx[i] = v.x();
    vy[i] = v.y();
    vz[i] = v.z();
  }
};

}  // namespace swarmsim
