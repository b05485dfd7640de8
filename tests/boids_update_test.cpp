// The boids model's agent update on lanes (lib/models/boids/boids_update.hpp) and the lane functions its jitter
// uses (lib/core/lanes.hpp: logUnitLanes, cosSinTurnLanes): each against a reference in double written from the
// equations of docs/models/boids.md, and the same bits on every lane set.
#include "models/boids/boids_update.hpp"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/lanes.hpp"
#include "lane_sets.hpp"

using namespace swarmsim;

namespace {

// ln u, cos 2πu and sin 2πu of every u by the lane type L
template <typename L>
void lanesMath(const std::vector<float>& u, std::vector<float>& ln, std::vector<float>& c, std::vector<float>& s) {
  ln.assign(u.size(), 0.0f);
  c.assign(u.size(), 0.0f);
  s.assign(u.size(), 0.0f);
  for (std::size_t i = 0; i < u.size(); i += kLanes) {
    const typename L::V x = L::load(u.data() + i);
    L::store(ln.data() + i, logUnitLanes<L>(x));
    typename L::V cv, sv;
    cosSinTurnLanes<L>(x, cv, sv);
    L::store(c.data() + i, cv);
    L::store(s.data() + i, sv);
  }
}
#if SWARMSIM_X86_LANES
SWARMSIM_AVX __attribute__((flatten)) void lanesMathAvx(const std::vector<float>& u, std::vector<float>& ln,
                                                        std::vector<float>& c, std::vector<float>& s) {
  lanesMath<AvxLanes>(u, ln, c, s);
}
#endif

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// the update of one agent in double, from the equations (docs/models/boids.md), with the jitter's normals from
// the same four uniforms by Box-Muller
std::array<double, 3> reference(const BoidsUpdateParams& p, const double x[3], const double u[3], const double v[3],
                                const std::array<float, 9>& sums, const float* jitter) {
  double t[3], dc[3];
  for (int a = 0; a < 3; ++a) dc[a] = static_cast<double>(p.center[a]) - x[a];
  const double d = std::sqrt(dc[0] * dc[0] + dc[1] * dc[1] + dc[2] * dc[2]);
  const double scale = p.invCr > 0.0f ? std::min(1.0, d * p.invCr) : 1.0;
  double normal[3] = {0.0, 0.0, 0.0};
  if (jitter) {
    const double r1 = std::sqrt(-2.0 * std::log(1.0 - jitter[0])), r2 = std::sqrt(-2.0 * std::log(1.0 - jitter[2]));
    normal[0] = r1 * std::cos(2.0 * M_PI * jitter[1]);
    normal[1] = r1 * std::sin(2.0 * M_PI * jitter[1]);
    normal[2] = r2 * std::cos(2.0 * M_PI * jitter[3]);
  }
  for (int a = 0; a < 3; ++a) {
    const auto k = static_cast<std::size_t>(a);
    const double m = p.margin;
    const double lo = std::max(0.0, p.lo[a] + m - x[a]) / m, hi = std::max(0.0, x[a] - (p.hi[a] - m)) / m;
    t[a] = p.smin * u[a] - p.fr * sums[k] + p.fa * sums[3 + k] + p.ft * sums[6 + k] +
           (d > 0.0 ? p.fc * scale * dc[a] / d : 0.0) + p.fw * (lo - hi) + p.noise * normal[a];
  }
  std::array<double, 3> nv;
  for (int a = 0; a < 3; ++a) nv[static_cast<std::size_t>(a)] = v[a] + (t[a] - v[a]) * p.blend;
  const double sp = std::sqrt(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]);
  if (sp > p.smax) {
    for (double& c : nv) c *= p.smax / sp;
  } else if (sp < p.smin) {
    const double hu = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    for (int a = 0; a < 3; ++a) {
      const auto k = static_cast<std::size_t>(a);
      const double dir = sp > 1e-12 ? nv[k] / sp : hu > 0.0 ? u[a] : (a == 0 ? 1.0 : 0.0);
      nv[k] = dir * p.smin;
    }
  }
  return nv;
}

}  // namespace

TEST_CASE("lanes: ln u, cos 2πu and sin 2πu against double precision, the same bits on every lane type",
          "[boids][lanes]") {
  std::vector<float> u;
  for (int i = 1; i <= (1 << 16); ++i) u.push_back(static_cast<float>(i) / 65536.0f);  // (0, 1] in 2^-16 steps
  for (int e = 1; e <= 31; ++e) u.push_back(std::ldexp(1.0f, -e));         // every power of two down to 2^-31
  for (int e = 1; e <= 24; ++e) u.push_back(1.0f - std::ldexp(1.0f, -e));  // just below 1
  u.push_back(0.0f);                                                       // (cos and sin: u in [0, 1])
  u.push_back(std::ldexp(1.0f, -24));
  u.push_back(0.70710677f);
  u.push_back(0.70710683f);
  while (u.size() % kLanes != 0) u.push_back(0.5f);
  std::vector<float> ln, c, s;
  lanesMath<SseLanes>(u, ln, c, s);
  double worstLn = 0.0, worstTrig = 0.0;
  for (std::size_t i = 0; i < u.size(); ++i) {
    const double x = u[i];
    if (x > 0.0) {
      const double want = std::log(x);
      // a few units in the last place of the result, and of ln 2^-24 near 1 (where ln u is near 0)
      worstLn = std::max(worstLn, std::abs(ln[i] - want) / (3e-7 * std::abs(want) + 1e-12));
    }
    worstTrig =
        std::max({worstTrig, std::abs(c[i] - std::cos(2.0 * M_PI * x)), std::abs(s[i] - std::sin(2.0 * M_PI * x))});
  }
  INFO("ln: worst error / (3e-7 |ln u|) = " << worstLn << ", cos and sin: worst absolute error " << worstTrig);
  CHECK(worstLn <= 1.0);
  CHECK(worstTrig <= 2e-7);
  CHECK(ln[(1 << 16) - 1] == 0.0f);  // ln 1
  std::vector<float> ln2, c2, s2;
  lanesMath<ScalarLanes>(u, ln2, c2, s2);
  CHECK(sameBits(ln, ln2));
  CHECK(sameBits(c, c2));
  CHECK(sameBits(s, s2));
#if SWARMSIM_X86_LANES
  if (__builtin_cpu_supports("avx")) {
    lanesMathAvx(u, ln2, c2, s2);
    CHECK(sameBits(ln, ln2));
    CHECK(sameBits(c, c2));
    CHECK(sameBits(s, s2));
  }
#endif
}

TEST_CASE("boids update: the lanes give the equations' velocities, with the same bits on every lane set",
          "[boids][lanes]") {
  BoidsUpdateParams p;
  p.smin = 0.5f;
  p.smax = 2.0f;
  p.fr = 0.7f;
  p.fa = 0.25f;
  p.ft = 0.2f;
  p.fc = 0.4f;
  p.invCr = 1.0f / 3.0f;
  p.fw = 1.5f;
  p.margin = 1.0f;
  p.blend = 0.6f;
  p.noise = 0.25f;
  p.center = Vec3(5.0f, 5.0f, 5.0f);
  p.lo = Vec3(0.0f, 0.0f, 0.0f);
  p.hi = Vec3(10.0f, 10.0f, 10.0f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(-0.5f, 10.5f), unit(-1.0f, 1.0f), sum(-4.0f, 4.0f), draw(0.0f, 1.0f);
  const std::size_t n = 1003;  // (a last block of three)
  std::vector<float> x[3], u[3], v[3], jitter(4 * n);  // (four uniforms of agent i at 4 i)
  std::vector<std::array<float, 9>> sums(n);
  for (std::size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      x[a].push_back(pos(rng));
      u[a].push_back(unit(rng));
      v[a].push_back(2.5f * unit(rng));
    }
    for (float& f : sums[i]) f = sum(rng);
    for (std::size_t w = 0; w < 4; ++w) jitter[4 * i + w] = draw(rng);
  }
  // the corner cases: at the centre; at rest with a target of zero (without the jitter) and a heading (cruise
  // 0.5 along y cancelled by the alignment sum: 0.5 + 0.25 (−2) = 0), and without a heading (+x then); a draw of
  // u = 0 (1 − u = 1: ln 1 = 0)
  for (int a = 0; a < 3; ++a) x[a][0] = p.center[a];
  for (std::size_t i : {1, 2}) {
    for (int a = 0; a < 3; ++a) {
      x[a][i] = p.center[a];
      v[a][i] = 0.0f;
      u[a][i] = i == 1 ? (a == 1 ? 1.0f : 0.0f) : 0.0f;
    }
    sums[i].fill(0.0f);
  }
  sums[1][4] = -2.0f;
  jitter[4 * 3] = 0.0f;
  const auto run = [&](LaneSet set, std::vector<float> out[3], bool withJitter) {
    for (int a = 0; a < 3; ++a) out[a] = v[a];
    std::vector<float> draws[4];
    for (std::size_t w = 0; w < 4; ++w) {
      for (std::size_t i = 0; i < n; ++i) draws[w].push_back(jitter[4 * i + w]);
    }
    std::vector<float> bySum[9];
    for (std::size_t a = 0; a < 9; ++a) {
      for (std::size_t i = 0; i < n; ++i) bySum[a].push_back(sums[i][a]);
    }
    BoidsUpdateRow row = {x[0].data(),   x[1].data(),   x[2].data(),   u[0].data(), u[1].data(), u[2].data(),
                          out[0].data(), out[1].data(), out[2].data(), {},          {}};
    for (std::size_t a = 0; a < 9; ++a) row.sums[a] = bySum[a].data();
    for (std::size_t w = 0; w < 4; ++w) row.jitter[w] = withJitter ? draws[w].data() : nullptr;
    boidsUpdate(row, n, p, set);
  };
  for (const bool withJitter : {true, false}) {
    INFO((withJitter ? "with" : "without") << " the jitter");
    std::vector<float> first[3];
    bool haveFirst = false;
    for (const LaneSet set : swarmsim_test::laneSetsOfThisCpu()) {
      std::vector<float> out[3];
      run(set, out, withJitter);
      if (!haveFirst) {
        for (int a = 0; a < 3; ++a) first[a] = out[a];
        haveFirst = true;
        double worst = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
          double xi[3], ui[3], vi[3];
          for (int a = 0; a < 3; ++a) {
            xi[a] = x[a][i];
            ui[a] = u[a][i];
            vi[a] = v[a][i];
          }
          const std::array<double, 3> want =
              reference(p, xi, ui, vi, sums[i], withJitter ? jitter.data() + 4 * i : nullptr);
          for (int a = 0; a < 3; ++a) worst = std::max(worst, std::abs(out[a][i] - want[static_cast<std::size_t>(a)]));
        }
        INFO("worst absolute error " << worst << " m/s");
        CHECK(worst < 2e-5);
        if (!withJitter) {  // the two at rest: the cruise speed along the heading, else along +x
          CHECK((out[0][1] == 0.0f && out[1][1] == p.smin && out[2][1] == 0.0f));
          CHECK((out[0][2] == p.smin && out[1][2] == 0.0f && out[2][2] == 0.0f));
        }
      } else {
        INFO("lane set " << static_cast<int>(set));
        for (int a = 0; a < 3; ++a) CHECK(sameBits(out[a], first[a]));
      }
    }
  }
}

TEST_CASE("boids unit velocities: normalizedOrZero's bits on every lane set, zero for a vanishing velocity",
          "[boids][lanes]") {
  std::mt19937 gen(11);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::vector<float> vx, vy, vz;
  for (int i = 0; i < 203; ++i) {  // (not a whole number of eights: the tail too)
    vx.push_back(u(gen));
    vy.push_back(u(gen));
    vz.push_back(u(gen));
  }
  // zero, a squared norm at and below the 1e-30 cut, and one just above it
  const float tiny[][3] = {{0.0f, 0.0f, 0.0f}, {1e-16f, 0.0f, 0.0f}, {5e-16f, 5e-16f, 5e-16f}, {0.0f, 2e-15f, 0.0f}};
  for (std::size_t k = 0; k < 4; ++k) {
    vx[3 + 8 * k] = tiny[k][0];
    vy[3 + 8 * k] = tiny[k][1];
    vz[3 + 8 * k] = tiny[k][2];
  }
  const std::size_t n = vx.size();
  for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
    std::vector<float> ux(n, 9.0f), uy(n, 9.0f), uz(n, 9.0f);
    unitVelocities(vx.data(), vy.data(), vz.data(), n, ux.data(), uy.data(), uz.data(), lanes);
    INFO("lane set " << static_cast<int>(lanes));
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 want = normalizedOrZero(Vec3(vx[i], vy[i], vz[i]));
      const float got[3] = {ux[i], uy[i], uz[i]};
      CHECK(std::memcmp(got, want.data(), sizeof got) == 0);
    }
    // the vanishing ones are zero; the one above the cut has unit length
    CHECK((ux[3] == 0.0f && uy[11] == 0.0f && uz[19] == 0.0f));
    CHECK(uy[27] == 1.0f);
  }
}
