#pragma once
// Exact distance from a point to a triangle mesh by brute force over every
// triangle (face and edges), for tests that check geometry against it.
#include <algorithm>
#include <cmath>

#include "core/vec.hpp"
#include "geometry/mesh.hpp"

namespace swarmsim_test {

// exact squared distance from p to triangle (a, b, c), by brute force over the
// face and the three edges
inline double bruteTriangleDist2(const swarmsim::Vec3d& p, const swarmsim::Vec3d& a, const swarmsim::Vec3d& b,
                                 const swarmsim::Vec3d& c) {
  using swarmsim::Vec3d;
  auto segment = [&](const Vec3d& x, const Vec3d& y) {
    const Vec3d d = y - x;
    const double s = std::clamp((p - x).dot(d) / d.squaredNorm(), 0.0, 1.0);
    return (x + s * d - p).squaredNorm();
  };
  double best = std::min({segment(a, b), segment(b, c), segment(c, a)});
  const Vec3d n = (b - a).cross(c - a);
  const Vec3d q = p - n * ((p - a).dot(n) / n.squaredNorm());
  if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0) {
    best = std::min(best, (q - p).squaredNorm());
  }
  return best;
}

inline double bruteDistance(const swarmsim::TriangleMesh& m, const swarmsim::Vec3d& p) {
  double best = 1e300;
  for (const auto& t : m.triangles) {
    best = std::min(best, bruteTriangleDist2(p, m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]));
  }
  return std::sqrt(best);
}

}  // namespace swarmsim_test
