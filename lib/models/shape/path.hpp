#pragma once
// The global path of a shape (chen2019, section 6, "global path planning"): a
// clamped uniform cubic B-spline through the ends of its control polygon,
// parameterised by arc length so the shape travels it at a given speed.
//
// Knots: 0, 0, 0, 0, 1, 2, ..., m - 3, m - 2, m - 2, m - 2, m - 2 for control
// points P_0..P_m (m + 1 >= 4): the curve starts at P_0, ends at P_m, is C2,
// and stays in the control points' convex hull. Arc length comes from a table
// of 1024 chords per knot span (relative error ~1e-7 for smooth paths), the
// position at arc length s from that table and one more evaluation.
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

class BSplinePath {
 public:
  static constexpr int kDegree = 3;
  BSplinePath() = default;
  // throws std::invalid_argument with fewer than kDegree + 1 control points
  explicit BSplinePath(std::vector<Vec3d> control);

  bool empty() const { return control_.empty(); }
  double length() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }
  // the curve at parameter u in [0, 1] (clamped)
  Vec3d atParameter(double u) const;
  // the curve at arc length s from its start (clamped to [0, length()])
  Vec3d at(double s) const;
  // unit tangent at arc length s (the direction of travel)
  Vec3d tangent(double s) const;

 private:
  double parameterAt(double s) const;

  std::vector<Vec3d> control_;
  std::vector<double> knots_;
  std::vector<double> u_, cumulative_;  // the arc-length table
};

}  // namespace swarmsim
