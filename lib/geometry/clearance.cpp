#include "geometry/clearance.hpp"

#include "core/parallel.hpp"

namespace swarmsim {

ObstacleClearance::ObstacleClearance(Grid3<float> sdf, float radius, bool any)
    : sdf_(std::move(sdf)), radius_(radius), any_(any) {
  const float margin = radius_ + 2.0f * static_cast<float>(sdf_.spec.cell.norm());
  far_.resize(sdf_.data.size());
  parallelFor(far_.size(), [&](std::size_t c) { far_[c] = sdf_.data[c] >= margin ? 1 : 0; });
  for (int a = 0; a < 3; ++a) {
    min_[a] = static_cast<float>(sdf_.spec.min[a]);
    inv_[a] = static_cast<float>(1.0 / sdf_.spec.cell[a]);
    top_[a] = static_cast<float>(sdf_.spec.n[a] - 1);
  }
}

Vec3 ObstacleClearance::normal(const Vec3& x) const {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    const float h = 0.5f * static_cast<float>(sdf_.spec.cell[a]);
    Vec3 e = Vec3::Zero();
    e[a] = h;
    g[a] = (sdf_.sample(x + e) - sdf_.sample(x - e)) / (2.0f * h);
  }
  return normalizedOrZero(g);
}

Vec3 ObstacleClearance::project(Vec3 x) const {
  for (int it = 0; it < 4; ++it) {
    const float phi = sdf_.sample(x);
    if (phi >= radius_) break;
    const Vec3 nrm = normal(x);
    if (nrm.squaredNorm() == 0.0f) break;
    x += nrm * (radius_ - phi + 1e-4f * static_cast<float>(sdf_.spec.cell.minCoeff()));
  }
  return x;
}

}  // namespace swarmsim
