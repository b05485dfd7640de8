#include "models/shape/near_list.hpp"

#include <algorithm>

#include "core/lanes.hpp"

namespace swarmsim {

namespace {

// the ids of the grid points j != k within r of q, eight candidates at a time over each cell row's run
template <typename L>
inline void scanLanes(const UniformGrid& grid, std::uint32_t k, float qx, float qy, float qz, float r,
                      const std::uint32_t* idOf, std::vector<std::uint32_t>& out) {
  using V = typename L::V;
  int lo[3], hi[3];
  grid.cellRange(qx, qy, qz, r, lo, hi);
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  const float r2 = r * r;
  const V vx = L::set1(qx), vy = L::set1(qy), vz = L::set1(qz), vr2 = L::set1(r2);
  const auto nx = static_cast<std::size_t>(grid.dim(0)), ny = static_cast<std::size_t>(grid.dim(1));
  for (int cz = lo[2]; cz <= hi[2]; ++cz) {
    for (int cy = lo[1]; cy <= hi[1]; ++cy) {
      const std::size_t row = (static_cast<std::size_t>(cz) * ny + static_cast<std::size_t>(cy)) * nx;
      std::uint32_t j = grid.cellBegin(row + static_cast<std::size_t>(lo[0]));
      const std::uint32_t end = grid.cellEnd(row + static_cast<std::size_t>(hi[0]));
      for (; j + kLanes <= end; j += static_cast<std::uint32_t>(kLanes)) {
        const V dx = L::sub(L::load(sx + j), vx), dy = L::sub(L::load(sy + j), vy), dz = L::sub(L::load(sz + j), vz);
        const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
        for (unsigned bits = L::mask(L::le(d2, vr2)); bits; bits &= bits - 1u) {
          const std::uint32_t p = j + static_cast<std::uint32_t>(__builtin_ctz(bits));
          if (p != k) out.push_back(idOf[p]);
        }
      }
      for (; j < end; ++j) {
        const float dx = sx[j] - qx, dy = sy[j] - qy, dz = sz[j] - qz;
        if (dx * dx + dy * dy + dz * dz <= r2 && j != k) out.push_back(idOf[j]);
      }
    }
  }
}

#if SWARMSIM_X86_LANES
__attribute__((flatten)) void scanSse(const UniformGrid& g, std::uint32_t k, float x, float y, float z, float r,
                                      const std::uint32_t* idOf, std::vector<std::uint32_t>& out) {
  scanLanes<SseLanes>(g, k, x, y, z, r, idOf, out);
}
SWARMSIM_AVX __attribute__((flatten)) void scanAvx(const UniformGrid& g, std::uint32_t k, float x, float y, float z,
                                                   float r, const std::uint32_t* idOf, std::vector<std::uint32_t>& out) {
  scanLanes<AvxLanes>(g, k, x, y, z, r, idOf, out);
}
#endif

}  // namespace

void NearLists::Slots::assign(std::size_t n, std::size_t capacity) {
  ids.assign(n * capacity, 0);
  len.assign(n, kNone);
  radius.assign(n, 0.0f);
  movedAt.assign(n, 0.0);
}

void NearLists::reset(std::size_t n, std::size_t capacity, float skin) {
  skin_ = skin;
  if (n == n_ && capacity == capacity_) return;
  n_ = n;
  capacity_ = capacity;
  last_.assign(n, capacity);
  next_.assign(n, capacity);
}

void NearLists::clear() {
  std::fill(last_.len.begin(), last_.len.end(), kNone);
  std::fill(next_.len.begin(), next_.len.end(), kNone);
}

const std::uint32_t* NearLists::keep(std::uint32_t from, std::uint32_t k, std::size_t& m) {
  m = last_.len[from];
  const std::uint32_t* old = last_.ids.data() + static_cast<std::size_t>(from) * capacity_;
  std::uint32_t* list = next_.ids.data() + static_cast<std::size_t>(k) * capacity_;
  for (std::size_t e = 0; e < m; ++e) list[e] = old[e];  // short: a loop, not a library call
  next_.len[k] = static_cast<std::uint32_t>(m);
  next_.radius[k] = last_.radius[from];
  next_.movedAt[k] = last_.movedAt[from];
  return list;
}

const std::uint32_t* NearLists::build(std::uint32_t k, float r, const UniformGrid& grid, const std::uint32_t* idOf,
                                      std::vector<std::uint32_t>& scratch, std::size_t& m, bool avx) {
  rebuilt_.fetch_add(1, std::memory_order_relaxed);
  const float qx = grid.sortedX()[k], qy = grid.sortedY()[k], qz = grid.sortedZ()[k];
  scratch.clear();
  if (grid.size() > 0) {
#if SWARMSIM_X86_LANES
    avx ? scanAvx(grid, k, qx, qy, qz, r, idOf, scratch) : scanSse(grid, k, qx, qy, qz, r, idOf, scratch);
#else
    (void)avx;
    scanLanes<ScalarLanes>(grid, k, qx, qy, qz, r, idOf, scratch);
#endif
  }
  std::sort(scratch.begin(), scratch.end());
  m = scratch.size();
  if (m > capacity_) {
    next_.len[k] = kNone;
    return scratch.data();
  }
  std::uint32_t* list = next_.ids.data() + static_cast<std::size_t>(k) * capacity_;
  std::copy(scratch.begin(), scratch.end(), list);
  next_.len[k] = static_cast<std::uint32_t>(m);
  next_.radius[k] = r;
  next_.movedAt[k] = moved_;
  return list;
}

}  // namespace swarmsim
