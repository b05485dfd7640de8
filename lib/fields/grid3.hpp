#pragma once
// Cell-centred regular 3-D grids over an axis-aligned box, and trilinear sampling.
//
// A GridSpec has n[a] cells along axis a, each `cell[a]` metres wide, starting at
// `min`; the value of cell (i, j, k) lives at its centre
//   min + ((i, j, k) + 0.5) * cell.
// Data are stored x-fastest: index = (k * n[1] + j) * n[0] + i.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

struct GridSpec {
  Vec3d min = Vec3d::Zero();
  Vec3d cell = Vec3d::Ones();  // cell edge per axis, metres
  std::array<int, 3> n = {1, 1, 1};

  // n cells per axis covering [lo, hi]
  static GridSpec covering(const Vec3d& lo, const Vec3d& hi, const std::array<int, 3>& cells) {
    GridSpec g;
    g.min = lo;
    g.n = cells;
    for (int a = 0; a < 3; ++a) g.cell[a] = (hi[a] - lo[a]) / cells[a];
    return g;
  }
  std::size_t size() const { return static_cast<std::size_t>(n[0]) * n[1] * n[2]; }
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i;
  }
  Vec3d center(int i, int j, int k) const {
    return min + Vec3d((i + 0.5) * cell[0], (j + 0.5) * cell[1], (k + 0.5) * cell[2]);
  }
  // centre of the cell with flat index c
  Vec3d centerOfIndex(std::size_t c) const {
    const std::size_t plane = static_cast<std::size_t>(n[0]) * n[1];
    return center(static_cast<int>(c % n[0]), static_cast<int>((c / n[0]) % n[1]), static_cast<int>(c / plane));
  }
  Vec3d max() const { return min + Vec3d(n[0] * cell[0], n[1] * cell[1], n[2] * cell[2]); }
  // the cell containing p, clamped to the grid (any p: clamped in floating
  // point before the conversion, so a huge or infinite t cannot overflow the
  // int; NaN gives cell 0)
  std::array<int, 3> cellOf(const Vec3d& p) const {
    std::array<int, 3> c{};
    for (int a = 0; a < 3; ++a) {
      const double t = (p[a] - min[a]) / cell[a];
      c[a] = t > 0.0 ? static_cast<int>(std::min(t, static_cast<double>(n[a] - 1))) : 0;
    }
    return c;
  }
};

template <typename T>
struct Grid3 {
  GridSpec spec;
  std::vector<T> data;  // spec.size() values, x-fastest

  Grid3() = default;
  Grid3(const GridSpec& s, const T& fill) : spec(s), data(s.size(), fill) {}

  T& at(int i, int j, int k) { return data[spec.index(i, j, k)]; }
  const T& at(int i, int j, int k) const { return data[spec.index(i, j, k)]; }

  // trilinear interpolation between cell centres; outside the centres' box
  // the nearest boundary values are used (clamped; t is compared in floating
  // point before any conversion, so huge or NaN coordinates are safe)
  T sample(const Vec3& p) const {
    int i0[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
      const float t = (p[a] - static_cast<float>(spec.min[a])) / static_cast<float>(spec.cell[a]) - 0.5f;
      const int last = spec.n[a] - 1;
      if (!(t > 0.0f)) {
        i0[a] = 0;
        f[a] = 0.0f;
      } else if (t >= static_cast<float>(last)) {
        i0[a] = std::max(0, last - 1);
        f[a] = last > 0 ? 1.0f : 0.0f;
      } else {
        i0[a] = static_cast<int>(t);
        f[a] = t - static_cast<float>(i0[a]);
      }
    }
    const int dx = spec.n[0] > 1 ? 1 : 0;
    const std::size_t sy = spec.n[1] > 1 ? static_cast<std::size_t>(spec.n[0]) : 0;
    const std::size_t sz = spec.n[2] > 1 ? static_cast<std::size_t>(spec.n[0]) * spec.n[1] : 0;
    const std::size_t b = spec.index(i0[0], i0[1], i0[2]);
    const T c00 = data[b] * (1.0f - f[0]) + data[b + dx] * f[0];
    const T c10 = data[b + sy] * (1.0f - f[0]) + data[b + sy + dx] * f[0];
    const T c01 = data[b + sz] * (1.0f - f[0]) + data[b + sz + dx] * f[0];
    const T c11 = data[b + sz + sy] * (1.0f - f[0]) + data[b + sz + sy + dx] * f[0];
    const T c0 = c00 * (1.0f - f[1]) + c10 * f[1];
    const T c1 = c01 * (1.0f - f[1]) + c11 * f[1];
    return c0 * (1.0f - f[2]) + c1 * f[2];
  }
};

}  // namespace swarmsim
