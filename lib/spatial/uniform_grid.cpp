#include "spatial/uniform_grid.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/lanes.hpp"
#include "core/parallel.hpp"

namespace swarmsim {

namespace {

#if SWARMSIM_X86_LANES
// points [first, last)'s cells, four at a time: UniformGrid::cellCoord's arithmetic in double (t clamped to
// [0, dims - 1] before the conversion, NaN to 0: max returns its second operand then), the flat index in 32 bits
// (its low bits, as the cast of the scalar index); low and high lowered and raised to the cells' range. Returns
// the first point it left to the caller
SWARMSIM_AVX std::size_t cellsAvx(const float* x, const float* y, const float* z, std::size_t first, std::size_t last,
                                  const double origin[3], const double inv[3], const int dims[3], std::uint32_t* cell,
                                  std::uint32_t& low, std::uint32_t& high) {
  const float* v[3] = {x, y, z};
  __m256d o[3], in[3], top[3];
  for (int a = 0; a < 3; ++a) {
    o[a] = _mm256_set1_pd(origin[a]);
    in[a] = _mm256_set1_pd(inv[a]);
    top[a] = _mm256_set1_pd(static_cast<double>(dims[a] - 1));
  }
  const __m128i d0 = _mm_set1_epi32(dims[0]), d1 = _mm_set1_epi32(dims[1]);
  __m128i lo4 = _mm_set1_epi32(-1), hi4 = _mm_setzero_si128();
  std::size_t i = first;
  for (; i + 4 <= last; i += 4) {
    __m128i c[3];
    for (int a = 0; a < 3; ++a) {
      const __m256d t = _mm256_mul_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm_loadu_ps(v[a] + i)), o[a]), in[a]);
      c[a] = _mm256_cvttpd_epi32(_mm256_min_pd(_mm256_max_pd(t, _mm256_setzero_pd()), top[a]));
    }
    const __m128i flat = _mm_add_epi32(_mm_mullo_epi32(_mm_add_epi32(_mm_mullo_epi32(c[2], d1), c[1]), d0), c[0]);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(cell + i), flat);
    lo4 = _mm_min_epu32(lo4, flat);
    hi4 = _mm_max_epu32(hi4, flat);
  }
  alignas(16) std::uint32_t l[4], h[4];
  _mm_store_si128(reinterpret_cast<__m128i*>(l), lo4);
  _mm_store_si128(reinterpret_cast<__m128i*>(h), hi4);
  for (int k = 0; k < 4; ++k) {
    low = std::min(low, l[k]);
    high = std::max(high, h[k]);
  }
  return i;
}

#endif

// growBox's lanes (core/lanes.hpp): axis points [0, m) eight at a time into lo and hi, finite cleared at a NaN
// (p <= p is false there); returns the first point left
template <typename L>
inline std::size_t growAxis(const float* v, std::size_t m, float& lo, float& hi, bool& finite) {
  using V = typename L::V;
  V l = L::set1(lo), h = L::set1(hi), ordered = L::le(L::set1(0.0f), L::set1(0.0f));
  std::size_t q = 0;
  for (; q + kLanes <= m; q += kLanes) {
    const V p = L::load(v + q);
    l = L::min(p, l);
    h = L::max(p, h);
    ordered = L::band(ordered, L::le(p, p));
  }
  alignas(32) float ls[kLanes], hs[kLanes];
  L::store(ls, l);
  L::store(hs, h);
  for (std::size_t j = 0; j < kLanes; ++j) {
    lo = std::min(lo, ls[j]);
    hi = std::max(hi, hs[j]);
  }
  finite = finite && L::mask(ordered) == 0xffu;
  return q;
}
#if SWARMSIM_X86_LANES
SWARMSIM_AVX __attribute__((flatten)) std::size_t growAxisAvx(const float* v, std::size_t m, float& lo, float& hi,
                                                              bool& finite) {
  return growAxis<AvxLanes>(v, m, lo, hi, finite);
}
#endif

}  // namespace

bool growBox(const float* x, const float* y, const float* z, std::size_t m, std::array<float, 6>& box, LaneSet lanes) {
  const float* v[3] = {x, y, z};
  bool finite = true;
  const bool avx = lanes != LaneSet::kSse;
  (void)avx;  // (only on x86)
  for (std::size_t a = 0; a < 3; ++a) {
    float lo = box[a], hi = box[3 + a];
    std::size_t q = 0;
#if SWARMSIM_X86_LANES
    q = avx ? growAxisAvx(v[a], m, lo, hi, finite) : growAxis<SseLanes>(v[a], m, lo, hi, finite);
#else
    q = growAxis<ScalarLanes>(v[a], m, lo, hi, finite);
#endif
    for (; q < m; ++q) {
      lo = std::min(lo, v[a][q]);
      hi = std::max(hi, v[a][q]);
      finite = finite && !std::isnan(v[a][q]);
    }
    box[a] = lo;
    box[3 + a] = hi;
  }
  return finite;
}

void UniformGrid::build(const float* x, const float* y, const float* z, std::size_t n, float minCell,
                        double cellsPerPoint, bool sortedCopies) {
  if (!(minCell > 0.0f)) throw std::invalid_argument("UniformGrid::build: cell size must be > 0");
  slack_ = 0.0f;
  // bounding box: per-chunk min/max, then combined (exact, so order-free)
  constexpr float kBig = std::numeric_limits<float>::max();
  const int chunks = chunkCount(n);
  std::vector<std::array<float, 6>>& part = bboxParts_;  // kept: no allocation per step
  part.assign(static_cast<std::size_t>(chunks), {kBig, kBig, kBig, -kBig, -kBig, -kBig});
  std::atomic<bool> nan{false};
  const LaneSet lanes = laneSet();
  parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
    if (!growBox(x + first, y + first, z + first, last - first, part[static_cast<std::size_t>(t)], lanes)) {
      nan.store(true);
    }
  });
  const bool avx = lanes != LaneSet::kSse;
  (void)avx;  // (only on x86)
  float lo[3] = {kBig, kBig, kBig}, hi[3] = {-kBig, -kBig, -kBig};
  for (const auto& r : part) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], r[a]);
      hi[a] = std::max(hi[a], r[3 + a]);
    }
  }
  for (int a = 0; a < 3; ++a) {
    if (n == 0) lo[a] = hi[a] = 0.0f;
    if (nan.load() || !std::isfinite(lo[a]) || !std::isfinite(hi[a])) {
      throw std::runtime_error("UniformGrid::build: non-finite agent position");
    }
  }
  // cell edge: slightly above minCell so a query of radius minCell spans +-1 cell
  // despite rounding; coarsened until there are at most ~2 cells per point
  double edge = static_cast<double>(minCell) * (1.0 + 1e-5);
  const double maxCells = cellsPerPoint * static_cast<double>(n) + 64.0;
  for (;;) {
    double cells = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double ext = static_cast<double>(hi[a]) - lo[a];
      dims_[a] = static_cast<int>(std::max(1.0, std::min(std::floor(ext / edge), 1e6)));
      cells *= dims_[a];
    }
    if (cells <= maxCells) break;
    edge *= std::cbrt(cells / maxCells) * 1.01;
  }
  for (int a = 0; a < 3; ++a) {
    origin_[a] = lo[a];
    const double ext = static_cast<double>(hi[a]) - lo[a];
    // every cell is at least `edge` wide; the last one absorbs the remainder
    const double cell = std::max(edge, dims_[a] > 1 ? ext / dims_[a] : edge);
    inv_[a] = 1.0 / cell;
  }

  // each point's cell, and each chunk's lowest and highest cell
  cell_.resize(n);
  const int teams = chunkCount(n);
  auto& range = rangeParts_;  // per chunk: its lowest and highest cell
  range.resize(static_cast<std::size_t>(teams));
  parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
    std::uint32_t low = 0xffffffffu, high = 0;
    std::size_t from = first;
#if SWARMSIM_X86_LANES
    if (avx) from = cellsAvx(x, y, z, first, last, origin_, inv_, dims_, cell_.data(), low, high);
#endif
    for (std::size_t i = from; i < last; ++i) {
      const auto c = static_cast<std::uint32_t>(
          (static_cast<std::size_t>(cellCoord(z[i], 2)) * dims_[1] + cellCoord(y[i], 1)) * dims_[0] +
          cellCoord(x[i], 0));
      cell_[i] = c;
      low = std::min(low, c);
      high = std::max(high, c);
    }
    range[static_cast<std::size_t>(t)] = {low, high};
  });
  sortByCell(x, y, z, n, sortedCopies);
}

void UniformGrid::buildFromCells(std::vector<std::uint32_t>& cells, std::size_t n, const int dims[3],
                                 const double origin[3], const double cellSize[3]) {
  if (cells.size() < n) throw std::invalid_argument("UniformGrid::buildFromCells: fewer cells than points");
  for (int a = 0; a < 3; ++a) {
    if (dims[a] < 1 || !(cellSize[a] > 0.0)) throw std::invalid_argument("UniformGrid::buildFromCells: bad grid");
    dims_[a] = dims[a];
    origin_[a] = origin[a];
    inv_[a] = 1.0 / cellSize[a];
  }
  slack_ = 0.0f;
  cell_.swap(cells);
  const std::size_t ncell = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  auto& range = rangeParts_;
  range.resize(static_cast<std::size_t>(chunkCount(n)));
  std::atomic<bool> outside{false};
  parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
    std::uint32_t low = 0xffffffffu, high = 0;
    for (std::size_t i = first; i < last; ++i) {
      low = std::min(low, cell_[i]);
      high = std::max(high, cell_[i]);
    }
    if (last > first && high >= ncell) outside = true;
    range[static_cast<std::size_t>(t)] = {low, high};
  });
  if (outside) throw std::invalid_argument("UniformGrid::buildFromCells: a cell beyond the grid");
  sortByCell(nullptr, nullptr, nullptr, n, false);
}

void UniformGrid::sortByCell(const float* x, const float* y, const float* z, std::size_t n, bool sortedCopies) {
  const std::size_t ncell = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  const auto& range = rangeParts_;
  const int teams = chunkCount(n);
  // counting sort, stable in point index. Each chunk of points (one per thread, in index order) counts and
  // places its points with cursors over the range of cells it touches; a state kept in last step's cell order
  // (every model writes it so) gives each chunk a slice of the cells, so the cursors take about one entry per
  // cell in all. Otherwise (the first step, points in any order, or cursors beyond 16 MiB) one thread sorts
  // with start_ alone.
  // each chunk's first cursor: its cells [lo, hi] one range after another; span = all of them
  std::vector<std::size_t>& base = rangeBase_;
  base.assign(range.size() + 1, 0);
  for (std::size_t t = 0; t < range.size(); ++t) {
    base[t + 1] = base[t] + (range[t][0] <= range[t][1] ? range[t][1] - range[t][0] + 1 : 0);
  }
  const std::size_t span = base.back();
  start_.assign(ncell + 1, 0);
  order_.resize(n);
  std::uint32_t* start = start_.data();
  // the cursors' memory stays bounded (16 MiB): beyond that (millions of points) one thread sorts, which costs
  // about 1 % of a boids step at 10 million agents and saves 4 bytes per cell
  constexpr std::size_t kMaxCursors = (std::size_t{16} << 20) / sizeof(std::uint32_t);
  if (teams > 1 && span <= ncell + ncell / 4 && span <= kMaxCursors) {
    // per chunk: counts, then cursors, over its cells [lo, hi] (cursor_ holds the chunks' ranges one after another)
    cursor_.assign(span, 0);
    parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
      std::uint32_t* count = cursor_.data() + base[static_cast<std::size_t>(t)];
      const std::uint32_t low = range[static_cast<std::size_t>(t)][0];
      for (std::size_t i = first; i < last; ++i) ++count[cell_[i] - low];
    });
    // cell by cell, the chunks in index order: each chunk's first slot in the cell, and the cell's start
    std::uint32_t at = 0;
    for (std::size_t c = 0; c < ncell; ++c) {
      start[c] = at;
      for (std::size_t t = 0; t < range.size(); ++t) {
        if (c < range[t][0] || c > range[t][1]) continue;
        std::uint32_t& slot = cursor_[base[t] + (c - range[t][0])];
        const std::uint32_t cnt = slot;
        slot = at;
        at += cnt;
      }
    }
    start[ncell] = at;
    parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
      std::uint32_t* cursor = cursor_.data() + base[static_cast<std::size_t>(t)];
      const std::uint32_t low = range[static_cast<std::size_t>(t)][0];
      for (std::size_t i = first; i < last; ++i) order_[cursor[cell_[i] - low]++] = static_cast<std::uint32_t>(i);
    });
  } else {
    // counts, their running sums (the end of each cell), then the points placed backwards from each end: in
    // index order within a cell, and start_[c] ends at the cell's start
    for (std::size_t i = 0; i < n; ++i) ++start[cell_[i]];
    for (std::size_t c = 1; c < ncell; ++c) start[c] += start[c - 1];
    start[ncell] = static_cast<std::uint32_t>(n);
    for (std::size_t i = n; i-- > 0;) order_[--start[cell_[i]]] = static_cast<std::uint32_t>(i);
  }
  if (!sortedCopies) {
    for (auto* a : {&sx_, &sy_, &sz_}) std::vector<float>().swap(*a);
    return;
  }
  for (auto* a : {&sx_, &sy_, &sz_}) {
    a->resize(n + kSortedPad);
    std::fill(a->begin() + static_cast<std::ptrdiff_t>(n), a->end(), 0.0f);
  }
  parallelFor(n, [&](std::size_t k) {
    const std::uint32_t i = order_[k];
    sx_[k] = x[i];
    sy_[k] = y[i];
    sz_[k] = z[i];
  });
}

void UniformGrid::moveSorted(const float* x, const float* y, const float* z, float moved) {
  if (sx_.empty() && !order_.empty()) throw std::logic_error("UniformGrid::moveSorted: a grid without sorted copies");
  if (!(moved >= 0.0f) || !std::isfinite(moved)) throw std::invalid_argument("UniformGrid::moveSorted: bad move");
  const std::size_t n = order_.size();
  parallelFor(n, [&](std::size_t k) {
    sx_[k] = x[k];
    sy_[k] = y[k];
    sz_[k] = z[k];
  });
  // a little more than the sum: float rounding of the moves
  slack_ = (slack_ + moved) * (1.0f + 1e-6f);
}

void UniformGrid::gatherCell(std::size_t c, float r, CellBlock& block) const {
  int lo[3], hi[3];
  cellBox(c, r, lo, hi);
  gatherBox(lo, hi, block);
}

void UniformGrid::cellBox(std::size_t c, float r, int lo[3], int hi[3]) const {
  const int cell[3] = {static_cast<int>(c % dims_[0]), static_cast<int>((c / dims_[0]) % dims_[1]),
                       static_cast<int>(c / (static_cast<std::size_t>(dims_[0]) * dims_[1]))};
  for (int a = 0; a < 3; ++a) {
    const int span = spanFor(r, a);
    lo[a] = std::max(0, cell[a] - span);
    hi[a] = std::min(dims_[a] - 1, cell[a] + span);
  }
}

void UniformGrid::gatherAround(float qx, float qy, float qz, float r, CellBlock& block) const {
  int lo[3], hi[3];
  cellRange(qx, qy, qz, r, lo, hi);
  gatherBox(lo, hi, block);
}

float UniformGrid::coveredRadius(const CellBlock& block, float qx, float qy, float qz) const {
  const double q[3] = {qx, qy, qz};
  double g = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double cell = 1.0 / inv_[a];
    if (block.lo[a] > 0) g = std::min(g, q[a] - (origin_[a] + block.lo[a] * cell));
    if (block.hi[a] < dims_[a] - 1) g = std::min(g, origin_[a] + (block.hi[a] + 1) * cell - q[a]);
  }
  // points up to slack_ outside their cells (moveSorted); cell coordinates and float distances round: stay a
  // little inside
  g -= static_cast<double>(slack_);
  return static_cast<float>(std::max(0.0, std::min(g * (1.0 - 1e-5), 3.0e38)));
}

void UniformGrid::gatherBox(const int lo[3], const int hi[3], CellBlock& block) const {
  for (int a = 0; a < 3; ++a) {
    block.lo[a] = lo[a];
    block.hi[a] = hi[a];
  }
  std::size_t total = 0;
  for (int cz = lo[2]; cz <= hi[2]; ++cz) {
    for (int cy = lo[1]; cy <= hi[1]; ++cy) {
      const std::size_t row = (static_cast<std::size_t>(cz) * dims_[1] + cy) * dims_[0];
      total += start_[row + hi[0] + 1] - start_[row + lo[0]];
    }
  }
  // grows rarely; reused across steps. kSlack entries stay beyond size, for whole-lane loads.
  if (block.x.size() < total + CellBlock::kSlack) {
    const std::size_t cap = total + total / 2 + 2 * CellBlock::kSlack;
    block.x.resize(cap);
    block.y.resize(cap);
    block.z.resize(cap);
    block.index.resize(cap);
    block.d2.resize(cap);
    block.hits.resize(cap);
  }
  std::size_t m = 0;
  for (int cz = lo[2]; cz <= hi[2]; ++cz) {
    for (int cy = lo[1]; cy <= hi[1]; ++cy) {
      const std::size_t row = (static_cast<std::size_t>(cz) * dims_[1] + cy) * dims_[0];
      const std::uint32_t b = start_[row + lo[0]], e = start_[row + hi[0] + 1];
      // short rows: a plain loop beats memmove calls
      for (std::uint32_t k = b; k < e; ++k, ++m) {
        block.x[m] = sx_[k];
        block.y[m] = sy_[k];
        block.z[m] = sz_[k];
        block.index[m] = k;
      }
    }
  }
  block.size = m;
}

void UniformGrid::gather(const std::vector<float>& src, std::vector<float>& dst) const {
  dst.resize(order_.size());
  parallelFor(order_.size(), [&](std::size_t k) { dst[k] = src[order_[k]]; });
}

}  // namespace swarmsim
