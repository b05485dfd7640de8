// The shape model's neighbour searches on the UniformGrid against nanoflann's
// exact k-d tree (Debian's libnanoflann-dev, header only).
//
// K nearest: driven exactly as the shape model drives it (models/shape/shape.cpp):
// the grid built with some cell, one forEachPointNeighbors pass with radius =
// that cell, blockKeys collecting the block's points j != k within
// min(rMax, coveredRadius), then nearestKeys(grid, k, K, that radius, hint,
// rMax, keys); the hints include 1.1 times the exact K-th distance, a bound
// like the one the model takes from the last step's neighbours. The reference is nanoflann's
// knnSearch (K + 1, the point itself dropped) filtered to d2 <= rMax^2. Both
// compute d2 in the same float arithmetic ((dx^2 + dy^2) + dz^2, the sign of
// dx does not matter for its square), so the sets must agree exactly; only
// equal distances at the K-th place may be broken differently (grid: by sorted
// position; k-d tree: by its own visit order), and the check allows exactly that.
//
// Fixed radius: the same pass, hits with d2 <= R^2 (F_con's Euclidean ball,
// which holds its Manhattan one), against radiusSearch.
//
// The rMax of each case is the 80th percentile of the exact K-th distances, so
// a fifth of the points have fewer than K within rMax; the cells range from a
// quarter of the median K-th distance (most points widen) to rMax (none do).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <catch2/catch.hpp>

#if SWARMSIM_HAVE_NANOFLANN
#include <nanoflann.hpp>

#include "spatial/nearest.hpp"
#include "spatial/uniform_grid.hpp"

namespace {

using swarmsim::CellBlock;
using swarmsim::UniformGrid;

struct Cloud {
  std::vector<float> x, y, z;
  std::size_t size() const { return x.size(); }
  void add(float a, float b, float c) {
    x.push_back(a);
    y.push_back(b);
    z.push_back(c);
  }
  // nanoflann's dataset interface
  std::size_t kdtree_get_point_count() const { return x.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return d == 0 ? x[i] : d == 1 ? y[i] : z[i]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;  // let the tree compute it
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, std::uint32_t>;

// uniform in the box [0, 10]^3
Cloud uniformBox(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 10.0f);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const float a = u(rng), b = u(rng);
    c.add(a, b, u(rng));
  }
  return c;
}

// a thin shell (radius 5, radial spread 0.05) and a few stragglers 8 to 30 away from its centre:
// dense on the shell, empty inside and out, so the cell that suits the shell is far too small
// for the stragglers, and their bounding box coarsens the grid
Cloud shellWithStragglers(std::size_t n, std::size_t stragglers, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::normal_distribution<float> radial(5.0f, 0.05f);
  std::uniform_real_distribution<float> far(8.0f, 30.0f);
  Cloud c;
  for (std::size_t i = 0; i < n + stragglers; ++i) {
    float a = g(rng), b = g(rng), d = g(rng);
    const float len = std::sqrt(a * a + b * b + d * d);
    const float r = i < n ? radial(rng) : far(rng);
    c.add(a / len * r, b / len * r, d / len * r);
  }
  return c;
}

// squared distance as both sides compute it
float dist2(const Cloud& c, std::uint32_t i, std::uint32_t j) {
  const float dx = c.x[j] - c.x[i], dy = c.y[j] - c.y[i], dz = c.z[j] - c.z[i];
  return dx * dx + dy * dy + dz * dz;
}

// exact K nearest of every point (original indices, itself excluded), ascending, unfiltered
std::vector<std::vector<std::uint32_t>> exactNearest(const Cloud& c, const KdTree& tree, std::size_t K) {
  std::vector<std::vector<std::uint32_t>> out(c.size());
  std::vector<std::uint32_t> idx(K + 1);
  std::vector<float> d2(K + 1);
  for (std::uint32_t i = 0; i < c.size(); ++i) {
    const float q[3] = {c.x[i], c.y[i], c.z[i]};
    const std::size_t m = tree.knnSearch(q, K + 1, idx.data(), d2.data());
    auto& nn = out[i];
    for (std::size_t a = 0; a < m; ++a) {
      if (idx[a] != i) nn.push_back(idx[a]);
    }
    if (nn.size() > K) nn.resize(K);  // the point was not among them (a duplicate at distance 0)
  }
  return out;
}

// the grid's K nearest within rMax of every point, as the shape model computes them, in original
// indices (per point, ascending by distance); flags which of forEachPointNeighbors' two branches ran
struct GridRun {
  std::vector<std::vector<std::uint32_t>> nearest;
  bool perPoint = false;  // the sparse branch: gathered per point, not per cell
};
GridRun gridNearest(const Cloud& c, float cell, std::size_t K, float rMax, const std::vector<float>& hint) {
  UniformGrid grid;
  grid.build(c.x.data(), c.y.data(), c.z.data(), c.size(), cell);
  const auto& order = grid.order();
  GridRun run;
  run.perPoint = 2 * grid.size() < grid.cellCount();
  run.nearest.resize(c.size());
  std::vector<CellBlock> blocks;
  std::vector<std::vector<std::uint64_t>> keysOf(static_cast<std::size_t>(swarmsim::threadCount()));
  swarmsim::forEachPointNeighbors(grid, cell, blocks, [&](std::uint32_t k, const CellBlock& block, std::size_t hits) {
    // as the shape model does: the block's candidates as far as the block is complete about the point
    (void)hits;
    std::vector<std::uint64_t>& keys = keysOf[static_cast<std::size_t>(swarmsim::threadIndex())];
    const float covered =
        std::min(rMax, grid.coveredRadius(block, grid.sortedX()[k], grid.sortedY()[k], grid.sortedZ()[k]));
    swarmsim::blockKeys(block, k, covered, keys);
    const std::uint32_t i = order[k];
    const std::size_t m = swarmsim::nearestKeys(grid, k, K, covered, hint[i], rMax, keys);
    auto& nn = run.nearest[i];  // each point writes only its own entry
    for (std::size_t q = 0; q < m; ++q) nn.push_back(order[swarmsim::keyIndex(keys[q])]);
  });
  return run;
}

// the value below which a fraction f of v lies
float quantile(std::vector<float> v, double f) {
  const auto q = static_cast<std::size_t>(f * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(q), v.end());
  return v[q];
}

// counts of one comparison, for the messages
struct Tally {
  std::size_t points = 0, mismatches = 0, ties = 0, short_ = 0, widened = 0;
};

// grid (got) and k-d tree (want, filtered to rMax here) neighbour lists of point i agree:
// the same distances in the same order, and the same set but for equal distances at the last place
bool sameNeighbours(const Cloud& c, std::uint32_t i, const std::vector<std::uint32_t>& got,
                    std::vector<std::uint32_t> want, float rMax, Tally& t) {
  want.erase(std::remove_if(want.begin(), want.end(), [&](std::uint32_t j) { return !(dist2(c, i, j) <= rMax * rMax); }),
             want.end());
  if (got.size() != want.size()) return false;
  for (std::size_t a = 0; a < got.size(); ++a) {
    if (dist2(c, i, got[a]) != dist2(c, i, want[a])) return false;
  }
  std::vector<std::uint32_t> g(got), w(want);
  std::sort(g.begin(), g.end());
  std::sort(w.begin(), w.end());
  if (g == w) return true;
  // a tie at the K-th distance may be broken either way: every differing index must lie at it
  const float last = dist2(c, i, got.back());
  std::vector<std::uint32_t> diff;
  std::set_symmetric_difference(g.begin(), g.end(), w.begin(), w.end(), std::back_inserter(diff));
  for (const std::uint32_t j : diff) {
    if (dist2(c, i, j) != last) return false;
  }
  ++t.ties;
  return true;
}

// every K in {1, 10, 40}, three cells and two hints on one cloud; flags which grid branches ran
void checkNearest(const Cloud& c, const std::string& name, bool& perPointSeen, bool& perCellSeen) {
  const KdTree tree(3, c, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  for (const std::size_t K : {std::size_t{1}, std::size_t{10}, std::size_t{40}}) {
    const auto exact = exactNearest(c, tree, K);
    std::vector<float> kth(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) kth[i] = std::sqrt(dist2(c, static_cast<std::uint32_t>(i), exact[i].back()));
    const float median = quantile(kth, 0.5), rMax = quantile(kth, 0.8);
    // hints: none (the model's first step) and the exact K-th distance (a converged run); the
    // result must not depend on them
    const std::vector<float> noHint(c.size(), 0.0f);
    std::vector<float> goodHint(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) goodHint[i] = std::min(rMax, 1.1f * kth[i]);
    for (const float cell : {0.25f * median, median, rMax}) {
      for (const std::vector<float>* hint : {&noHint, static_cast<const std::vector<float>*>(&goodHint)}) {
        const GridRun run = gridNearest(c, cell, K, rMax, *hint);
        (run.perPoint ? perPointSeen : perCellSeen) = true;
        Tally t;
        for (std::uint32_t i = 0; i < c.size(); ++i) {
          ++t.points;
          const auto& got = run.nearest[i];
          if (got.size() < K) ++t.short_;
          if (!got.empty() && dist2(c, i, got.back()) > cell * cell) ++t.widened;
          if (!sameNeighbours(c, i, got, exact[i], rMax, t)) {
            if (t.mismatches == 0) {
              INFO(name << " K=" << K << " cell=" << cell << " rMax=" << rMax << ": first mismatch at point " << i
                        << " (" << got.size() << " found, k-d tree " << exact[i].size() << " before the rMax filter)");
              CHECK(false);
            }
            ++t.mismatches;
          }
        }
        INFO(name << " K=" << K << " cell=" << cell << " (median K-th " << median << ") rMax=" << rMax
                  << (hint == &noHint ? " no hint" : " hint") << (run.perPoint ? " per-point" : " per-cell")
                  << ": " << t.mismatches << " of " << t.points << " differ, " << t.short_ << " have fewer than K, "
                  << t.widened << " needed a wider search, " << t.ties << " ties at the K-th place");
        CHECK(t.mismatches == 0);
        // the case is the one meant: some points short of K within rMax, some found beyond the first pass
        CHECK(t.short_ > 0);
        if (cell < median) CHECK(t.widened > 0);
      }
    }
  }
}

// the pass's fixed-radius hits (d2 <= R^2, itself excluded) against radiusSearch, plus the
// Manhattan subset F_con uses (|dx| + |dy| + |dz| < R), for a pass radius (the cell) >= R
void checkRadius(const Cloud& c, const std::string& name, float R, float cell) {
  const KdTree tree(3, c, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  UniformGrid grid;
  grid.build(c.x.data(), c.y.data(), c.z.data(), c.size(), cell);
  const auto& order = grid.order();
  std::vector<std::vector<std::uint32_t>> ball(c.size()), diamond(c.size());
  std::vector<CellBlock> blocks;
  swarmsim::forEachPointNeighbors(grid, cell, blocks, [&](std::uint32_t k, const CellBlock& block, std::size_t hits) {
    const std::uint32_t i = order[k];
    const float* sx = grid.sortedX().data();
    const float* sy = grid.sortedY().data();
    const float* sz = grid.sortedZ().data();
    for (std::size_t h = 0; h < hits; ++h) {
      const std::uint32_t b = block.hits[h];
      const std::uint32_t j = block.index[b];
      if (j == k || !(block.d2[b] <= R * R)) continue;
      ball[i].push_back(order[j]);
      const float m = std::abs(block.x[b] - sx[k]) + std::abs(block.y[b] - sy[k]) + std::abs(block.z[b] - sz[k]);
      if (m < R) diamond[i].push_back(order[j]);
    }
  });
  // nanoflann keeps d2 < radius: the next float above R^2 makes that d2 <= R^2, as the grid
  const float radius = std::nextafter(R * R, std::numeric_limits<float>::infinity());
  std::vector<std::pair<std::uint32_t, float>> found;
  std::size_t mismatches = 0, total = 0, manhattan = 0;
  for (std::uint32_t i = 0; i < c.size(); ++i) {
    const float q[3] = {c.x[i], c.y[i], c.z[i]};
    tree.radiusSearch(q, radius, found, nanoflann::SearchParams(32, 0.0f, false));
    std::vector<std::uint32_t> want, wantDiamond;
    for (const auto& f : found) {
      if (f.first == i) continue;
      want.push_back(f.first);
      const std::uint32_t j = f.first;
      if (std::abs(c.x[j] - c.x[i]) + std::abs(c.y[j] - c.y[i]) + std::abs(c.z[j] - c.z[i]) < R) wantDiamond.push_back(j);
    }
    std::sort(want.begin(), want.end());
    std::sort(wantDiamond.begin(), wantDiamond.end());
    std::sort(ball[i].begin(), ball[i].end());
    std::sort(diamond[i].begin(), diamond[i].end());
    total += want.size();
    manhattan += wantDiamond.size();
    if (ball[i] != want || diamond[i] != wantDiamond) {
      if (mismatches == 0) {
        INFO(name << " R=" << R << ": first mismatch at point " << i << " (grid " << ball[i].size() << " / "
                  << diamond[i].size() << ", k-d tree " << want.size() << " / " << wantDiamond.size() << ")");
        CHECK(false);
      }
      ++mismatches;
    }
  }
  INFO(name << " R=" << R << " cell=" << cell << ": " << mismatches << " of " << c.size() << " differ; " << total
            << " pairs within R, " << manhattan << " within Manhattan R");
  CHECK(mismatches == 0);
  CHECK(total > 0);
  CHECK(manhattan > 0);
}

}  // namespace

TEST_CASE("knn: grid K nearest = nanoflann kNN within rMax, uniform box", "[knn]") {
  bool perPoint = false, perCell = false;
  checkNearest(uniformBox(3000, 7), "box", perPoint, perCell);
  CHECK(perCell);
}

TEST_CASE("knn: grid K nearest = nanoflann kNN within rMax, shell with stragglers", "[knn]") {
  bool perPoint = false, perCell = false;
  checkNearest(shellWithStragglers(3000, 30, 11), "shell", perPoint, perCell);
  CHECK(perCell);
  // forEachPointNeighbors gathers per point only when the grid has over 2 cells per point, which
  // the build's cap (2 n + 64) leaves room for only at small n: a small swarm takes that branch
  perPoint = perCell = false;
  checkNearest(shellWithStragglers(150, 6, 13), "small shell", perPoint, perCell);
  CHECK(perPoint);
}

TEST_CASE("knn: grid fixed-radius pass = nanoflann radiusSearch", "[knn]") {
  const Cloud box = uniformBox(3000, 7);
  const Cloud shell = shellWithStragglers(3000, 30, 11);
  // mean spacing: box 10 / n^(1/3); shell sqrt(area / n); F_con's radius is k h with k = 2
  const float hBox = 10.0f / std::cbrt(3000.0f), hShell = std::sqrt(4.0f * 3.14159265f * 25.0f / 3000.0f);
  for (const float f : {1.0f, 1.5f}) {  // pass radius = R (F_con alone) and larger (the K-th distance's cell)
    checkRadius(box, "box", 2.0f * hBox, f * 2.0f * hBox);
    checkRadius(shell, "shell", 2.0f * hShell, f * 2.0f * hShell);
  }
}

#else

TEST_CASE("knn: grid against nanoflann (skipped: no nanoflann)", "[knn]") {
  WARN("nanoflann.hpp was not found at configure time (Debian: libnanoflann-dev): the grid is not checked against it");
}

#endif
