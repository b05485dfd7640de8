#include "spatial/seen_agents.hpp"

#include <cmath>

#include "core/swarm_state.hpp"

namespace swarmsim {

void SeenAgents::build(const SeenSwarms* seen, float radius) {
  for (auto* a : {&px_, &py_, &pz_, &ux_, &uy_, &uz_}) a->clear();
  if (seen) {
    for (const SwarmState* s : seen->swarms) {
      for (std::size_t i = 0; i < s->size(); ++i) {
        if (!(std::isfinite(s->px[i]) && std::isfinite(s->py[i]) && std::isfinite(s->pz[i]))) continue;
        px_.push_back(s->px[i]);
        py_.push_back(s->py[i]);
        pz_.push_back(s->pz[i]);
        ux_.push_back(s->vx[i]);
        uy_.push_back(s->vy[i]);
        uz_.push_back(s->vz[i]);
      }
    }
  }
  grid_.build(px_.data(), py_.data(), pz_.data(), px_.size(), radius);
  grid_.gather(ux_, vx_);
  grid_.gather(uy_, vy_);
  grid_.gather(uz_, vz_);
}

}  // namespace swarmsim
