// knn_bench: the shape model's two neighbour searches on the project's UniformGrid
// against nanoflann's k-d tree (Debian's libnanoflann-dev), to answer "k-d tree or
// grid: which is faster". Not installed; not part of the swarmsim binary.
//
//   knn_bench [MESH.obj [N,N,...]]   (defaults: data/shapes/moon.obj of the source tree; 10000,100000,1000000)
//
// Points: N stratified samples of the mesh surface (the shape model's own
// sampleSurface, so the insects' targets), each moved by an isotropic Gaussian
// of 0.3 m: a swarm hovering about its shape. N = 10^4, 10^5, 10^6.
//
// Searches, as the shape model does them (models/shape/shape.cpp), K = 10:
//   knn     each point's K nearest within r_att = 3 m (the moon scenario's), itself excluded
//   radius  every point within k h (k = 2, h = sqrt(A / N) the sample spacing): F_con's
//           Euclidean ball, which holds its Manhattan threshold
//   both    the two at once: the model's one pass (grid), or the two queries per point (tree)
// Grid: UniformGrid::build + forEachPointNeighbors + blockKeys + nearestKeys as the model,
// cells of the median K-th distance (knn), k h (radius) or the larger of the two (both), and
// each point's search bound 1.1 x its exact K-th distance (standing in for the farthest of
// the last step's K; also without, as in the model's first step).
// Tree: build (leaf size 10 and 20; nanoflann 1.4 builds on one thread) + knnSearch
// (K + 1: the point finds itself) / radiusSearch (unsorted) for every point, in parallel.
// Both write one result per point (K-th distance or count), so neither is optimised away
// and the "pairs" column, the neighbours found in total, must agree between methods.
//
// Each method runs 5 times per (N, threads); the table gives the median build and
// query times and (build + query) / N.
#include <omp.h>

#include <algorithm>
#include <exception>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <nanoflann.hpp>

#include "core/parallel.hpp"
#include "geometry/mesh.hpp"
#include "models/shape/sampling.hpp"
#include "spatial/nearest.hpp"
#include "spatial/uniform_grid.hpp"

using namespace swarmsim;

namespace {

constexpr std::size_t K = 10;     // the shape model's default 'neighbours'
constexpr float kK = 2.0f;        // its default k (F_con's threshold k h)
constexpr float kRAtt = 3.0f;     // r_att of scenarios/moon.json: the K nearest are taken within it
constexpr double kJitter = 0.3;   // m, standard deviation per axis
constexpr int kRepetitions = 5;

struct Cloud {
  std::vector<float> x, y, z;
  std::size_t size() const { return x.size(); }
  // nanoflann's dataset interface
  std::size_t kdtree_get_point_count() const { return x.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return d == 0 ? x[i] : d == 1 ? y[i] : z[i]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;  // the tree computes it
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, std::uint32_t>;

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string firstLine(const char* command) {
  std::string out;
  if (FILE* p = popen(command, "r")) {
    char buf[512];
    while (fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown";
}

// N surface samples of the mesh, jittered; sampleSurface orders them along its
// triangles' Hilbert curve, so consecutive points are near (as the model's sorted insects)
Cloud makeCloud(const TriangleMesh& mesh, std::size_t n) {
  const auto samples = sampleSurface(mesh, n, 2019);
  Cloud c;
  c.x.resize(n);
  c.y.resize(n);
  c.z.resize(n);
  std::mt19937 rng(42);
  std::normal_distribution<double> g(0.0, kJitter);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3d p = surfacePoint(mesh, samples[i]);
    c.x[i] = static_cast<float>(p.x() + g(rng));
    c.y[i] = static_cast<float>(p.y() + g(rng));
    c.z[i] = static_cast<float>(p.z() + g(rng));
  }
  return c;
}

// the tree's K nearest of point i within rMax, itself excluded; returns how many and the last's d2
std::pair<std::size_t, float> treeNearest(const KdTree& tree, const Cloud& c, std::uint32_t i, float rMax2) {
  std::array<std::uint32_t, K + 1> idx;
  std::array<float, K + 1> d2;
  const float q[3] = {c.x[i], c.y[i], c.z[i]};
  const std::size_t found = tree.knnSearch(q, K + 1, idx.data(), d2.data());
  std::size_t m = 0;
  float last = 0.0f;
  for (std::size_t a = 0; a < found && m < K; ++a) {
    if (idx[a] == i || !(d2[a] <= rMax2)) continue;
    ++m;
    last = d2[a];
  }
  return {m, last};
}

// the tree's count of points within sqrt(r2) of point i (d2 <= r2), itself excluded
std::size_t treeRadius(const KdTree& tree, const Cloud& c, std::uint32_t i, float r2,
                       std::vector<std::pair<std::uint32_t, float>>& found) {
  // nanoflann keeps d2 < radius: the next float above r2 makes it d2 <= r2, as the grid
  const float radius = std::nextafter(r2, std::numeric_limits<float>::infinity());
  const float q[3] = {c.x[i], c.y[i], c.z[i]};
  return tree.radiusSearch(q, radius, found, nanoflann::SearchParams(32, 0.0f, false)) - 1;
}

struct Row {
  std::size_t n;
  int threads;
  std::string method;
  double buildMs, queryMs;
  std::uint64_t pairs;
};

void printRow(const Row& r) {
  std::printf("%8zu %7d  %-26s %10.2f %10.2f %10.1f %12llu\n", r.n, r.threads, r.method.c_str(), r.buildMs, r.queryMs,
              (r.buildMs + r.queryMs) * 1e6 / static_cast<double>(r.n), static_cast<unsigned long long>(r.pairs));
  std::fflush(stdout);
}

// run build() then query() kRepetitions times; the medians of each
Row timeMethod(std::size_t n, int threads, const std::string& method, const std::function<void()>& build,
               const std::function<std::uint64_t()>& query) {
  std::vector<double> b, q;
  std::uint64_t pairs = 0;
  for (int rep = 0; rep < kRepetitions; ++rep) {
    auto t0 = Clock::now();
    build();
    b.push_back(msSince(t0));
    t0 = Clock::now();
    pairs = query();
    q.push_back(msSince(t0));
  }
  return {n, threads, method, median(b), median(q), pairs};
}

std::uint64_t total(const std::vector<std::uint32_t>& count) {
  std::uint64_t s = 0;
  for (const std::uint32_t c : count) s += c;
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string meshPath = argc > 1 ? argv[1] : std::string(SWARMSIM_SOURCE_DIR) + "/data/shapes/moon.obj";
  std::printf("uptime: %s\n", firstLine("uptime").c_str());
  std::printf("cpu: %s (%d logical CPUs)\n", cpuModel().c_str(), omp_get_num_procs());
  std::printf("nanoflann: NANOFLANN_VERSION 0x%x\n", NANOFLANN_VERSION);

  TriangleMesh mesh;
  try {
    mesh = loadObj(meshPath);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "knn_bench: %s (usage: knn_bench [MESH.obj [N,N,...]])\n", e.what());
    return 2;
  }
  const double area = surfaceArea(mesh);
  std::printf("points: %s samples (area %.1f m^2) + Gaussian %.1f m per axis; K = %zu within r_att = %.1f m; "
              "radius k h, k = %.0f\n",
              meshPath.c_str(), area, kJitter, K, static_cast<double>(kRAtt), static_cast<double>(kK));

  const auto header = [] {
    std::printf("%8s %7s  %-26s %10s %10s %10s %12s\n", "N", "threads", "method", "build ms", "query ms", "ns/pt",
                "pairs");
  };
  std::vector<std::size_t> sizes = {10000, 100000, 1000000};
  if (argc > 2) {
    sizes.clear();
    for (const char* p = argv[2]; *p;) {
      char* end = nullptr;
      const unsigned long long v = std::strtoull(p, &end, 10);
      if (end == p || v < 2) {
        std::fprintf(stderr, "knn_bench: expected N,N,... (each >= 2), got \"%s\"\n", argv[2]);
        return 2;
      }
      sizes.push_back(static_cast<std::size_t>(v));
      p = *end == ',' ? end + 1 : end;
    }
  }
  std::vector<Row> rows;
  for (const std::size_t n : sizes) {
    const Cloud c = makeCloud(mesh, n);
    const float h = static_cast<float>(std::sqrt(area / static_cast<double>(n)));
    const float kh = kK * h, kh2 = kh * kh, rMax2 = kRAtt * kRAtt;

    // untimed: the exact K-th distances (the model's last step), their median (the knn cell)
    // and each point's widening hint
    setThreadCount(omp_get_num_procs());
    std::vector<float> reach(n);
    {
      const KdTree tree(3, c, nanoflann::KDTreeSingleIndexAdaptorParams(10));
      parallelForDynamic(n, 256, [&](std::size_t i) {
        const auto [m, d2] = treeNearest(tree, c, static_cast<std::uint32_t>(i), rMax2);
        reach[i] = m == K ? std::sqrt(d2) : kRAtt;
      });
    }
    std::vector<float> scratch(reach);
    std::nth_element(scratch.begin(), scratch.begin() + static_cast<std::ptrdiff_t>(n / 2), scratch.end());
    const float cellKnn = std::min(kRAtt, scratch[n / 2]);
    const float cellBoth = std::max(kh, cellKnn);
    std::vector<float> hint(n);
    for (std::size_t i = 0; i < n; ++i) hint[i] = 1.1f * reach[i];
    const std::vector<float> noHint(n, 0.0f);
    std::size_t widened = 0;
    for (const float r : reach) widened += r > cellKnn ? 1 : 0;
    std::printf("\nN = %zu: h = %.4f m, k h = %.4f m, median K-th distance (knn cell) = %.4f m, "
                "both cell = %.4f m; %.1f%% of points have their K-th beyond the knn cell\n",
                n, static_cast<double>(h), static_cast<double>(kh), static_cast<double>(cellKnn),
                static_cast<double>(cellBoth), 100.0 * static_cast<double>(widened) / static_cast<double>(n));

    header();
    for (const int threads : {1, 2}) {
      setThreadCount(threads);
      const auto T = static_cast<std::size_t>(threads);
      std::vector<std::uint32_t> count(n);  // per point: neighbours found
      std::vector<float> kth(n);            // per point: the K-th's squared distance
      // per-thread scratch, sized before timing so the timed loops do not allocate
      std::vector<std::vector<std::pair<std::uint32_t, float>>> found(T);
      for (auto& f : found) f.reserve(4096);
      std::vector<std::vector<std::uint64_t>> keysOf(T);
      for (auto& k : keysOf) k.reserve(4096);
      std::vector<CellBlock> blocks;
      UniformGrid grid;  // kept across repetitions, as the model keeps it across steps

      for (const std::size_t leaf : {std::size_t{10}, std::size_t{20}}) {
        std::unique_ptr<KdTree> tree;
        const auto buildTree = [&] {
          tree.reset();
          tree = std::make_unique<KdTree>(3, c, nanoflann::KDTreeSingleIndexAdaptorParams(leaf));
        };
        const std::string name = "kd-tree leaf " + std::to_string(leaf);
        rows.push_back(timeMethod(n, threads, name + " knn", buildTree, [&] {
          parallelForDynamic(n, 256, [&](std::size_t i) {
            const auto [m, d2] = treeNearest(*tree, c, static_cast<std::uint32_t>(i), rMax2);
            count[i] = static_cast<std::uint32_t>(m);
            kth[i] = d2;
          });
          return total(count);
        }));
        printRow(rows.back());
        rows.push_back(timeMethod(n, threads, name + " radius", buildTree, [&] {
          parallelForDynamic(n, 256, [&](std::size_t i) {
            count[i] = static_cast<std::uint32_t>(
                treeRadius(*tree, c, static_cast<std::uint32_t>(i), kh2, found[static_cast<std::size_t>(threadIndex())]));
          });
          return total(count);
        }));
        printRow(rows.back());
        rows.push_back(timeMethod(n, threads, name + " both", buildTree, [&] {
          parallelForDynamic(n, 256, [&](std::size_t i) {
            const auto [m, d2] = treeNearest(*tree, c, static_cast<std::uint32_t>(i), rMax2);
            kth[i] = d2;
            count[i] = static_cast<std::uint32_t>(m) +
                       static_cast<std::uint32_t>(treeRadius(*tree, c, static_cast<std::uint32_t>(i), kh2,
                                                             found[static_cast<std::size_t>(threadIndex())]));
          });
          return total(count);
        }));
        printRow(rows.back());
      }

      // the grid as the shape model drives it: one pass over each cell's 27-cell neighbourhood
      // collecting the keys within the bound where the block is complete that far, then nearestKeys
      // (one search at the bound, or widening without one)
      const auto gridPass = [&](float cell, bool knn, bool radius, const std::vector<float>& hints) {
        forEachPointNeighbors(grid, cell, blocks, [&](std::uint32_t k, const CellBlock& block, std::size_t hits) {
          std::vector<std::uint64_t>& keys = keysOf[static_cast<std::size_t>(threadIndex())];
          std::uint32_t within = 0;
          for (std::size_t hh = 0; hh < hits; ++hh) {
            const std::uint32_t b = block.hits[hh];
            within += block.index[b] != k && block.d2[b] <= kh2 ? 1u : 0u;
          }
          std::uint32_t m = 0;
          if (knn) {
            const float covered =
                std::min(kRAtt, grid.coveredRadius(block, grid.sortedX()[k], grid.sortedY()[k], grid.sortedZ()[k]));
            const float bound = hints[grid.order()[k]];
            const float r = std::min(covered, bound > 0.0f ? bound : covered);
            blockKeys(block, k, r, keys);
            m = static_cast<std::uint32_t>(nearestKeys(grid, k, K, r, bound, kRAtt, keys));
            kth[k] = m > 0 ? keyDistance2(keys[m - 1]) : 0.0f;
          }
          count[k] = m + (radius ? within : 0u);
        });
        return total(count);
      };
      const auto buildGrid = [&](float cell) {
        return [&grid, &c, cell] { grid.build(c.x.data(), c.y.data(), c.z.data(), c.size(), cell); };
      };
      rows.push_back(timeMethod(n, threads, "grid knn", buildGrid(cellKnn),
                                [&] { return gridPass(cellKnn, true, false, hint); }));
      printRow(rows.back());
      // the model's first step: no K-th distances yet, so the short half widens by doubling from the cell
      rows.push_back(timeMethod(n, threads, "grid knn, no hint", buildGrid(cellKnn),
                                [&] { return gridPass(cellKnn, true, false, noHint); }));
      printRow(rows.back());
      rows.push_back(timeMethod(n, threads, "grid radius", buildGrid(kh), [&] { return gridPass(kh, false, true, hint); }));
      printRow(rows.back());
      rows.push_back(timeMethod(n, threads, "grid both (model pass)", buildGrid(cellBoth),
                                [&] { return gridPass(cellBoth, true, true, hint); }));
      printRow(rows.back());
    }
  }

  std::printf("\nsummary (median of %d; ns/pt = (build + query) / N; pairs = neighbours found in total)\n",
              kRepetitions);
  header();
  for (const Row& r : rows) printRow(r);
  std::printf("uptime: %s\n", firstLine("uptime").c_str());
  return 0;
}
