#pragma once
// Small vector helpers on top of Eigen.
#include <Eigen/Core>
#include <cmath>

namespace swarmsim {

using Vec3 = Eigen::Vector3f;
using Vec3d = Eigen::Vector3d;

// unit vector of v, or zero when v is (numerically) zero
inline Vec3 normalizedOrZero(const Vec3& v) {
  const float n2 = v.squaredNorm();
  return n2 > 1e-30f ? Vec3(v / std::sqrt(n2)) : Vec3::Zero();
}

}  // namespace swarmsim
