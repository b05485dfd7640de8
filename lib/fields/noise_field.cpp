#include "fields/noise_field.hpp"

#include <cmath>

#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/params_util.hpp"

namespace swarmsim {

NoiseField::NoiseField(NoiseFieldKind kind, const NoiseParams& params, const Aabb& domain, const Obstacles& obstacles,
                       std::array<int, 3> cells, const Grid3<float>* boundary, double maxCells)
    : kind_(kind), boundary_(boundary), gain_(params.gain) {
  // 3 samples per lattice cell when that fits (at most 256 per axis and maxCells cells)
  const double edge = params.unit / (3.0 * params.scale);
  double total = 1.0;
  bool fits = true;
  for (int a = 0; a < 3; ++a) {
    const double na = std::ceil(domain.extent()[a] / edge);
    fits = fits && na <= 256.0;
    total *= na;
  }
  direct_ = cells[0] == 0 && !(fits && total <= maxCells);
  if (direct_) {
    potential_ = std::make_shared<NoisePotential>(params);
    step_ = 0.1 * edge;
    return;
  }
  const GridSpec spec =
      GridSpec::covering(domain.min, domain.max, cells[0] > 0 ? cells : cellsForEdge(domain, edge, maxCells));
  if (kind == NoiseFieldKind::kCurl) {
    Grid3<float> walls = signedDistance(obstacles, spec);
    addBoxWalls(walls, domain);
    grid_ = curl(noisePotential(spec, params, &walls));
  } else {
    grid_ = perlinVelocity(spec, params);
  }
}

Vec3 NoiseField::evaluate(const Vec3& x) const {
  const Vec3d p = x.cast<double>();
  if (kind_ == NoiseFieldKind::kPerlin) return (potential_->noise(p) * gain_).cast<float>();
  // away from the boundary (the blend is 1 over the whole difference stencil: the trilinear
  // distance changes by at most sqrt(3) per metre) the curl is exact, from the noises' gradients
  if (!boundary_ || boundary_->sample(x) >= potential_->d0() + 1.7320508 * step_) {
    return potential_->curlRaw(p).cast<float>();
  }
  Vec3d d[3];  // d[a] = ∂N/∂x_a
  for (int a = 0; a < 3; ++a) {
    Vec3d e = Vec3d::Zero();
    e[a] = step_;
    d[a] = ((*potential_)(p + e, boundary_) - (*potential_)(p - e, boundary_)) / (2.0 * step_);
  }
  return Vec3d(d[1].z() - d[2].y(), d[2].x() - d[0].z(), d[0].y() - d[1].x()).cast<float>();
}

}  // namespace swarmsim
