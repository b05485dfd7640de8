#include "models/shape/sampling.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"

namespace swarmsim {
namespace {

double triangleArea(const TriangleMesh& mesh, std::size_t t) {
  const auto& f = mesh.triangles[t];
  const Vec3d& a = mesh.vertices.at(f[0]);
  return 0.5 * (mesh.vertices.at(f[1]) - a).cross(mesh.vertices.at(f[2]) - a).norm();
}

// Hilbert index of a cell of the 2^kHilbertBits grid per axis (Skilling 2004,
// "Programming the Hilbert curve": the axes are turned into the curve's
// "transpose", whose bits interleaved are the index). Cells with consecutive
// indices share a face, which a Morton order does not guarantee.
constexpr int kHilbertBits = 21;
std::uint64_t hilbertIndex(std::uint32_t x0, std::uint32_t x1, std::uint32_t x2) {
  std::uint32_t x[3] = {x0, x1, x2};
  const std::uint32_t top = 1u << (kHilbertBits - 1);
  for (std::uint32_t q = top; q > 1; q >>= 1) {  // undo the excess work of the inverse transform
    const std::uint32_t p = q - 1;
    for (int i = 0; i < 3; ++i) {
      if (x[i] & q) {
        x[0] ^= p;  // invert
      } else {
        const std::uint32_t t = (x[0] ^ x[i]) & p;  // exchange
        x[0] ^= t;
        x[i] ^= t;
      }
    }
  }
  for (int i = 1; i < 3; ++i) x[i] ^= x[i - 1];  // Gray encode
  std::uint32_t t = 0;
  for (std::uint32_t q = top; q > 1; q >>= 1) {
    if (x[2] & q) t ^= q - 1;
  }
  std::uint64_t index = 0;
  for (int b = kHilbertBits - 1; b >= 0; --b) {
    for (int i = 0; i < 3; ++i) index = (index << 1) | (((x[i] ^ t) >> b) & 1u);
  }
  return index;
}

// the random stream of stratum j: word 0 places the stratum's sample along the
// sub-triangles, words 1-2 place it inside its sub-triangle
AgentRng stratumRng(std::uint64_t seed, std::size_t j) {
  return AgentRng(seed, static_cast<std::uint64_t>(j) >> 32, static_cast<std::uint32_t>(j), RngPurpose::kSurfaceSample);
}

// the first stratum j whose sample position j + xi_j lies at or after s
// (strata before floor(s) end before s)
std::size_t firstStratumFrom(double s, std::size_t n, std::uint64_t seed) {
  if (!(s > 0.0)) return 0;
  const double whole = std::floor(s);
  if (whole >= static_cast<double>(n)) return n;
  const auto j = static_cast<std::size_t>(whole);
  return static_cast<double>(j) + stratumRng(seed, j).uniform() >= s ? j : j + 1;
}

// smallest k >= 1 with k^2 >= m
std::uint64_t ceilSqrt(std::uint64_t m) {
  auto k = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::sqrt(static_cast<double>(m))));
  while (k * k < m) ++k;
  while (k > 1 && (k - 1) * (k - 1) >= m) --k;
  return k;
}

// A uniform point (r1, r2 uniform in [0, 1)) in sub-triangle idx of the k-grid
// that cuts the barycentric triangle u, v >= 0, u + v <= 1 into k^2 congruent
// ones. Row j (v between j / k and (j + 1) / k) holds 2 (k - j) - 1 of them,
// alternately pointing up and down; rows are walked in a snake (odd rows right
// to left), so consecutive indices touch.
void subTrianglePoint(std::uint64_t idx, std::uint64_t k, float r1, float r2, float& u, float& v) {
  // the rows before row j hold j (2k - j) = k^2 - (k - j)^2 sub-triangles
  const std::uint64_t j = k - ceilSqrt(k * k - idx);
  std::uint64_t q = idx - (k * k - (k - j) * (k - j));
  if (j % 2 == 1) q = 2 * (k - j) - 2 - q;
  const auto i = static_cast<double>(q / 2);
  double a = r1, b = r2;
  if (a + b > 1.0) {  // fold the unit square onto the lower triangle: uniform there
    a = 1.0 - a;
    b = 1.0 - b;
  }
  const double kk = static_cast<double>(k), jj = static_cast<double>(j);
  const bool up = q % 2 == 0;  // corners (i, j), (i + 1, j), (i, j + 1); else (i + 1, j + 1) minus those offsets
  u = static_cast<float>(up ? (i + a) / kk : (i + 1.0 - a) / kk);
  v = static_cast<float>(up ? (jj + b) / kk : (jj + 1.0 - b) / kk);
  v = std::min(v, 1.0f - u);  // u + v <= 1 also after rounding to float
}

}  // namespace

double surfaceArea(const TriangleMesh& mesh) {
  double area = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) area += triangleArea(mesh, t);
  return area;
}

Vec3d surfacePoint(const TriangleMesh& mesh, const SurfacePoint& s) {
  if (s.triangle >= mesh.triangles.size()) {
    throw std::out_of_range("surfacePoint: triangle " + std::to_string(s.triangle) + " of a mesh with " +
                            std::to_string(mesh.triangles.size()));
  }
  const auto& f = mesh.triangles[s.triangle];
  const Vec3d& a = mesh.vertices.at(f[0]);
  return a + double(s.u) * (mesh.vertices.at(f[1]) - a) + double(s.v) * (mesh.vertices.at(f[2]) - a);
}

std::vector<SurfacePoint> sampleSurface(const TriangleMesh& mesh, std::size_t n, std::uint64_t seed) {
  const std::size_t triangles = mesh.triangles.size();
  if (triangles == 0) throw InputError(mesh.source + ": cannot sample a mesh without triangles");
  if (triangles > std::numeric_limits<std::uint32_t>::max()) {
    throw InputError(mesh.source + ": too many triangles to sample (" + std::to_string(triangles) + ")");
  }
  for (std::size_t t = 0; t < triangles; ++t) {
    for (const std::uint32_t v : mesh.triangles[t]) {
      if (v >= mesh.vertices.size()) {
        throw InputError(mesh.source + ": triangle " + std::to_string(t) + " uses vertex " + std::to_string(v) +
                         " of " + std::to_string(mesh.vertices.size()));
      }
    }
  }
  // areas and centroids; triangles of zero area take no part
  std::vector<double> area(triangles);
  std::vector<Vec3d> centroid(triangles);
  parallelFor(triangles, [&](std::size_t t) {
    area[t] = triangleArea(mesh, t);
    const auto& f = mesh.triangles[t];
    centroid[t] = (mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]) / 3.0;
  });
  double total = 0.0;
  for (const double a : area) total += a;
  if (!(total > 0.0) || !std::isfinite(total)) {
    throw InputError(mesh.source + ": cannot sample a mesh of zero (or non-finite) surface area");
  }
  if (n == 0) return {};

  // the triangles in the Hilbert order of their centroids (a cube grid over
  // the centroids' bounding box; ties by index)
  Eigen::AlignedBox3d box;
  for (std::size_t t = 0; t < triangles; ++t) {
    if (area[t] > 0.0) box.extend(centroid[t]);
  }
  const double extent = box.sizes().maxCoeff();
  const double scale = extent > 0.0 ? ((1u << kHilbertBits) - 1) / extent : 0.0;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
  order.reserve(triangles);
  for (std::size_t t = 0; t < triangles; ++t) {
    if (!(area[t] > 0.0)) continue;
    const Vec3d q = (centroid[t] - box.min()) * scale;
    order.emplace_back(hilbertIndex(static_cast<std::uint32_t>(q.x()), static_cast<std::uint32_t>(q.y()),
                                    static_cast<std::uint32_t>(q.z())),
                       static_cast<std::uint32_t>(t));
  }
  std::sort(order.begin(), order.end());

  // Laid end to end in that order, triangle r covers [start[r], start[r + 1])
  // of [0, n), a length of area / total * n (its expected number of samples).
  // It is cut into k^2 sub-triangles (k^2 >= that length), each covering an
  // equal part of the interval, in snake order. Stratum j's sample position
  // j + xi_j picks the triangle and the sub-triangle; the sample is uniform in
  // the sub-triangle. Triangle r receives the strata first[r] <= j < first[r + 1].
  const std::size_t used = order.size();
  std::vector<double> start(used + 1);
  {
    const double perArea = static_cast<double>(n) / total;
    double sum = 0.0;
    for (std::size_t r = 0; r < used; ++r) {
      start[r] = sum * perArea;
      sum += area[order[r].second];
    }
    start[used] = static_cast<double>(n);  // exactly, whatever the rounding of the sum
  }
  std::vector<std::size_t> first(used + 1);
  parallelFor(used, [&](std::size_t r) { first[r] = firstStratumFrom(start[r], n, seed); });
  first[used] = n;

  // every stratum's sample; chunks walk the triangles from a binary search,
  // each sample is a function of its stratum alone
  std::vector<SurfacePoint> out(n);
  parallelChunks(n, [&](std::size_t begin, std::size_t end, int) {
    if (begin == end) return;
    // the triangle whose strata contain `begin`: the last r with first[r] <= begin
    std::size_t r = static_cast<std::size_t>(std::upper_bound(first.begin(), first.end(), begin) - first.begin()) - 1;
    for (std::size_t j = begin; j < end;) {
      while (first[r + 1] <= j) ++r;
      const double s = start[r], length = start[r + 1] - start[r];
      const std::uint64_t k = ceilSqrt(static_cast<std::uint64_t>(std::ceil(length))), cells = k * k;
      const std::uint32_t t = order[r].second;
      for (const std::size_t stop = std::min(end, first[r + 1]); j < stop; ++j) {
        AgentRng rng = stratumRng(seed, j);
        const double x = static_cast<double>(j) + rng.uniform();  // in [s, s + length) by construction of first
        const auto idx =
            std::min<std::uint64_t>(cells - 1, static_cast<std::uint64_t>((x - s) / length * static_cast<double>(cells)));
        const float r1 = rng.uniform(), r2 = rng.uniform();
        SurfacePoint& p = out[j];
        p.triangle = t;
        subTrianglePoint(idx, k, r1, r2, p.u, p.v);
      }
    }
  });
  return out;
}

}  // namespace swarmsim
