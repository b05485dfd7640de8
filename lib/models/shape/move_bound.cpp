#include "models/shape/move_bound.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "core/parallel.hpp"

namespace swarmsim {

namespace {
constexpr float kInf = std::numeric_limits<float>::infinity();

// box's bounds widened to take in the four floats at p (on SSE lanes where there are)
template <typename Box>
inline void widen(Box& box, const float* p) {
#if defined(__SSE2__)
  const __m128 v = _mm_loadu_ps(p);
  _mm_store_ps(box.lo, _mm_min_ps(_mm_load_ps(box.lo), v));
  _mm_store_ps(box.hi, _mm_max_ps(_mm_load_ps(box.hi), v));
#else
  for (int a = 0; a < 4; ++a) {
    box.lo[a] = std::min(box.lo[a], p[a]);
    box.hi[a] = std::max(box.hi[a], p[a]);
  }
#endif
}
// box's bounds widened to take in another box
template <typename Box>
inline void join(Box& box, const Box& o) {
#if defined(__SSE2__)
  _mm_store_ps(box.lo, _mm_min_ps(_mm_load_ps(box.lo), _mm_load_ps(o.lo)));
  _mm_store_ps(box.hi, _mm_max_ps(_mm_load_ps(box.hi), _mm_load_ps(o.hi)));
#else
  for (int a = 0; a < 4; ++a) {
    box.lo[a] = std::min(box.lo[a], o.lo[a]);
    box.hi[a] = std::max(box.hi[a], o.hi[a]);
  }
#endif
}
}  // namespace

const LocalMoveBound::Box LocalMoveBound::kEmpty = {{kInf, kInf, kInf, kInf}, {-kInf, -kInf, -kInf, -kInf}};

bool LocalMoveBound::compute(std::size_t n, const float* x, const float* y, const float* z, const float lo[3],
                             const float hi[3], const float* move, double edge, double maxMove, std::size_t maxBlocks,
                             float* local, const float* other, float otherAdd) {
  reach_ = -1.0;
  blocks_ = 0;
  spent_ = spentLocal_ = 0;
  if (n == 0 || !(edge > 0.0) || !std::isfinite(edge)) return false;
  // blocks of edge `edge` from lo; block (i, j, l) at i + dims[0] (j + dims[1] l)
  std::size_t dims[3];
  double origin[3], total = 1.0;
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || hi[a] < lo[a]) return false;
    origin[a] = static_cast<double>(lo[a]);
    const double d = std::floor((static_cast<double>(hi[a]) - origin[a]) / edge) + 1.0;
    total *= d;
    if (!(total <= static_cast<double>(maxBlocks))) return false;
    dims[a] = static_cast<std::size_t>(d);
  }
  const std::size_t count = dims[0] * dims[1] * dims[2];
  blocks_ = count;
  // each chunk's boxes of its insects' moves, per block (four lanes each: the fourth is not used)
  const auto chunks = static_cast<std::size_t>(chunkCount(n));
  blockOf_.resize(n);
  perChunk_.resize(chunks * count);
  const double inv = 1.0 / edge;
  const double top[3] = {static_cast<double>(dims[0] - 1), static_cast<double>(dims[1] - 1),
                         static_cast<double>(dims[2] - 1)};
  parallelChunks(n, [&](std::size_t first, std::size_t last, int chunk) {
    Box* boxes = perChunk_.data() + static_cast<std::size_t>(chunk) * count;
    std::fill(boxes, boxes + count, kEmpty);
    // (everything the loop reads in locals: the boxes' stores could alias what the lambda captured, which the
    // compiler then loads again for each insect)
    const double o[3] = {origin[0], origin[1], origin[2]}, t[3] = {top[0], top[1], top[2]}, iv = inv;
    const std::size_t d0 = dims[0], d1 = dims[1];
    const float *px = x, *py = y, *pz = z, *mv = move;
    std::uint32_t* blockOf = blockOf_.data();
    for (std::size_t k = first; k < last; ++k) {
      const double p[3] = {px[k], py[k], pz[k]};
      std::size_t at[3];
      for (int a = 0; a < 3; ++a) {
        // (p >= lo, so truncation is the floor; in double, far within the reach's slack of the exact block)
        const double i = std::min(std::max(0.0, (p[a] - o[a]) * iv), t[a]);
        at[a] = static_cast<std::size_t>(static_cast<std::int64_t>(i));
      }
      const std::size_t b = at[0] + d0 * (at[1] + d1 * at[2]);
      blockOf[k] = static_cast<std::uint32_t>(b);
      widen(boxes[b], mv + 3 * k);  // (and the next insect's first: the fourth lane)
    }
  });
  // merged over the chunks, then over the 3 x 3 x 3 blocks about each (one axis at a time)
  box_.resize(count);
  tmp_.resize(count);
  parallelFor(count, [&](std::size_t b) {
    Box m = perChunk_[b];
    for (std::size_t c = 1; c < chunks; ++c) join(m, perChunk_[c * count + b]);
    box_[b] = m;
  });
  // (each pass over rows of blocks along its axis: row r's first block, then `stride` apart)
  const std::size_t stride[3] = {1, dims[0], dims[0] * dims[1]};
  for (int axis = 0; axis < 3; ++axis) {
    const std::vector<Box>& from = axis == 1 ? tmp_ : box_;
    std::vector<Box>& to = axis == 1 ? box_ : tmp_;
    const std::size_t s = stride[axis], d = dims[axis], rows = count / d;
    parallelFor(rows, [&](std::size_t r) {
      const std::size_t first = (r / s) * s * d + r % s;  // the rows' blocks: i s + (everything but axis)
      Box last = kEmpty, here = from[first];
      for (std::size_t i = 0; i < d; ++i) {
        const std::size_t b = first + i * s;
        Box m = here;
        join(m, last);
        last = here;
        if (i + 1 < d) {
          here = from[b + s];
          join(m, here);
        }
        to[b] = m;
      }
    });
  }
  // each insect's bound: half the diagonal of its neighbourhood's box plus its own distance from the middle
  // (with a slack upward for the float rounding: the moves are below a metre, so it is below 1e-7 m)
  // (and the sums of the other bound and of the smaller of the two, in whole micrometres: integers, the same
  // for any split)
  sums_.assign(2 * chunks, 0);
  parallelChunks(n, [&](std::size_t first, std::size_t last, int chunk) {
    std::uint64_t spent = 0, spentLocal = 0;
    const Box* boxes = tmp_.data();  // (locals: as above)
    const std::uint32_t* blockOf = blockOf_.data();
    const float *mv = move, *ot = other, add = otherAdd;
    float* out = local;
    for (std::size_t k = first; k < last; ++k) {
      const Box& m = boxes[blockOf[k]];
      float half2 = 0.0f, own2 = 0.0f;
      for (int a = 0; a < 3; ++a) {
        const float w = m.hi[a] - m.lo[a], e = mv[3 * k + a] - 0.5f * (m.lo[a] + m.hi[a]);
        half2 += w * w;
        own2 += e * e;
      }
      const float bound = (0.5f * std::sqrt(half2) + std::sqrt(own2)) * (1.0f + 1e-5f) + 1e-7f;
      out[k] = bound;
      if (ot) {
        const float o = ot[k] + add;
        // (through signed integers: one instruction each, where the unsigned conversion branches)
        spent += static_cast<std::uint64_t>(static_cast<std::int64_t>(std::min(o, 1e6f) * 1e6f));
        spentLocal += static_cast<std::uint64_t>(static_cast<std::int64_t>(std::min({o, bound, 1e6f}) * 1e6f));
      }
    }
    sums_[2 * static_cast<std::size_t>(chunk)] = spent;
    sums_[2 * static_cast<std::size_t>(chunk) + 1] = spentLocal;
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    spent_ += sums_[2 * c];
    spentLocal_ += sums_[2 * c + 1];
  }
  reach_ = edge * (1.0 - 1e-6) - 2.0 * maxMove;
  return true;
}

}  // namespace swarmsim
