#pragma once
// The agents of the swarms a model sees (core/world.hpp SeenSwarms), binned for fixed-radius queries: the
// one way any model looks at other swarms. build() once per step from StepInfo::seen; absent agents
// (non-finite positions) are left out. Deterministic: the agents are taken in the order of the sees list
// and of each swarm's slots, and queries visit them in the grid's order, whatever the thread count.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/world.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

class SeenAgents {
 public:
  // bin the present agents of `seen` (null: none) for queries of radius up to `radius` (> 0)
  void build(const SeenSwarms* seen, float radius);
  std::size_t size() const { return grid_.size(); }
  bool empty() const { return grid_.size() == 0; }
  // call f(px, py, pz, vx, vy, vz, d2) for every seen agent within r of q (d2 = its squared distance)
  template <typename F>
  void forEachNear(float qx, float qy, float qz, float r, F&& f) const {
    if (empty()) return;
    const float* x = grid_.sortedX().data();
    const float* y = grid_.sortedY().data();
    const float* z = grid_.sortedZ().data();
    grid_.forEachNeighbor(qx, qy, qz, r, [&](std::uint32_t k, float, float, float, float d2) {
      f(x[k], y[k], z[k], vx_[k], vy_[k], vz_[k], d2);
    });
  }

 private:
  std::vector<float> px_, py_, pz_, ux_, uy_, uz_;  // present agents, in sees order
  std::vector<float> vx_, vy_, vz_;                 // their velocities in the grid's sorted order
  UniformGrid grid_;
};

}  // namespace swarmsim
