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
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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
  // point before any conversion, so huge or NaN coordinates are safe).
  // Sampler does the same for many points, the grid's constants converted once.
  T sample(const Vec3& p) const { return Sampler(*this)(p); }

  class Sampler {
   public:
    explicit Sampler(const Grid3& grid) : data_(grid.data.data()), size_(grid.data.size()) {
      const GridSpec& g = grid.spec;
      for (int a = 0; a < 3; ++a) {
        min_[a] = static_cast<float>(g.min[a]);
        cell_[a] = static_cast<float>(g.cell[a]);
        last_[a] = g.n[a] - 1;
      }
      nx_ = static_cast<std::size_t>(g.n[0]);
      ny_ = static_cast<std::size_t>(g.n[1]);
      dx_ = g.n[0] > 1 ? 1 : 0;
      sy_ = g.n[1] > 1 ? nx_ : 0;
      sz_ = g.n[2] > 1 ? nx_ * ny_ : 0;
    }
    T operator()(const Vec3& p) const { return blendAt(corners(p)); }

    // A sample's base cell (flat index) and its weights: f toward the next cell along each axis, g = 1 − f.
    // cornersOf makes them from the base cells along the axes and f (base()'s results); blendAt() blends them. A
    // batch sampler (fields/sample_batch.hpp) finds base() of many points on lanes, then takes these.
    struct Corners {
      std::size_t b;
      float f[3], g[3];
    };
    Corners cornersOf(const std::size_t i0[3], const float f[3]) const {
      Corners c;
      for (int a = 0; a < 3; ++a) {
        c.f[a] = f[a];
        c.g[a] = 1.0f - f[a];
      }
      c.b = (i0[2] * ny_ + i0[1]) * nx_ + i0[0];
      return c;
    }
    T blendAt(const Corners& c) const { return blend(c); }
    // base()'s constants, for the batch samplers
    struct Constants {
      float min[3], cell[3];
      int last[3];
    };
    Constants constants() const {
      return {{min_[0], min_[1], min_[2]}, {cell_[0], cell_[1], cell_[2]}, {last_[0], last_[1], last_[2]}};
    }

    // the base values below this one have corners that can each be read as 16 bytes (a Vec3 and 4 bytes past
    // it) inside the data: all but those whose last corner is the data's last value
    std::size_t wholeReadsBelow() const { return size_ - (sz_ + sy_ + dx_ + 1); }
    // the data, the offsets (in values) of a cell's neighbours along x, y and z that blend() reads (0 along an
    // axis of one cell) and wholeReadsBelow(), for the batch samplers
    struct Layout {
      const T* data;
      std::size_t nx, ny, dx, sy, sz, wholeBelow;
    };
    Layout layout() const { return {data_, nx_, ny_, dx_, sy_, sz_, wholeReadsBelow()}; }

    // the base cell along axis a of a sample at coordinate x (it reads cells base and base + 1), and f, the
    // fraction of the way to the next cell's centre
    std::size_t base(float x, int a, float& f) const {
      const float t = (x - min_[a]) / cell_[a] - 0.5f;
      const int last = last_[a];
      if (!(t > 0.0f)) {
        f = 0.0f;
        return 0;
      }
      if (t >= static_cast<float>(last)) {
        f = last > 0 ? 1.0f : 0.0f;
        return static_cast<std::size_t>(std::max(0, last - 1));
      }
      const int i = static_cast<int>(t);
      f = t - static_cast<float>(i);
      return static_cast<std::size_t>(i);
    }

   private:
    Corners corners(const Vec3& p) const {
      std::size_t i0[3];
      float f[3];
      for (int a = 0; a < 3; ++a) i0[a] = base(p[a], a, f[a]);
      return cornersOf(i0, f);
    }
    // the trilinear blend of the corners, x first, then y, then z (the neighbours along an axis of one cell:
    // offset 0)
    T blend(const Corners& c) const {
      const T* d = data_;
      const std::size_t b = c.b, dx = dx_, sy = sy_, sz = sz_;
      const T c00 = d[b] * c.g[0] + d[b + dx] * c.f[0];
      const T c10 = d[b + sy] * c.g[0] + d[b + sy + dx] * c.f[0];
      const T c01 = d[b + sz] * c.g[0] + d[b + sz + dx] * c.f[0];
      const T c11 = d[b + sz + sy] * c.g[0] + d[b + sz + sy + dx] * c.f[0];
      const T c0 = c00 * c.g[1] + c10 * c.f[1];
      const T c1 = c01 * c.g[1] + c11 * c.f[1];
      return c0 * c.g[2] + c1 * c.f[2];
    }

    const T* data_;
    std::size_t size_, nx_, ny_, dx_, sy_, sz_;
    float min_[3], cell_[3];
    int last_[3];
  };
  Sampler sampler() const { return Sampler(*this); }
};

#if defined(__SSE2__)
// The trilinear blend of a grid of vectors' eight corners, x first, then y, then z: the same operations per
// component as the generic sample (so the same bits), on one SSE register per corner (x, y, z and a lane that is
// not used). p: the base value's first float; dx, sy, sz: the neighbours' offsets in floats (3 per value); g and
// f: the weights per axis. A corner is read as 16 bytes, 4 past its value. Batch samplers call it too.
inline __m128 blendCorners(const float* p, std::size_t dx, std::size_t sy, std::size_t sz, float g0, float f0, float g1,
                           float f1, float g2, float f2) {
  const auto at = [&](std::size_t i) { return _mm_loadu_ps(p + i); };
  const auto lerp = [](__m128 x, __m128 y, float g, float f) {
    return _mm_add_ps(_mm_mul_ps(x, _mm_set1_ps(g)), _mm_mul_ps(y, _mm_set1_ps(f)));
  };
  const __m128 c00 = lerp(at(0), at(dx), g0, f0);
  const __m128 c10 = lerp(at(sy), at(sy + dx), g0, f0);
  const __m128 c01 = lerp(at(sz), at(sz + dx), g0, f0);
  const __m128 c11 = lerp(at(sz + sy), at(sz + sy + dx), g0, f0);
  return lerp(lerp(c00, c10, g1, f1), lerp(c01, c11, g1, f1), g2, f2);
}

// A grid of vectors: blendCorners, except at the very end of the data (the last value: three floats only)
template <>
inline Vec3 Grid3<Vec3>::Sampler::blendAt(const Corners& c) const {
  static_assert(sizeof(Vec3) == 12, "a Vec3 is three packed floats");
  if (c.b >= wholeReadsBelow()) return blend(c);
  const __m128 r =
      blendCorners(data_->data() + 3 * c.b, 3 * dx_, 3 * sy_, 3 * sz_, c.g[0], c.f[0], c.g[1], c.f[1], c.g[2], c.f[2]);
  alignas(16) float out[4];
  _mm_store_ps(out, r);
  return Vec3(out[0], out[1], out[2]);
}
#endif

}  // namespace swarmsim
