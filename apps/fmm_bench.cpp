// fmm_bench: our fast marching (lib/fields/fast_marching.hpp) on the test grids that
// scripts/fmm_compare.py also gives Debian's scikit-fmm, printed as one JSON line. A
// developer tool, not installed; not part of the swarmsim binary.
//
//   fmm_bench CASE N ORDER [REPEAT [heap]]
//
// (heap: order 1 by the heap instead of the waves, FastMarchingInput::heap; the same values)
//
// The unit cube in N^3 cells of edge h = 1/N, cost 1 (C is a distance), c the centre of the cell
// holding (0.3, 0.4, 0.55):
//   point  the cell of c is the one goal cell (C = 0); exact C = |x - c|
//   band   the same, and every cell with |x - c| <= 2h starts at its exact distance (the
//          information scikit-fmm's start band gets from a level set through c)
//   ball   every cell with |x - c| <= 0.2 starts at its exact distance: a smooth solution outside
//   sphere every cell with |x - c| <= 0.2 is a goal cell (C = 0), as a field model's spherical goal;
//          exact C = |x - c| - 0.2
// Output: {"case", "n", "order", "seconds" (median of REPEAT solves), "max_cells", "mean_cells", "method"}:
// the largest and the mean |C - exact| over the cells outside the start values and goals, in cells; how the
// solve went (FastMarchingReport: "heap", "waves" or "waves+heap", and the number of waves).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <string>
#include <vector>

#include "fields/fast_marching.hpp"

int main(int argc, char** argv) {
  using swarmsim::GridSpec;
  using swarmsim::Vec3d;
  if (argc < 4) {
    std::fprintf(stderr, "usage: fmm_bench point|band|ball|sphere N ORDER [REPEAT [heap]]\n");
    return 2;
  }
  try {
    const std::string which = argv[1];
    const int n = std::atoi(argv[2]), order = std::atoi(argv[3]);
    const int repeat = argc > 4 ? std::max(1, std::atoi(argv[4])) : 3;
    const bool heap = argc > 5 && std::string(argv[5]) == "heap";
    if ((which != "point" && which != "band" && which != "ball" && which != "sphere") || n < 4 || n > 1024 ||
        (order != 1 && order != 2)) {
      std::fprintf(stderr, "fmm_bench: expected point|band|ball|sphere, N in [4, 1024], ORDER 1 or 2\n");
      return 2;
    }
    const GridSpec spec = GridSpec::covering(Vec3d(0, 0, 0), Vec3d(1, 1, 1), {n, n, n});
    const double h = spec.cell[0];
    swarmsim::FastMarchingInput in;
    in.spec = spec;
    in.order = order;
    in.heap = heap;
    in.cost.assign(spec.size(), 1.0f);
    in.goal.assign(spec.size(), 0);
    const auto g = spec.cellOf(Vec3d(0.3, 0.4, 0.55));
    const Vec3d c = spec.center(g[0], g[1], g[2]);
    const double startRadius = which == "band" ? 2.0 * h * (1.0 + 1e-9) : which == "ball" ? 0.2 : -1.0;
    const double goalRadius = which == "sphere" ? 0.2 : 0.0;  // (exact C: the distance to that sphere)
    std::vector<char> started(spec.size(), 0);
    if (which != "ball") in.goal[spec.index(g[0], g[1], g[2])] = 1;
    started[spec.index(g[0], g[1], g[2])] = which != "ball";
    if (goalRadius > 0.0) {
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            if ((spec.center(i, j, k) - c).norm() > goalRadius) continue;
            in.goal[spec.index(i, j, k)] = 1;
            started[spec.index(i, j, k)] = 1;
          }
    }
    if (startRadius > 0.0) {
      in.start.assign(spec.size(), std::numeric_limits<float>::infinity());
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const double d = (spec.center(i, j, k) - c).norm();
            if (d <= startRadius) {
              in.start[spec.index(i, j, k)] = static_cast<float>(d);
              started[spec.index(i, j, k)] = 1;
            }
          }
    }
    std::vector<double> seconds;
    swarmsim::Grid3<float> C;
    swarmsim::FastMarchingReport report;
    for (int r = 0; r < repeat; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      C = swarmsim::fastMarching(in, &report);
      seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(seconds.begin(), seconds.end());
    double maxErr = 0.0, sumErr = 0.0;
    std::size_t count = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          if (started[spec.index(i, j, k)]) continue;
          const double exact = (spec.center(i, j, k) - c).norm() - goalRadius;
          const double e = std::abs(static_cast<double>(C.at(i, j, k)) - exact);
          maxErr = std::max(maxErr, e);
          sumErr += e;
          ++count;
        }
    const char* method = !report.waved ? "heap" : report.handedOver ? "waves+heap" : "waves";
    std::printf(
        "{\"case\": \"%s\", \"n\": %d, \"order\": %d, \"seconds\": %.6f, \"max_cells\": %.6f, \"mean_cells\": %.6f, "
        "\"method\": \"%s\", \"waves\": %d}\n",
        which.c_str(), n, order, seconds[seconds.size() / 2], maxErr / h, sumErr / static_cast<double>(count) / h,
        method, report.waves);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fmm_bench: %s\n", e.what());
    return 1;
  }
}
