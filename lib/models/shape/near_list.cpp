#include "models/shape/near_list.hpp"

#include <algorithm>
#include <stdexcept>

#include "core/lanes.hpp"

namespace swarmsim {

namespace {

// the cell rows a scan of radius r about q visits: row (cz, cy) for cz in [lo[2], hi[2]], cy in [lo[1], hi[1]],
// each the run of sorted positions [begin, end) of its cells lo[0] to hi[0]
struct ScanRows {
  const UniformGrid& grid;
  const float *x, *y, *z;  // the grid's sorted positions
  int lo[3], hi[3];
  std::size_t nx, ny;
  ScanRows(const UniformGrid& g, float qx, float qy, float qz, float r)
      : grid(g),
        x(g.sortedX().data()),
        y(g.sortedY().data()),
        z(g.sortedZ().data()),
        nx(static_cast<std::size_t>(g.dim(0))),
        ny(static_cast<std::size_t>(g.dim(1))) {
    g.cellRange(qx, qy, qz, r, lo, hi);
  }
  std::size_t row(int cz, int cy) const {
    return (static_cast<std::size_t>(cz) * ny + static_cast<std::size_t>(cy)) * nx;
  }
  std::uint32_t begin(int cz, int cy) const { return grid.cellBegin(row(cz, cy) + static_cast<std::size_t>(lo[0])); }
  std::uint32_t end(int cz, int cy) const { return grid.cellEnd(row(cz, cy) + static_cast<std::size_t>(hi[0])); }
  // how many points the rows hold
  std::size_t points() const {
    std::size_t n = 0;
    for (int cz = lo[2]; cz <= hi[2]; ++cz) {
      for (int cy = lo[1]; cy <= hi[1]; ++cy) n += end(cz, cy) - begin(cz, cy);
    }
    return n;
  }
  // out with room for every point of the rows and the `lanes` a whole store writes past the last hit; out
  // only grows (no zero fill of the room at each scan)
  std::uint32_t* room(std::vector<std::uint32_t>& out, std::size_t lanes) const {
    const std::size_t need = points() + lanes;
    if (out.size() < need) out.resize(need);
    return out.data();
  }
};

// the grid points (sorted positions) j != k within r of q, eight candidates at a time over each cell row's run
template <typename L>
inline std::size_t scanLanes(const UniformGrid& grid, std::uint32_t k, float qx, float qy, float qz, float r,
                             std::vector<std::uint32_t>& out) {
  using V = typename L::V;
  const ScanRows rows(grid, qx, qy, qz, r);
  std::uint32_t* dst = rows.room(out, 0);
  std::size_t n = 0;
  const float *sx = rows.x, *sy = rows.y, *sz = rows.z;
  const float r2 = r * r;
  const V vx = L::set1(qx), vy = L::set1(qy), vz = L::set1(qz), vr2 = L::set1(r2);
  for (int cz = rows.lo[2]; cz <= rows.hi[2]; ++cz) {
    for (int cy = rows.lo[1]; cy <= rows.hi[1]; ++cy) {
      std::uint32_t j = rows.begin(cz, cy);
      const std::uint32_t end = rows.end(cz, cy);
      for (; j + kLanes <= end; j += static_cast<std::uint32_t>(kLanes)) {
        const V dx = L::sub(L::load(sx + j), vx), dy = L::sub(L::load(sy + j), vy), dz = L::sub(L::load(sz + j), vz);
        const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
        for (unsigned bits = L::mask(L::le(d2, vr2)); bits; bits &= bits - 1u) {
          const std::uint32_t p = j + static_cast<std::uint32_t>(__builtin_ctz(bits));
          if (p != k) dst[n++] = p;
        }
      }
      for (; j < end; ++j) {
        const float dx = sx[j] - qx, dy = sy[j] - qy, dz = sz[j] - qz;
        if (dx * dx + dy * dy + dz * dz <= r2 && j != k) dst[n++] = j;
      }
    }
  }
  return n;
}

#if SWARMSIM_X86_LANES
// scanLanes without a branch per hit or a scalar tail: each row's last lanes by masked loads, the hits packed
// by a table permute (kLanePack), the insect itself masked out. The same points in the same order.
SWARMSIM_AVX2 __attribute__((flatten)) std::size_t scanAvx2(const UniformGrid& grid, std::uint32_t k, float qx,
                                                            float qy, float qz, float r,
                                                            std::vector<std::uint32_t>& out) {
  const ScanRows rows(grid, qx, qy, qz, r);
  std::uint32_t* dst = rows.room(out, 8);
  std::size_t n = 0;
  const float *sx = rows.x, *sy = rows.y, *sz = rows.z;
  const __m256 vx = _mm256_set1_ps(qx), vy = _mm256_set1_ps(qy), vz = _mm256_set1_ps(qz), vr2 = _mm256_set1_ps(r * r);
  const __m256i laneIndex = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  for (int cz = rows.lo[2]; cz <= rows.hi[2]; ++cz) {
    for (int cy = rows.lo[1]; cy <= rows.hi[1]; ++cy) {
      std::uint32_t j = rows.begin(cz, cy);
      const std::uint32_t end = rows.end(cz, cy);
      for (; j < end; j += 8) {
        __m256 px, py, pz;
        const __m256i lanePos = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(j)), laneIndex);
        unsigned valid = 0xffu;
        if (end - j >= 8) {
          px = _mm256_loadu_ps(sx + j);
          py = _mm256_loadu_ps(sy + j);
          pz = _mm256_loadu_ps(sz + j);
        } else {  // the row's last lanes: nothing read past its end
          const __m256i in = _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(end - j)), laneIndex);
          valid = (1u << (end - j)) - 1u;
          px = _mm256_maskload_ps(sx + j, in);
          py = _mm256_maskload_ps(sy + j, in);
          pz = _mm256_maskload_ps(sz + j, in);
        }
        const __m256 dx = _mm256_sub_ps(px, vx), dy = _mm256_sub_ps(py, vy), dz = _mm256_sub_ps(pz, vz);
        const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
        unsigned hit = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2, vr2, _CMP_LE_OQ))) & valid;
        if (k - j < 8u) hit &= ~(1u << (k - j));  // not the insect itself
        const __m256i pick = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanePack.lanes[hit]));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst + n), _mm256_permutevar8x32_epi32(lanePos, pick));
        n += static_cast<std::size_t>(__builtin_popcount(hit));
      }
    }
  }
  return n;
}
// scanAvx2 on sixteen lanes: the hits packed by a compress, each row's last lanes by a masked load. The same
// points in the same order.
SWARMSIM_AVX512 __attribute__((flatten)) std::size_t scanAvx512(const UniformGrid& grid, std::uint32_t k, float qx,
                                                                float qy, float qz, float r,
                                                                std::vector<std::uint32_t>& out) {
  const ScanRows rows(grid, qx, qy, qz, r);
  std::uint32_t* dst = rows.room(out, 16);
  std::size_t n = 0;
  const float *sx = rows.x, *sy = rows.y, *sz = rows.z;
  const __m512 vx = _mm512_set1_ps(qx), vy = _mm512_set1_ps(qy), vz = _mm512_set1_ps(qz), vr2 = _mm512_set1_ps(r * r);
  const __m512i laneIndex = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i self = _mm512_set1_epi32(static_cast<int>(k));
  for (int cz = rows.lo[2]; cz <= rows.hi[2]; ++cz) {
    for (int cy = rows.lo[1]; cy <= rows.hi[1]; ++cy) {
      std::uint32_t j = rows.begin(cz, cy);
      const std::uint32_t end = rows.end(cz, cy);
      for (; j < end; j += 16) {
        const __mmask16 valid =
            end - j >= 16 ? static_cast<__mmask16>(0xffff) : static_cast<__mmask16>((1u << (end - j)) - 1u);
        const __m512 dx = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, sx + j), vx);
        const __m512 dy = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, sy + j), vy);
        const __m512 dz = _mm512_sub_ps(_mm512_maskz_loadu_ps(valid, sz + j), vz);
        // the same operations in the same order as scanAvx2 (no fused multiply-add)
        const __m512 d2 =
            _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
        const __m512i lanePos = _mm512_add_epi32(_mm512_set1_epi32(static_cast<int>(j)), laneIndex);
        // (not the insect itself: the mask stays in a mask register, no round trip through a general one)
        const __mmask16 hit =
            _mm512_mask_cmp_ps_mask(_mm512_mask_cmpneq_epi32_mask(valid, lanePos, self), d2, vr2, _CMP_LE_OQ);
        // compressed in a register and stored whole (a compressing store to memory is slow on some CPUs)
        _mm512_storeu_si512(dst + n, _mm512_maskz_compress_epi32(hit, lanePos));
        n += static_cast<std::size_t>(__builtin_popcount(static_cast<unsigned>(hit)));
      }
    }
  }
  return n;
}
// sortById of at most kRankSortMax entries without a branch per comparison: each entry's rank is how many
// ids are smaller (ids are distinct), counted eight at a time, and the entry goes to its rank. ids[] holds the
// m ids, padded to whole lanes with the largest id (never smaller than another); out gets the m positions.
constexpr std::size_t kRankSortMax = 128;
SWARMSIM_AVX2 void rankSortAvx2(const std::uint32_t* ids, const std::uint32_t* pos, std::size_t m,
                                std::uint32_t* out) {
  const __m256i flip = _mm256_set1_epi32(static_cast<int>(0x80000000u));  // unsigned order by signed compares
  for (std::size_t i = 0; i < m; ++i) {
    const __m256i key = _mm256_xor_si256(_mm256_set1_epi32(static_cast<int>(ids[i])), flip);
    std::size_t rank = 0;
    for (std::size_t j = 0; j < m; j += 8) {
      const __m256i other = _mm256_xor_si256(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + j)), flip);
      rank += static_cast<std::size_t>(
          __builtin_popcount(static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(key, other))))));
    }
    out[rank] = pos[i];
  }
}
// rankSortAvx2's ranks on sixteen lanes the other way round: the B sixteens of ids (padded) stay in registers, each
// with its lanes' ranks, and each id in turn adds one to the rank of every larger one (no count through a
// general register)
template <int B>
SWARMSIM_AVX512 inline void rankSortAvx512Of(const std::uint32_t* ids, const std::uint32_t* pos, std::size_t m,
                                             std::uint32_t* out) {
  __m512i key[B], rank[B];
  for (int b = 0; b < B; ++b) {
    key[b] = _mm512_loadu_si512(ids + 16 * b);
    rank[b] = _mm512_setzero_si512();
  }
  const __m512i one = _mm512_set1_epi32(1);
  for (std::size_t j = 0; j < m; ++j) {
    const __m512i other = _mm512_set1_epi32(static_cast<int>(ids[j]));
    for (int b = 0; b < B; ++b)
      rank[b] = _mm512_mask_add_epi32(rank[b], _mm512_cmpgt_epu32_mask(key[b], other), rank[b], one);
  }
  alignas(64) std::uint32_t r[16 * B];
  for (int b = 0; b < B; ++b) _mm512_store_si512(r + 16 * b, rank[b]);
  for (std::size_t i = 0; i < m; ++i) out[r[i]] = pos[i];
}
// (ids padded to whole sixteens; m <= kRankSortMax)
SWARMSIM_AVX512 void rankSortAvx512(const std::uint32_t* ids, const std::uint32_t* pos, std::size_t m,
                                    std::uint32_t* out) {
  static_assert(kRankSortMax <= 128, "rankSortAvx512: at most eight sixteens");
  using Sort = void (*)(const std::uint32_t*, const std::uint32_t*, std::size_t, std::uint32_t*);
  static constexpr Sort kSorts[8] = {rankSortAvx512Of<1>, rankSortAvx512Of<2>, rankSortAvx512Of<3>,
                                     rankSortAvx512Of<4>, rankSortAvx512Of<5>, rankSortAvx512Of<6>,
                                     rankSortAvx512Of<7>, rankSortAvx512Of<8>};
  if (m > 0) kSorts[(m + 15) / 16 - 1](ids, pos, m, out);
}
__attribute__((flatten)) std::size_t scanSse(const UniformGrid& g, std::uint32_t k, float x, float y, float z, float r,
                                             std::vector<std::uint32_t>& out) {
  return scanLanes<SseLanes>(g, k, x, y, z, r, out);
}
SWARMSIM_AVX __attribute__((flatten)) std::size_t scanAvx(const UniformGrid& g, std::uint32_t k, float x, float y,
                                                          float z, float r, std::vector<std::uint32_t>& out) {
  return scanLanes<AvxLanes>(g, k, x, y, z, r, out);
}
#endif

}  // namespace

void sortById(std::vector<std::uint32_t>& pos, const std::uint32_t* idOf, std::vector<std::uint64_t>& keys,
              LaneSet lanes) {
  sortById(pos.data(), pos.size(), idOf, keys, lanes);
}

void sortById(std::uint32_t* pos, std::size_t m, const std::uint32_t* idOf, std::vector<std::uint64_t>& keys,
              LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if ((lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512) && m <= kRankSortMax) {
    // the ids, padded, and a copy of the positions
    alignas(64) std::uint32_t ids[kRankSortMax + 16], from[kRankSortMax];
    for (std::size_t e = 0; e < m; ++e) {
      ids[e] = idOf[pos[e]];
      from[e] = pos[e];
    }
    for (std::size_t e = m; e % 16 != 0; ++e) ids[e] = 0xffffffffu;
    if (lanes == LaneSet::kAvx512) {
      rankSortAvx512(ids, from, m, pos);
    } else {
      rankSortAvx2(ids, from, m, pos);
    }
    return;
  }
#else
  (void)lanes;
#endif
  keys.resize(m);
  for (std::size_t e = 0; e < m; ++e) keys[e] = (std::uint64_t{idOf[pos[e]]} << 32) | pos[e];
  std::sort(keys.begin(), keys.end());
  for (std::size_t e = 0; e < m; ++e) pos[e] = static_cast<std::uint32_t>(keys[e]);
}

void NearLists::Slots::assign(std::size_t n, std::size_t capacity) {
  pos.assign(n * capacity, 0);
  len.assign(n, kNone);
  radius.assign(n, 0.0f);
  moved.assign(n, 0.0);
}

void NearLists::reset(std::size_t n, std::size_t capacity, float skin) {
  skin_ = skin;
  if (n == n_ && capacity == capacity_) return;
  n_ = n;
  capacity_ = capacity;
  last_.assign(n, capacity);
  next_.assign(n, capacity);
  lastOwn_.assign(n, 0.0f);
  lastLocal_.assign(n, 0.0f);
  localReach_ = -1.0;
}

void NearLists::advance(double maxMove, std::vector<float>& own, std::vector<float>* local, double localReach) {
  if (own.size() != n_ || (local && local->size() != n_)) throw std::logic_error("NearLists::advance: not n moves");
  lastMove_ = maxMove;
  lastOwn_.swap(own);
  localReach_ = local ? localReach : -1.0;
  if (local) lastLocal_.swap(*local);
  if (!inPlace_) std::swap(last_, next_);
  inPlace_ = false;
}

void NearLists::clear() {
  std::fill(last_.len.begin(), last_.len.end(), kNone);
  std::fill(next_.len.begin(), next_.len.end(), kNone);
}

const std::uint32_t* NearLists::keep(std::uint32_t from, std::uint32_t k, const std::uint32_t* newPos,
                                     std::size_t& m) {
  m = last_.len[from];
  const std::uint32_t* old = last_.pos.data() + static_cast<std::size_t>(from) * capacity_;
  if (inPlace_) {
    if (from != k) throw std::logic_error("NearLists::keep: a step in place with an insect moved");
    last_.moved[k] += lastMoveBound(k, static_cast<double>(last_.radius[k]));
    return old;  // every sorted position is last step's: the list as it is
  }
  std::uint32_t* list = next_.pos.data() + static_cast<std::size_t>(k) * capacity_;
  for (std::size_t e = 0; e < m; ++e) list[e] = newPos[old[e]];  // near k: mostly in this core's cache
  next_.len[k] = static_cast<std::uint32_t>(m);
  next_.radius[k] = last_.radius[from];
  next_.moved[k] = last_.moved[from] + lastMoveBound(from, static_cast<double>(last_.radius[from]));
  return list;
}

const std::uint32_t* NearLists::build(std::uint32_t k, float r, const UniformGrid& grid, const std::uint32_t* idOf,
                                      std::vector<std::uint32_t>& scratch, std::vector<std::uint64_t>& keys,
                                      std::size_t& m, LaneSet lanes) {
  const float qx = grid.sortedX()[k], qy = grid.sortedY()[k], qz = grid.sortedZ()[k];
  // (every scan keeps scratch's size and returns how many it found: no build zero-fills its room)
  m = 0;
  if (grid.size() > 0) {
#if SWARMSIM_X86_LANES
    switch (lanes) {
      case LaneSet::kAvx512:
        m = scanAvx512(grid, k, qx, qy, qz, r, scratch);
        break;
      case LaneSet::kAvx2:
        m = scanAvx2(grid, k, qx, qy, qz, r, scratch);
        break;
      case LaneSet::kAvx:
        m = scanAvx(grid, k, qx, qy, qz, r, scratch);
        break;
      default:
        m = scanSse(grid, k, qx, qy, qz, r, scratch);
    }
#else
    (void)lanes;
    m = scanLanes<ScalarLanes>(grid, k, qx, qy, qz, r, scratch);
#endif
  }
  sortById(scratch.data(), m, idOf, keys, lanes);
  Slots& out = inPlace_ ? last_ : next_;
  if (m > capacity_) {
    out.len[k] = kNone;
    return scratch.data();
  }
  std::uint32_t* list = out.pos.data() + static_cast<std::size_t>(k) * capacity_;
  std::copy(scratch.data(), scratch.data() + m, list);
  out.len[k] = static_cast<std::uint32_t>(m);
  out.radius[k] = r;
  out.moved[k] = 0.0;
  return list;
}

}  // namespace swarmsim
