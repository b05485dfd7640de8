#include "models/shape/path.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace swarmsim {

BSplinePath::BSplinePath(std::vector<Vec3d> control) : control_(std::move(control)) {
  const int m = static_cast<int>(control_.size()) - 1;
  if (m < kDegree) {
    throw std::invalid_argument("a cubic B-spline needs at least " + std::to_string(kDegree + 1) +
                                " control points, got " + std::to_string(control_.size()));
  }
  const int spans = m - kDegree + 1;
  for (int i = 0; i <= kDegree; ++i) knots_.push_back(0.0);
  for (int i = 1; i < spans; ++i) knots_.push_back(static_cast<double>(i));
  for (int i = 0; i <= kDegree; ++i) knots_.push_back(static_cast<double>(spans));
  for (double& k : knots_) k /= static_cast<double>(spans);
  const int samples = 1024 * spans;
  u_.resize(static_cast<std::size_t>(samples) + 1);
  cumulative_.resize(u_.size());
  Vec3d prev = atParameter(0.0);
  cumulative_[0] = 0.0;
  for (int i = 1; i <= samples; ++i) {
    u_[static_cast<std::size_t>(i)] = static_cast<double>(i) / samples;
    const Vec3d p = atParameter(u_[static_cast<std::size_t>(i)]);
    cumulative_[static_cast<std::size_t>(i)] = cumulative_[static_cast<std::size_t>(i) - 1] + (p - prev).norm();
    prev = p;
  }
}

Vec3d BSplinePath::atParameter(double u) const {
  u = std::clamp(u, 0.0, 1.0);
  const int m = static_cast<int>(control_.size()) - 1;
  // the knot span [knots_[k], knots_[k + 1]) holding u (the last span for u = 1)
  int k = static_cast<int>(std::upper_bound(knots_.begin(), knots_.end(), u) - knots_.begin()) - 1;
  k = std::clamp(k, kDegree, m);
  // de Boor's algorithm
  Vec3d d[kDegree + 1];
  for (int j = 0; j <= kDegree; ++j) d[j] = control_[static_cast<std::size_t>(j + k - kDegree)];
  for (int r = 1; r <= kDegree; ++r) {
    for (int j = kDegree; j >= r; --j) {
      const int i = j + k - kDegree;
      const double lo = knots_[static_cast<std::size_t>(i)], hi = knots_[static_cast<std::size_t>(i + kDegree + 1 - r)];
      const double a = hi > lo ? (u - lo) / (hi - lo) : 0.0;
      d[j] = (1.0 - a) * d[j - 1] + a * d[j];
    }
  }
  return d[kDegree];
}

double BSplinePath::parameterAt(double s) const {
  if (s <= 0.0) return 0.0;
  if (s >= length()) return 1.0;
  const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), s);
  const std::size_t b = static_cast<std::size_t>(it - cumulative_.begin()), a = b - 1;
  const double span = cumulative_[b] - cumulative_[a];
  const double f = span > 0.0 ? (s - cumulative_[a]) / span : 0.0;
  return u_[a] + f * (u_[b] - u_[a]);
}

Vec3d BSplinePath::at(double s) const { return atParameter(parameterAt(s)); }

Vec3d BSplinePath::tangent(double s) const {
  const double u = parameterAt(s), h = 1e-4;
  const double a = std::max(0.0, u - h), b = std::min(1.0, u + h);
  const Vec3d d = atParameter(b) - atParameter(a);
  const double n = d.norm();
  return n > 0.0 ? Vec3d(d / n) : Vec3d::UnitX();
}

}  // namespace swarmsim
