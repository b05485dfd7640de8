#pragma once
// Uniform grid for fixed-radius neighbour search, rebuilt once per step.
//
// build() bins the points by a counting sort over cells of edge >= minCell
// covering the points' bounding box (so points anywhere, inside or outside
// the domain, are handled; far-flung points only make cells coarser, since the
// number of cells is capped at a few per point). After build, points are also
// available in cell order (sortedX/Y/Z), and forEachNeighbor visits the sorted
// points within radius r of a query point. Cells are x-fastest, so the cells of
// one (y, z) row of the query's neighbourhood are one contiguous range of the
// sorted arrays. The visit order is deterministic (cell order, then point index).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/parallel.hpp"
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace swarmsim {

// box (lo xyz, hi xyz) grown to hold the m points, eight at a time (on the lanes of core/lanes.hpp: `lanes`,
// laneSet()). The lanes' min(v, lo) and max(v, hi) choose as std::min(lo, v) and std::max(hi, v) do, so a NaN never
// enters the box and every lane set gives the same bits. Returns false if a coordinate is NaN.
bool growBox(const float* x, const float* y, const float* z, std::size_t m, std::array<float, 6>& box, LaneSet lanes);

// Candidate neighbours of one cell, gathered contiguously (per-thread scratch).
// Queries from every point of the cell then scan one array, which is much
// faster than walking short cell rows per point.
struct CellBlock {
  std::vector<float> x, y, z;        // candidate positions
  std::vector<std::uint32_t> index;  // their sorted positions in the grid
  std::vector<float> d2;             // scratch: squared distances of the last filter
  std::vector<std::uint32_t> hits;   // block indices found by the last filter
  std::size_t size = 0;
  // every array holds at least size + kSlack entries (gatherBox), so a kernel may load whole lanes of up to
  // 8 floats from any j < size (the entries past size hold leftovers: mask them off)
  static constexpr std::size_t kSlack = 8;
  int lo[3] = {0, 0, 0}, hi[3] = {-1, -1, -1};  // the gathered box of cells (inclusive)

  // block indices of the candidates within r of q go to hits[0, returned count),
  // their squared distances stay in d2; deterministic order
  std::size_t filter(float qx, float qy, float qz, float r) {
    const float r2 = r * r;
    const float* __restrict bx = x.data();
    const float* __restrict by = y.data();
    const float* __restrict bz = z.data();
    float* __restrict dd = d2.data();
    for (std::size_t j = 0; j < size; ++j) {  // vectorises
      const float dx = bx[j] - qx, dy = by[j] - qy, dz = bz[j] - qz;
      dd[j] = dx * dx + dy * dy + dz * dz;
    }
    std::uint32_t* __restrict h = hits.data();
    std::size_t m = 0, j = 0;
#if defined(__SSE2__)
    // four at a time: the indices of the lanes within r, packed by a table of the 16 lane masks and
    // stored as one vector (the store may write up to 3 entries past the result: hits has the room)
    const __m128 vr2 = _mm_set1_ps(r2);
    for (; j + 4 <= size; j += 4) {
      const auto mask = static_cast<unsigned>(_mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(dd + j), vr2)));
      const __m128i packed = _mm_add_epi32(_mm_load_si128(reinterpret_cast<const __m128i*>(kPackedLanes[mask])),
                                           _mm_set1_epi32(static_cast<int>(j)));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(h + m), packed);
      m += kLaneCount[mask];
    }
#endif
    for (; j < size; ++j) {  // branch-free compaction
      h[m] = static_cast<std::uint32_t>(j);
      m += dd[j] <= r2 ? 1u : 0u;
    }
    return m;
  }

#if defined(__SSE2__)
  // for each 4-lane mask, the set lanes' numbers in order (the rest: don't care)
  alignas(16) static constexpr std::uint32_t kPackedLanes[16][4] = {
      {0, 0, 0, 0}, {0, 0, 0, 0}, {1, 0, 0, 0}, {0, 1, 0, 0}, {2, 0, 0, 0}, {0, 2, 0, 0}, {1, 2, 0, 0},
      {0, 1, 2, 0}, {3, 0, 0, 0}, {0, 3, 0, 0}, {1, 3, 0, 0}, {0, 1, 3, 0}, {2, 3, 0, 0}, {0, 2, 3, 0},
      {1, 2, 3, 0}, {0, 1, 2, 3}};
  // set lanes per 4-lane mask (__builtin_popcount is a library call on x86-64 without POPCNT)
  static constexpr std::uint8_t kLaneCount[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
#endif
};

class UniformGrid {
 public:
  // bin n points; minCell > 0 is the smallest allowed cell edge (usually the
  // largest query radius, so queries visit 3x3x3 cells); cells are coarsened
  // until there are at most cellsPerPoint * n + 64 of them. Without sortedCopies
  // the grid keeps no positions (sortedX/Y/Z are empty, and so is everything
  // that reads them: gatherCell, gatherAround, forEachNeighbor): for a caller
  // that puts its own arrays in cell order (boids, to save 12 bytes per point).
  void build(const float* x, const float* y, const float* z, std::size_t n, float minCell, double cellsPerPoint = 2.0,
             bool sortedCopies = true);
  // bin n points whose cells the caller has found: cells[i] is point i's cell (x fastest) of a grid of dims
  // cells of edge cellSize from origin. The vector is swapped with the grid's own buffer (the caller gets the
  // last build's back, to fill for the next one). No sorted copies are kept.
  void buildFromCells(std::vector<std::uint32_t>& cells, std::size_t n, const int dims[3], const double origin[3],
                      const double cellSize[3]);

  // The points, still given in sorted order (point k is sorted position k), have moved by at most `moved`
  // since the last build or moveSorted: their positions in sortedX/Y/Z become these, and the cells stay. A
  // point may now lie up to slack() (the sum of the moves since the build) outside its cell, so every query
  // below reaches slack() farther across cells, and tests distances on the new positions: the same points as
  // a grid built on them, in the cells' order, from a few more cells. (Only with sortedCopies.)
  void moveSorted(const float* x, const float* y, const float* z, float moved);
  float slack() const { return slack_; }

  std::size_t size() const { return order_.size(); }
  // sorted position k -> original point index
  const std::vector<std::uint32_t>& order() const { return order_; }
  // positions in sorted order: entries 0..size()-1, then kSortedPad entries (zero) so that kernels may load
  // whole lanes of up to 8 floats from any k < size() (mask off the lanes past size())
  static constexpr std::size_t kSortedPad = 8;
  const std::vector<float>& sortedX() const { return sx_; }
  const std::vector<float>& sortedY() const { return sy_; }
  const std::vector<float>& sortedZ() const { return sz_; }
  // dst[k] = src[order[k]] for every sorted position k (dst is resized)
  void gather(const std::vector<float>& src, std::vector<float>& dst) const;
  int dim(int axis) const { return dims_[axis]; }
  std::size_t cellCount() const { return start_.empty() ? 0 : start_.size() - 1; }
  // sorted positions [cellBegin(c), cellEnd(c)) are the points of cell c
  std::uint32_t cellBegin(std::size_t c) const { return start_[c]; }
  std::uint32_t cellEnd(std::size_t c) const { return start_[c + 1]; }
  // gather into `block` every point of the cells that can hold a point within
  // r of some point of cell c (a superset; use CellBlock::filter per query)
  void gatherCell(std::size_t c, float r, CellBlock& block) const;
  // gather the points of the cells overlapping the cube of half-width r about q
  void gatherAround(float qx, float qy, float qz, float r, CellBlock& block) const;
  // inclusive cell ranges overlapping [q - r, q + r] on each axis: every point
  // within r of q lies in them (cell coordinates are monotone in position)
  void cellRange(float qx, float qy, float qz, float r, int lo[3], int hi[3]) const {
    const double q[3] = {qx, qy, qz};
    // float rounding of distances: 1e-6 more
    const double rr = (static_cast<double>(r) + static_cast<double>(slack_)) * (1.0 + 1e-6);
    for (int a = 0; a < 3; ++a) {
      lo[a] = cellCoord(q[a] - rr, a);
      hi[a] = cellCoord(q[a] + rr, a);
    }
  }
  float cellSize(int axis) const { return static_cast<float>(1.0 / inv_[axis]); }
  // a radius about q (a point inside block's box of cells) within which every
  // grid point is in `block`: the distance from q to the nearest face of the box
  // that is not the grid's edge (no point lies beyond those), less a float slack
  float coveredRadius(const CellBlock& block, float qx, float qy, float qz) const;

  // call f(begin, end) for each run [begin, end) of sorted positions that can
  // hold points within r of q (one run per (y, z) cell row; rows may be empty)
  template <typename F>
  void forEachRun(float qx, float qy, float qz, float r, F&& f) const {
    if (order_.empty()) return;
    int lo[3], hi[3];
    cellRange(qx, qy, qz, r, lo, hi);
    for (int cz = lo[2]; cz <= hi[2]; ++cz) {
      for (int cy = lo[1]; cy <= hi[1]; ++cy) {
        const std::size_t row = (static_cast<std::size_t>(cz) * dims_[1] + cy) * dims_[0];
        f(start_[row + lo[0]], start_[row + hi[0] + 1]);
      }
    }
  }

  // forEachRun's runs less the cells that cannot hold a point within r of q: a row whose cross-section (its y and
  // z cell ranges) is farther than r from q is skipped, and the others' runs are cut to the cells the ball's chord
  // along x overlaps. The same points within r, in the same order, from about two thirds of the points (cells of
  // half r: 21.6 rows of 25 on average, 2.5 times the ball's volume instead of 3.7). The first and last cells of
  // an axis reach to infinity (they hold what lies beyond the grid's box).
  template <typename F>
  void forEachRunInBall(float qx, float qy, float qz, float r, F&& f) const {
    if (order_.empty()) return;
    int lo[3], hi[3];
    cellRange(qx, qy, qz, r, lo, hi);
    const double rr = (static_cast<double>(r) + static_cast<double>(slack_)) * (1.0 + 1e-6), rr2 = rr * rr;
    // the squared distance from q to the slab of cells c on axis a, a little less (1e-6 of a cell)
    const double ty = (static_cast<double>(qy) - origin_[1]) * inv_[1], tz = (static_cast<double>(qz) - origin_[2]) * inv_[2];
    const double size[3] = {0.0, 1.0 / inv_[1], 1.0 / inv_[2]};
    const auto gap2 = [&](double t, int c, int a) {
      double d = 0.0;
      if (c > 0 && t < c) d = c - t;
      if (c < dims_[a] - 1 && t > c + 1) d = t - (c + 1);
      d = std::max(0.0, d - 1e-6) * size[a];
      return d * d;
    };
    double gy[kMaxSpan], gz[kMaxSpan];
    const bool table = hi[1] - lo[1] < kMaxSpan && hi[2] - lo[2] < kMaxSpan;
    if (table) {
      for (int c = lo[1]; c <= hi[1]; ++c) gy[c - lo[1]] = gap2(ty, c, 1);
      for (int c = lo[2]; c <= hi[2]; ++c) gz[c - lo[2]] = gap2(tz, c, 2);
    }
    for (int cz = lo[2]; cz <= hi[2]; ++cz) {
      const double dz2 = table ? gz[cz - lo[2]] : gap2(tz, cz, 2);
      for (int cy = lo[1]; cy <= hi[1]; ++cy) {
        const double s = dz2 + (table ? gy[cy - lo[1]] : gap2(ty, cy, 1));
        if (s > rr2) continue;
        const std::size_t row = (static_cast<std::size_t>(cz) * dims_[1] + cy) * dims_[0];
        if (start_[row + lo[0]] == start_[row + hi[0] + 1]) continue;  // an empty run (sparse swarms: most)
        const double h = std::sqrt(rr2 - s);
        const int x0 = std::max(lo[0], cellCoord(qx - h, 0)), x1 = std::min(hi[0], cellCoord(qx + h, 0));
        f(start_[row + x0], start_[row + x1 + 1]);
      }
    }
  }

  // rows of cells: row = cz * dim(1) + cy, for row < rowCount()
  std::size_t rowCount() const { return static_cast<std::size_t>(dims_[1]) * dims_[2]; }
  // call f(c, runs, nRuns) for every non-empty cell c of `row`, in x order, where runs[2 i], runs[2 i + 1]
  // (i < nRuns) are the non-empty runs [begin, end) of sorted positions that can hold points within r of some
  // point of c: the rows gatherCell(c, r) gathers, in its order, so for every point q of c, forEachRun(q, r)
  // visits a subset of them. The neighbouring rows are found once per row (no division per cell). `runs` is
  // the caller's scratch (grown here, kept between calls).
  template <typename F>
  void forEachCellOfRow(std::size_t row, float r, std::vector<std::uint32_t>& runs, F&& f) const {
    const int cy = static_cast<int>(row % static_cast<std::size_t>(dims_[1]));
    const int cz = static_cast<int>(row / static_cast<std::size_t>(dims_[1]));
    int lo[3], hi[3], span[3];
    for (int a = 0; a < 3; ++a) span[a] = spanFor(r, a);
    lo[1] = std::max(0, cy - span[1]);
    hi[1] = std::min(dims_[1] - 1, cy + span[1]);
    lo[2] = std::max(0, cz - span[2]);
    hi[2] = std::min(dims_[2] - 1, cz + span[2]);
    const std::size_t rows = static_cast<std::size_t>(hi[1] - lo[1] + 1) * static_cast<std::size_t>(hi[2] - lo[2] + 1);
    if (runs.size() < 3 * rows) runs.resize(3 * rows);
    std::uint32_t* base = runs.data() + 2 * rows;  // the neighbouring rows' first cells, after the runs
    std::size_t nb = 0;
    for (int z = lo[2]; z <= hi[2]; ++z) {
      for (int y = lo[1]; y <= hi[1]; ++y) base[nb++] = static_cast<std::uint32_t>((static_cast<std::size_t>(z) * dims_[1] + y) * dims_[0]);
    }
    const std::size_t rowFirst = row * static_cast<std::size_t>(dims_[0]);
    for (int cx = 0; cx < dims_[0]; ++cx) {
      const std::size_t c = rowFirst + static_cast<std::size_t>(cx);
      if (start_[c] == start_[c + 1]) continue;
      const std::size_t x0 = static_cast<std::size_t>(std::max(0, cx - span[0]));
      const std::size_t x1 = static_cast<std::size_t>(std::min(dims_[0] - 1, cx + span[0])) + 1;
      std::size_t n = 0;
      for (std::size_t i = 0; i < nb; ++i) {
        const std::uint32_t b = start_[base[i] + x0], e = start_[base[i] + x1];
        runs[2 * n] = b;
        runs[2 * n + 1] = e;
        n += b < e ? 1 : 0;
      }
      f(c, static_cast<const std::uint32_t*>(runs.data()), n);
    }
  }

  // call f(k, dx, dy, dz, d2) for every sorted point k with d2 = |p_k - q|^2 <= r^2,
  // where (dx, dy, dz) = p_k - q. Includes the query point itself if it is a
  // grid point (d2 = 0). Any r works; r <= minCell visits at most 27 cells.
  template <typename F>
  void forEachNeighbor(float qx, float qy, float qz, float r, F&& f) const {
    const float r2 = r * r;
    forEachRun(qx, qy, qz, r, [&](std::uint32_t begin, std::uint32_t end) {
      // one plain pass: rows are short and hits rare, so a single loop (one
      // exit misprediction per row) beats blocked, branch-free filtering here
      for (std::uint32_t k = begin; k < end; ++k) {
        const float dx = sx_[k] - qx, dy = sy_[k] - qy, dz = sz_[k] - qz;
        const float d2 = dx * dx + dy * dy + dz * dz;
        if (d2 <= r2) f(k, dx, dy, dz, d2);
      }
    });
  }

 private:
  // the counting sort of build and buildFromCells, from cell_ and rangeParts_
  void sortByCell(const float* x, const float* y, const float* z, std::size_t n, bool sortedCopies);
  // the box of cells (inclusive) that can hold points within r of some point of cell c
  void cellBox(std::size_t c, float r, int lo[3], int hi[3]) const;
  // gather the points of cells lo..hi (inclusive) into block
  void gatherBox(const int lo[3], const int hi[3], CellBlock& block) const;
  // cells to search on each side for radius r. Cell coordinates are computed
  // in double, so they are exact to ~1e-12 cells; the 1e-6 slack makes a radius
  // equal to the cell edge search two cells, while a radius of minCell (cells
  // are built 1e-5 wider) searches one.
  static constexpr int kMaxSpan = 16;  // forEachRunInBall's tables of gaps per row
  int spanFor(float r, int axis) const {
    return static_cast<int>(
               std::floor((static_cast<double>(r) + static_cast<double>(slack_)) * inv_[axis] * (1.0 + 1e-6))) +
           1;
  }
  int cellCoord(double v, int axis) const {
    const double t = (v - origin_[axis]) * inv_[axis];
    if (!(t > 0.0)) return 0;  // also catches NaN
    return std::min(dims_[axis] - 1, static_cast<int>(t));
  }

  double origin_[3] = {0, 0, 0};
  double inv_[3] = {1, 1, 1};  // 1 / cell edge per axis
  int dims_[3] = {1, 1, 1};
  std::vector<std::uint32_t> cell_;              // cell of each point (n)
  std::vector<std::uint32_t> start_;             // first sorted position of each cell (cells + 1)
  std::vector<std::uint32_t> order_;             // sorted position -> point index (n)
  std::vector<std::uint32_t> cursor_;            // scratch for the counting sort (about one per cell)
  std::vector<std::array<std::uint32_t, 2>> rangeParts_;  // build scratch: each chunk's lowest and highest cell
  std::vector<std::size_t> rangeBase_;                    // build scratch: each chunk's first cursor
  std::vector<float> sx_, sy_, sz_;              // positions in sorted order (n + kSortedPad)
  std::vector<std::array<float, 6>> bboxParts_;  // per-chunk bounding boxes (build scratch)
  float slack_ = 0.0f;                           // how far the points have moved since the build (moveSorted)
};

// The cell-batched neighbour loop: for every sorted point k of `grid`, in
// parallel over cells, calls visit(k, block, hits) where block.hits[0, hits)
// index the candidates (block.index[h] = sorted position, block.d2[h] = squared
// distance) within r of point k, the point itself included. `blocks` is
// per-thread scratch, kept between calls so steps do not allocate.
template <typename F>
void forEachPointNeighbors(const UniformGrid& grid, float r, std::vector<CellBlock>& blocks, F&& visit) {
  blocks.resize(static_cast<std::size_t>(threadCount()));
  // each point's work is a whole neighbourhood scan: worth the team from a few
  // hundred points on (plain index loops use the higher kSerialBelow)
  constexpr std::size_t kSerialPointsBelow = 256;
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  // sparse grids (cells coarsened to hold few points): gather per point over
  // the cells its ball overlaps; otherwise gather once per cell and share it
  // among the cell's points
  if (2 * grid.size() < grid.cellCount()) {
    const auto pointWork = [&](std::size_t k) {
      CellBlock& block = blocks[static_cast<std::size_t>(threadIndex())];
      grid.gatherAround(sx[k], sy[k], sz[k], r, block);
      visit(static_cast<std::uint32_t>(k), block, block.filter(sx[k], sy[k], sz[k], r));
    };
    if (grid.size() < kSerialPointsBelow) {
      for (std::size_t k = 0; k < grid.size(); ++k) pointWork(k);
    } else {
      parallelForDynamic(grid.size(), 256, pointWork);
    }
    return;
  }
  const auto cellWork = [&](std::size_t c) {
    const std::uint32_t a0 = grid.cellBegin(c), a1 = grid.cellEnd(c);
    if (a0 == a1) return;
    CellBlock& block = blocks[static_cast<std::size_t>(threadIndex())];
    grid.gatherCell(c, r, block);
    for (std::uint32_t k = a0; k < a1; ++k) visit(k, block, block.filter(sx[k], sy[k], sz[k], r));
  };
  if (grid.size() < kSerialPointsBelow) {  // few points: not worth waking the team
    for (std::size_t c = 0; c < grid.cellCount(); ++c) cellWork(c);
  } else {
    const std::size_t chunk = std::clamp<std::size_t>(grid.cellCount() / (16 * blocks.size()), 1, 64);
    parallelForDynamic(grid.cellCount(), chunk, cellWork);
  }
}

}  // namespace swarmsim
