// Batch noise (lib/fields/noise.hpp withGradientLanes, curl_noise.hpp curlRawBatch, noise_field.hpp
// evaluateBatch): equal bit for bit to the scalar code, on AVX and on SSE2 lanes, at random points, lattice
// planes, signed zeros and large coordinates, near the boundary and away from it, for any count of points.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <cstring>
#include <string>
#include <vector>

#include "core/world.hpp"
#include "fields/curl_noise.hpp"
#include "fields/noise.hpp"
#include "fields/noise_field.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "test_util.hpp"

using swarmsim::Aabb;
using swarmsim::GridSpec;
using swarmsim::NoiseField;
using swarmsim::NoiseFieldKind;
using swarmsim::NoiseParams;
using swarmsim::PerlinNoise3;
using swarmsim::Vec3;
using swarmsim::Vec3d;

namespace {

constexpr int kLanes = PerlinNoise3::kLanes;

// deterministic test values: a 64-bit LCG mapped to [lo, hi)
struct Lcg {
  std::uint64_t s;
  double uniform(double lo, double hi) {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (hi - lo) * static_cast<double>(s >> 11) * (1.0 / 9007199254740992.0);
  }
  int below(int n) { return static_cast<int>(uniform(0.0, n)); }
};

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// whether this CPU can run the AVX lanes (else both runs below take the SSE2 ones)
bool cpuHasAvx() {
#if defined(__GNUC__) && defined(__x86_64__)
  return __builtin_cpu_supports("avx");
#else
  return false;
#endif
}

// SWARMSIM_NO_AVX set for its lifetime, and then restored to what it was
struct NoAvxGuard {
  swarmsim_test::EnvGuard env{"SWARMSIM_NO_AVX", "1"};
};

// SWARMSIM_NO_AVX512 set for its lifetime when `on` (and then restored)
struct NoAvx512Guard {
  std::optional<swarmsim_test::EnvGuard> env;
  explicit NoAvx512Guard(bool set) {
    if (set) env.emplace("SWARMSIM_NO_AVX512", "1");
  }
};

// lattice coordinates that stress the cell and offset: random ones (both signs, beyond the period 256), lattice
// planes, signed zeros, the smallest magnitudes, halves (ties of the rounding in floorLanes) and large magnitudes
// around 2^52, beyond which every double is an integer
double latticeCoordinate(Lcg& rng) {
  // magnitudes, of either sign: zero, the smallest subnormal, tiny, the double below 1, lattice planes and
  // halves, and around 2^51, 2^52 and 2^60
  constexpr double k52 = 4503599627370496.0;
  static const double magnitude[] = {
      0.0,   4.9e-324, 1e-300, 0.99999999999999989, 0.5,       1.0, 1.5,       2.5,
      255.0, 256.0,    257.0,  0.5 * k52 - 0.25,    k52 - 0.5, k52, k52 + 1.0, 256.0 * k52};
  const int pick = rng.below(10);
  if (pick < 5) return rng.uniform(-600.0, 600.0);
  if (pick < 7) return std::floor(rng.uniform(-600.0, 600.0));
  if (pick < 8) return rng.uniform(-1e15, 1e15);
  const double m = magnitude[rng.below(static_cast<int>(sizeof magnitude / sizeof magnitude[0]))];
  return rng.below(2) == 0 ? m : -m;
}

// withGradientLanes at kLanes points against withGradient at each: every value (clamped) and every gradient
// component of every noise must have the same bits
void checkLanes(const PerlinNoise3* noises, int count, Lcg& rng, bool avx, int batches) {
  int mismatches = 0;
  for (int b = 0; b < batches; ++b) {
    double p[3][kLanes];
    for (auto& axis : p)
      for (double& c : axis) c = latticeCoordinate(rng);
    std::vector<double> value(static_cast<std::size_t>(count * kLanes)), g[3];
    for (auto& gi : g) gi.assign(value.size(), 0.0);
    PerlinNoise3::withGradientLanes(noises, count, p[0], p[1], p[2], value.data(), g[0].data(), g[1].data(),
                                    g[2].data(), avx);
    for (int k = 0; k < count; ++k) {
      for (int l = 0; l < kLanes; ++l) {
        Vec3d grad;
        const double v = noises[k].withGradient(Vec3d(p[0][l], p[1][l], p[2][l]), grad);
        const auto i = static_cast<std::size_t>(k * kLanes + l);
        const bool same = sameBits(v, value[i]) && sameBits(grad.x(), g[0][i]) && sameBits(grad.y(), g[1][i]) &&
                          sameBits(grad.z(), g[2][i]);
        if (!same && ++mismatches <= 5) {
          UNSCOPED_INFO("noise " << k << " at (" << p[0][l] << ", " << p[1][l] << ", " << p[2][l] << "): value " << v
                                 << " vs " << value[i] << ", gradient (" << grad.transpose() << ") vs (" << g[0][i]
                                 << " " << g[1][i] << " " << g[2][i] << ")");
        }
      }
    }
  }
  CHECK(mismatches == 0);
}

// n points of a domain [-20, 20]^3 with obstacles: uniform ones (some beyond the domain), points on lattice
// planes (coordinates on even metres with the lattice of 2 m below), signed zeros, and points within a metre
// of the sphere's surface, where the field blends toward it
struct Points {
  std::vector<float> x, y, z;
};
Points testPoints(std::size_t n, std::uint64_t seed) {
  Points p;
  Lcg rng{seed};
  for (std::size_t i = 0; i < n; ++i) {
    float c[3];
    const int pick = rng.below(10);
    for (float& ci : c) ci = static_cast<float>(rng.uniform(-22.0, 22.0));
    if (pick < 3) {
      // one to three coordinates on a lattice plane
      for (float& ci : c) {
        if (rng.below(2) == 0) ci = static_cast<float>(2 * (rng.below(21) - 10));
      }
    } else if (pick < 4) {
      for (float& ci : c) {
        if (rng.below(2) == 0) ci = rng.below(2) == 0 ? 0.0f : -0.0f;
      }
    } else if (pick < 6) {
      // near the sphere (centre (3, -2, 1), radius 6)
      const double th = rng.uniform(0.0, 3.14159265), ph = rng.uniform(0.0, 6.2831853), r = rng.uniform(5.0, 8.0);
      c[0] = static_cast<float>(3.0 + r * std::sin(th) * std::cos(ph));
      c[1] = static_cast<float>(-2.0 + r * std::sin(th) * std::sin(ph));
      c[2] = static_cast<float>(1.0 + r * std::cos(th));
    }
    p.x.push_back(c[0]);
    p.y.push_back(c[1]);
    p.z.push_back(c[2]);
  }
  return p;
}

// how many of the n points (from `first`) evaluateBatch gives differently from operator() (bit for bit), and
// that it writes nothing beyond them
int batchMismatches(const NoiseField& field, const Points& p, std::size_t first, std::size_t n) {
  const float sentinel = 12345.0f;
  std::vector<float> o[3];
  for (auto& oi : o) oi.assign(n + 1, sentinel);
  field.evaluateBatch(p.x.data() + first, p.y.data() + first, p.z.data() + first, n, o[0].data(), o[1].data(),
                      o[2].data());
  int bad = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = first + i;
    const Vec3 want = field(Vec3(p.x[j], p.y[j], p.z[j]));
    const float got[3] = {o[0][i], o[1][i], o[2][i]};
    if (std::memcmp(want.data(), got, sizeof got) != 0 && ++bad <= 5) {
      UNSCOPED_INFO("at (" << p.x[j] << ", " << p.y[j] << ", " << p.z[j] << "): operator() (" << want.transpose()
                           << "), batch (" << got[0] << " " << got[1] << " " << got[2] << ")");
    }
  }
  for (const auto& oi : o) bad += oi[n] != sentinel;
  return bad;
}

// the test domain's obstacles (a sphere and a box) and their distance with the domain's walls
struct Scene {
  Aabb domain{Vec3d(-20, -20, -20), Vec3d(20, 20, 20)};
  swarmsim::Obstacles obstacles;
  swarmsim::Grid3<float> boundary;
  Scene() {
    obstacles.spheres.push_back({Vec3d(3, -2, 1), 6.0});
    obstacles.boxes.push_back({Vec3d(-16, -16, -16), Vec3d(-10, -12, 4)});
    boundary = swarmsim::signedDistance(obstacles, GridSpec::covering(domain.min, domain.max, {64, 64, 64}));
    swarmsim::addBoxWalls(boundary, domain);
  }
};

NoiseParams testParams() {
  NoiseParams np;
  np.scale = 1.0;
  np.unit = 2.0;  // lattice cells of 2 m: even coordinates lie on lattice planes
  np.gain = 0.7;
  np.seeds = {7, 8, 9};
  np.d0 = 1.0;
  return np;
}

// every count that is not a multiple of the lanes (and some that are), at several offsets, then all the points
void checkBatch(const NoiseField& field, const Points& p) {
  for (const std::size_t n : {0, 1, 3, 4, 5, 8, 17, 64, 65, 129}) {
    for (const std::size_t first : {0, 1, 6, 999}) {
      INFO("n " << n << " from " << first);
      CHECK(batchMismatches(field, p, first, n) == 0);
    }
  }
  CHECK(batchMismatches(field, p, 0, p.x.size()) == 0);
}

}  // namespace

TEST_CASE("Perlin noise on SIMD lanes equals withGradient bit for bit", "[noise][fields]") {
  const PerlinNoise3 noises[3] = {PerlinNoise3(11), PerlinNoise3(12), PerlinNoise3(0xDEADBEEF)};
  Lcg rng{3};
  SECTION("SSE2") {
    checkLanes(noises, 3, rng, false, 3000);
    checkLanes(noises + 2, 1, rng, false, 500);
  }
  SECTION("AVX") {
    if (!cpuHasAvx()) {
      WARN("this CPU has no AVX: its lanes are not tested");
      return;
    }
    checkLanes(noises, 3, rng, true, 3000);
    checkLanes(noises + 2, 1, rng, true, 500);
  }
  SECTION("without the value") {
    // value may be null; the gradients are the same
    double p[3][kLanes] = {{0.25, -3.5, 17.0, -0.0}, {1.0, 2.5, -7.75, 300.125}, {-0.5, 0.0, 9.5, -255.5}};
    double g1[3][3 * kLanes], g2[3][3 * kLanes], v[3 * kLanes];
    for (const bool avx : {false, cpuHasAvx()}) {
      PerlinNoise3::withGradientLanes(noises, 3, p[0], p[1], p[2], v, g1[0], g1[1], g1[2], avx);
      PerlinNoise3::withGradientLanes(noises, 3, p[0], p[1], p[2], nullptr, g2[0], g2[1], g2[2], avx);
      CHECK(std::memcmp(g1, g2, sizeof g1) == 0);
    }
  }
}

TEST_CASE("Perlin noise on eight AVX-512 lanes equals withGradient bit for bit", "[noise][fields]") {
  if (!PerlinNoise3::batchWide()) {
    WARN("no AVX-512 here (or SWARMSIM_NO_AVX512 set): the wide lanes are not tested");
    return;
  }
  constexpr int kWide = PerlinNoise3::kWideLanes;
  const PerlinNoise3 noises[4] = {PerlinNoise3(11), PerlinNoise3(12), PerlinNoise3(0xDEADBEEF), PerlinNoise3(5)};
  Lcg rng{23};
  int mismatches = 0, compared = 0;
  // the hashes by scalar look-ups, and by byte permutes where the CPU has VBMI
  std::vector<bool> hashes = {false};
  if (PerlinNoise3::batchVbmi()) {
    hashes.push_back(true);
  } else {
    WARN("no AVX-512 VBMI here (or SWARMSIM_NO_VBMI set): the byte-permute hashes are not tested");
  }
  for (const bool vbmi : hashes)
    // one, three and four noises (three at a time inside: the fourth is a second group)
    for (const int count : {1, 3, 4}) {
      for (int b = 0; b < 2000; ++b) {
        double p[3][kWide];
        for (auto& axis : p)
          for (double& c : axis) c = latticeCoordinate(rng);
        std::vector<double> g[3];
        for (auto& gi : g) gi.assign(static_cast<std::size_t>(count * kWide), -7.0);
        PerlinNoise3::withGradientWide(noises, count, p[0], p[1], p[2], g[0].data(), g[1].data(), g[2].data(), vbmi);
        for (int k = 0; k < count; ++k) {
          for (int l = 0; l < kWide; ++l) {
            Vec3d grad;
            noises[k].withGradient(Vec3d(p[0][l], p[1][l], p[2][l]), grad);
            const auto i = static_cast<std::size_t>(k * kWide + l);
            ++compared;
            if (!(sameBits(grad.x(), g[0][i]) && sameBits(grad.y(), g[1][i]) && sameBits(grad.z(), g[2][i])) &&
                ++mismatches <= 5) {
              UNSCOPED_INFO("vbmi " << vbmi << ", noise " << k << " at (" << p[0][l] << ", " << p[1][l] << ", "
                                    << p[2][l] << "): gradient (" << grad.transpose() << ") vs (" << g[0][i] << " "
                                    << g[1][i] << " " << g[2][i] << ")");
            }
          }
        }
      }
    }
  CHECK(compared == static_cast<int>(hashes.size()) * 2000 * 8 * 8);
  CHECK(mismatches == 0);
}

TEST_CASE("The exact curl in batches equals curlRaw bit for bit", "[noise][fields]") {
  const swarmsim::NoisePotential pot(testParams());
  Lcg rng{17};
  std::vector<double> x[3];
  for (auto& axis : x) {
    for (int i = 0; i < 8000; ++i)
      axis.push_back(rng.below(4) == 0 ? 2.0 * (rng.below(41) - 20) : rng.uniform(-40, 40));
  }
  // SSE2 lanes; AVX ones (eight at a time where batchWide() holds); with SWARMSIM_NO_AVX512 four AVX lanes
  for (const int pass : {0, 1, 2}) {
    const bool avx = pass > 0 && cpuHasAvx();
    const NoAvx512Guard narrow(pass == 2);
    // counts around the lanes and the chunks of 64 points, and all the points at once
    for (const std::size_t n : {0, 1, 3, 5, 17, 63, 64, 65, 130, 8000}) {
      std::vector<double> c[3];
      for (auto& ci : c) ci.assign(n + 1, -1.0);
      pot.curlRawBatch(x[0].data(), x[1].data(), x[2].data(), n, c[0].data(), c[1].data(), c[2].data(), avx,
                       PerlinNoise3::batchWide(), PerlinNoise3::batchVbmi());
      int bad = 0;
      for (std::size_t i = 0; i < n; ++i) {
        const Vec3d want = pot.curlRaw(Vec3d(x[0][i], x[1][i], x[2][i]));
        bad += !(sameBits(want.x(), c[0][i]) && sameBits(want.y(), c[1][i]) && sameBits(want.z(), c[2][i]));
      }
      INFO("avx " << avx << ", wide " << PerlinNoise3::batchWide() << ", n " << n);
      CHECK(bad == 0);
      CHECK((c[0][n] == -1.0 && c[1][n] == -1.0 && c[2][n] == -1.0));  // nothing written beyond n
    }
  }
}

TEST_CASE("NoiseField::evaluateBatch equals operator() bit for bit in direct mode, with and without AVX",
          "[noise][fields]") {
  const Scene scene;
  // maxCells 1: never a grid
  const NoiseField field(NoiseFieldKind::kCurl, testParams(), scene.domain, scene.obstacles, {0, 0, 0}, &scene.boundary,
                         1.0);
  REQUIRE(field.direct());
  const Points p = testPoints(20000, 99);
  // both branches of evaluate are taken: the exact curl far from the boundary, the differences near it
  // (within d0 = 1 m, plus the stencil)
  int nearBoundary = 0;
  for (std::size_t i = 0; i < p.x.size(); ++i)
    nearBoundary += scene.boundary.sample(Vec3(p.x[i], p.y[i], p.z[i])) < 1.1f;
  CHECK(nearBoundary > 2000);
  CHECK(nearBoundary < 12000);

  SECTION("AVX where the CPU has it") { checkBatch(field, p); }
  SECTION("SWARMSIM_NO_AVX set") {
    const NoAvxGuard noAvx;
    CHECK_FALSE(PerlinNoise3::batchAvx());
    checkBatch(field, p);
  }
  SECTION("no boundary: every point on the lanes") {
    const NoiseField free(NoiseFieldKind::kCurl, testParams(), scene.domain, scene.obstacles, {0, 0, 0}, nullptr, 1.0);
    REQUIRE(free.direct());
    checkBatch(free, p);
  }
}

TEST_CASE("NoiseField::evaluateBatch equals operator() on a grid and for Perlin noise", "[noise][fields]") {
  const Scene scene;
  const Points p = testPoints(3000, 5);
  SECTION("curl noise on a grid") {
    const NoiseField grid(NoiseFieldKind::kCurl, testParams(), scene.domain, scene.obstacles, {12, 10, 8},
                          &scene.boundary);
    REQUIRE_FALSE(grid.direct());
    checkBatch(grid, p);
  }
  SECTION("direct Perlin noise") {
    const NoiseField perlin(NoiseFieldKind::kPerlin, testParams(), scene.domain, scene.obstacles, {0, 0, 0},
                            &scene.boundary, 1.0);
    REQUIRE(perlin.direct());
    checkBatch(perlin, p);
  }
}

TEST_CASE("Direct curl noise is the exact curl exactly where the boundary distance allows it", "[noise][fields]") {
  // evaluate() decides by the distance sample, after a coarse lower bound of it (NoiseField's floor_): the
  // bound must never claim a point the sample would not
  const Scene scene;
  const NoiseParams np = testParams();
  const NoiseField field(NoiseFieldKind::kCurl, np, scene.domain, scene.obstacles, {0, 0, 0}, &scene.boundary, 1.0);
  REQUIRE(field.direct());
  const swarmsim::NoisePotential potential(np);
  const double exactFrom = np.d0 + 1.7320508 * (0.1 * np.unit / (3.0 * np.scale));  // d0 + sqrt(3) stencil steps
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0), shell(exactFrom - 0.05, exactFrom + 0.05);
  std::vector<Vec3> points;
  for (int i = 0; i < 20000; ++i) {
    const Vec3d dir = Vec3d(u(rng), u(rng), u(rng)).normalized();
    points.push_back((Vec3d(3, -2, 1) + dir * (6.0 + shell(rng))).cast<float>());  // about the sphere's threshold
    points.push_back(Vec3d(20 * u(rng), 20 * u(rng), 20 * u(rng)).cast<float>());  // anywhere
  }
  int exact = 0, near = 0, wrong = 0;
  for (const Vec3& x : points) {
    const bool far = static_cast<double>(scene.boundary.sample(x)) >= exactFrom;
    const bool isExact = field(x) == potential.curlRaw(x.cast<double>()).cast<float>();
    (far ? exact : near) += 1;
    wrong += far != isExact ? 1 : 0;
  }
  CHECK(wrong == 0);
  CHECK(exact > 5000);
  CHECK(near > 5000);
}
