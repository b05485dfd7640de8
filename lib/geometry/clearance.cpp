#include "geometry/clearance.hpp"

#include <algorithm>
#include <cmath>

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

void ObstacleClearance::prepareDistanceBound() {
  // distanceBound: a trilinear blend of values >= m is >= m up to its three levels of rounding (each a
  // relative 2^-24 or so for the blend and for g = 1 - f): 1e-6 of |m| covers them, 1e-30 the subnormals
  const GridSpec& g = sdf_.spec;
  nx_ = static_cast<std::size_t>(g.n[0]);
  ny_ = static_cast<std::size_t>(g.n[1]);
  const std::size_t dx = g.n[0] > 1 ? 1 : 0, sy = g.n[1] > 1 ? nx_ : 0, sz = g.n[2] > 1 ? nx_ * ny_ : 0;
  cornerMin_.resize(sdf_.data.size());
  parallelFor(cornerMin_.size(), [&](std::size_t b) {
    const std::size_t i = b % nx_, j = (b / nx_) % ny_, k = b / (nx_ * ny_);
    // a base cell is never the last along an axis with more than one cell (Sampler::base)
    const std::size_t ox = i + 1 < nx_ ? dx : 0, oy = j + 1 < ny_ ? sy : 0,
                      oz = k + 1 < static_cast<std::size_t>(g.n[2]) ? sz : 0;
    float m = sdf_.data[b];
    for (const std::size_t o : {ox, oy, ox + oy, oz, oz + ox, oz + oy, oz + oy + ox}) m = std::min(m, sdf_.data[b + o]);
    cornerMin_[b] = std::isfinite(m) ? m - 1e-6f * std::fabs(m) - 1e-30f : m;
  });
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
