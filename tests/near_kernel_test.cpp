// The shape model's near-field kernels (lib/models/shape/near_kernel.hpp) and the lanes they are built on
// (lib/core/lanes.hpp): the vector e^x against std::exp, the same bits on every lane type, and each kernel
// against the scalar sums of shape.hpp (ShapeConstraintSum, ZonalSum) over the same entries.
#include "models/shape/near_kernel.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "core/lanes.hpp"
#include "lane_sets.hpp"
#include "models/shape/shape.hpp"
#include "spatial/nearest.hpp"
#include "spatial/uniform_grid.hpp"

using namespace swarmsim;

namespace {

template <typename L>
std::vector<float> expOf(const std::vector<float>& x) {
  std::vector<float> out(x.size());
  for (std::size_t i = 0; i < x.size(); i += kLanes) L::store(out.data() + i, expLanes<L>(L::load(x.data() + i)));
  return out;
}

#if SWARMSIM_X86_LANES
// the AVX lanes only inside a function compiled for AVX (their vectors cross no other function's boundary)
SWARMSIM_AVX __attribute__((flatten)) void expAvx(const float* x, float* out, std::size_t n) {
  for (std::size_t i = 0; i < n; i += kLanes) AvxLanes::store(out + i, expLanes<AvxLanes>(AvxLanes::load(x + i)));
}
#endif

// a block holding every point (one cell), its squared distances to q filled as CellBlock::filter does
CellBlock blockOf(const std::vector<Vec3>& pts, const Vec3& q) {
  CellBlock b;
  const std::size_t cap = pts.size() + 16;
  for (auto* v : {&b.x, &b.y, &b.z, &b.d2}) v->assign(cap, 0.0f);
  b.index.assign(cap, 0);
  b.hits.assign(cap, 0);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    b.x[i] = pts[i].x();
    b.y[i] = pts[i].y();
    b.z[i] = pts[i].z();
    b.index[i] = static_cast<std::uint32_t>(i);
  }
  b.size = pts.size();
  b.filter(q.x(), q.y(), q.z(), 1e30f);
  return b;
}

// the rows the near kernels read (near_kernel.hpp: position, 0, velocity, 0): point i of pts (velocity vel[i],
// or zero without vel) at sorted position at[i] (i without at), and the far row at pts.size()
float* rowsOf(AlignedFloats& store, const std::vector<Vec3>& pts, const std::vector<Vec3>* vel = nullptr,
              const std::vector<std::size_t>* at = nullptr) {
  const std::size_t n = pts.size();
  float* rows = store.resize(kRowFloats * (n + 1));
  for (std::size_t i = 0; i <= n; ++i) {
    const Vec3 p = i < n ? pts[i] : Vec3::Constant(3.0e38f);
    const Vec3 v = i < n && vel ? (*vel)[i] : Vec3::Zero();
    const float row[kRowFloats] = {p.x(), p.y(), p.z(), 0.0f, v.x(), v.y(), v.z(), 0.0f};
    std::copy(row, row + kRowFloats, rows + kRowFloats * (i < n && at ? (*at)[i] : i));
  }
  return rows;
}

[[maybe_unused]] bool sameBits(const Vec3& a, const Vec3& b) {
  return std::memcmp(a.data(), b.data(), sizeof(float) * 3) == 0;
}

}  // namespace

TEST_CASE("lanes: e^x within 3e-7 of std::exp on [-20, 3], the same bits on every lane type", "[shape][lanes]") {
  std::vector<float> x;
  for (int i = 0; i <= 23000; ++i) x.push_back(-20.0f + 0.001f * static_cast<float>(i));
  x.push_back(-200.0f);  // clamped to -87: tiny but finite
  while (x.size() % kLanes != 0) x.push_back(0.0f);
  const std::vector<float> s = expOf<ScalarLanes>(x);
  double worst = 0.0, worstFar = 0.0;
  for (std::size_t i = 0; i + 1 < x.size(); ++i) {
    if (x[i] < -87.0f) continue;
    const double e = std::exp(static_cast<double>(x[i]));
    (x[i] >= -3.0f ? worst : worstFar) =
        std::max(x[i] >= -3.0f ? worst : worstFar, std::abs(static_cast<double>(s[i]) - e) / e);
  }
  CHECK(worst < 3e-7);
  CHECK(worstFar < 3e-7);
  const auto tail = std::find(x.begin(), x.end(), -200.0f) - x.begin();
  CHECK(s[static_cast<std::size_t>(tail)] > 0.0f);
  CHECK(s[static_cast<std::size_t>(tail)] < 1e-37f);
#if SWARMSIM_X86_LANES
  CHECK(expOf<SseLanes>(x) == s);
  if (__builtin_cpu_supports("avx")) {
    std::vector<float> a(x.size());
    expAvx(x.data(), a.data(), x.size());
    CHECK(a == s);
  }
#endif
}

TEST_CASE("near kernels: F_con and F_int sums equal the scalar ones, and AVX equals SSE bit for bit",
          "[shape][lanes]") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (const std::size_t n : {1u, 2u, 7u, 8u, 9u, 12u, 16u, 17u, 18u, 31u, 200u}) {
    std::vector<Vec3> pts(n), vel(n);
    for (std::size_t i = 0; i < n; ++i) {
      pts[i] = Vec3(u(rng), u(rng), u(rng));
      vel[i] = Vec3(u(rng), u(rng), u(rng));
    }
    pts[n / 2] = pts[0];  // a coincident pair (and, for n = 1, the query itself): counted by neither F_con
    const Vec3 q = pts[0], vq = vel[0];
    const CellBlock block = blockOf(pts, q);

    // F_con: Manhattan threshold 0.9, sigma 0.3
    ShapeConstraintSum ref(0.9f, 0.3f);
    for (std::size_t i = 0; i < n; ++i)
      ref.add(pts[i].x() - q.x(), pts[i].y() - q.y(), pts[i].z() - q.z(), block.d2[i]);
    NearScratch ns;
    Vec3 sum[2];
    int count[2] = {0, 0};
    for (int avx = 0; avx < 2; ++avx) {
      ns.reserve(n + kLanes);
      for (std::size_t i = 0; i < n; ++i) {
        ns.dx[i] = pts[i].x() - q.x();
        ns.dy[i] = pts[i].y() - q.y();
        ns.dz[i] = pts[i].z() - q.z();
        ns.d2[i] = block.d2[i];
      }
      constraintSumScratch(n, 0.9f, 1.0f / (2.0f * 0.3f * 0.3f), ns, avx == 1, sum[avx], count[avx]);
    }
    CHECK(count[0] == ref.count);
    const Vec3 fRef = ref.force(1.0f),
               f = ref.count > 0 ? Vec3(sum[0] * (-1.0f / static_cast<float>(count[0]))) : Vec3::Zero();
    CHECK((f - fRef).norm() <= 1e-5f * (1.0f + fRef.norm()));
#if SWARMSIM_X86_LANES
    if (__builtin_cpu_supports("avx")) {
      CHECK(count[1] == count[0]);
      CHECK(sameBits(sum[0], sum[1]));
    }
#endif

    // F_int over every point but the query (zones 0.3 / 0.8 / 1.5)
    ZonalSum zref(0.3f, 0.8f, 1.5f, 0.2f, 3.0f, 13.0f);
    ns.reserve(n);
    std::size_t m = 0;
    for (std::size_t i = 1; i < n; ++i, ++m) {
      const Vec3 d = pts[i] - q, dv = vel[i] - vq;
      zref.add(d.x(), d.y(), d.z(), d.squaredNorm(), dv.x(), dv.y(), dv.z());
      ns.dx[m] = d.x();
      ns.dy[m] = d.y();
      ns.dz[m] = d.z();
      ns.d2[m] = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
      ns.ux[m] = dv.x();
      ns.uy[m] = dv.y();
      ns.uz[m] = dv.z();
    }
    const ZoneLanes zl = {zref.rRep2, zref.rAli2, zref.rAtt2, {0.2f, 3.0f, 13.0f}};
    NearScratch copy = ns;
    const Vec3 fz = zonalForce(m, zl, ns, false);
    CHECK((fz - zref.force()).norm() <= 1e-5f * (1.0f + zref.force().norm()));
#if SWARMSIM_X86_LANES
    if (__builtin_cpu_supports("avx")) CHECK(sameBits(zonalForce(m, zl, copy, true), fz));
#endif
    // the same sum straight from the points' rows (position, 0, velocity, 0; a far row at n), on AVX2
    if (zonalFromRows(laneSet())) {
      AlignedFloats store;
      const float* rows = rowsOf(store, pts, &vel);
      std::vector<std::uint32_t> js(n + kLanes);
      for (std::size_t i = 1; i < n; ++i) js[i - 1] = static_cast<std::uint32_t>(i);
      CHECK(sameBits(zonalForceRows(m, js.data(), rows, static_cast<std::uint32_t>(n), q, vq, zl), fz));
    }
  }
}

TEST_CASE(
    "near kernels: classifyCandidates and gatherClassify sort each candidate into its classes, the same on every lane "
    "set",
    "[shape][lanes]") {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const std::vector<LaneSet> sets = swarmsim_test::laneSetsOfThisCpu();
  // sparse classes, and classes that take in (nearly) every candidate of a chunk of sixteen
  struct Radii {
    float threshold, near2, reach2;
  };
  for (const Radii radii : {Radii{0.9f, 0.4f, 0.1f}, Radii{3.5f, 12.0f, 2.0f}})
    for (const std::size_t m : {0u, 1u, 7u, 8u, 9u, 15u, 16u, 17u, 33u, 64u, 301u}) {
      const float threshold = radii.threshold, near2 = radii.near2, reach2 = radii.reach2;
      std::vector<Vec3> pts(m);
      for (auto& p : pts) p = Vec3(u(rng), u(rng), u(rng));
      const Vec3 q(0.1f, -0.2f, 0.05f);
      if (m > 2) pts[2] = q;  // at the query: d2 = 0, in the near and reach classes but not F_con's
      // the classes by a plain loop
      std::vector<std::uint32_t> want[3];
      for (std::size_t e = 0; e < m; ++e) {
        const float dx = pts[e].x() - q.x(), dy = pts[e].y() - q.y(), dz = pts[e].z() - q.z();
        const float d2 = dx * dx + dy * dy + dz * dz;
        const float man = std::abs(dx) + std::abs(dy) + std::abs(dz);
        if (man < threshold && d2 > 0.0f) want[0].push_back(static_cast<std::uint32_t>(e));
        if (d2 <= near2) want[1].push_back(static_cast<std::uint32_t>(e));
        if (d2 <= reach2) want[2].push_back(static_cast<std::uint32_t>(e));
      }
      for (const LaneSet set : sets) {
        INFO("m = " << m << ", lane set " << static_cast<int>(set));
        NearScratch ns;
        ns.reserveCandidates(m);
        for (std::size_t e = 0; e < m; ++e) {
          ns.cx[e] = pts[e].x();
          ns.cy[e] = pts[e].y();
          ns.cz[e] = pts[e].z();
        }
        std::size_t counts[3];
        classifyCandidates(m, q, threshold, near2, reach2, ns, set, counts);
        // (F_int's class: the indices in its keys' low halves)
        std::vector<std::uint32_t> nsNear;
        for (std::size_t c = 0; c < counts[1]; ++c) nsNear.push_back(keyIndex(ns.keys[c]));
        const std::vector<std::uint32_t>* got[3] = {&ns.conIdx, &nsNear, &ns.mdeIdx};
        for (int c = 0; c < 3; ++c) {
          REQUIRE(counts[c] == want[c].size());
          CHECK(std::equal(want[c].begin(), want[c].end(), got[c]->begin()));
        }
        for (std::size_t e = 0; e < m; ++e) {  // the offsets and squared distances, in place
          const float dx = pts[e].x() - q.x(), dy = pts[e].y() - q.y(), dz = pts[e].z() - q.z();
          CHECK((ns.cx[e] == dx && ns.cy[e] == dy && ns.cz[e] == dz));
          CHECK(ns.cd2[e] == dx * dx + dy * dy + dz * dz);
        }
        // the same from rows: candidate e is point e at sorted position m - 1 - e, the far row at m
        std::vector<std::size_t> at(m);
        std::vector<std::uint32_t> cand(m);
        for (std::size_t e = 0; e < m; ++e) cand[e] = static_cast<std::uint32_t>(at[e] = m - 1 - e);
        AlignedFloats store;
        const float* rows = rowsOf(store, pts, nullptr, &at);
        NearScratch gs;
        std::size_t gotCounts[3];
        gatherClassify(m, cand.data(), rows, static_cast<std::uint32_t>(m), q, threshold, near2, reach2, gs, set,
                       gotCounts);
        // (F_int's class: the indices in its keys' low halves)
        std::vector<std::uint32_t> gsNear;
        for (std::size_t c = 0; c < gotCounts[1]; ++c) gsNear.push_back(keyIndex(gs.keys[c]));
        const std::vector<std::uint32_t>* fromRows[3] = {&gs.conIdx, &gsNear, &gs.mdeIdx};
        for (int c = 0; c < 3; ++c) {
          REQUIRE(gotCounts[c] == want[c].size());
          CHECK(std::equal(want[c].begin(), want[c].end(), fromRows[c]->begin()));
        }
        for (std::size_t e = 0; e < m; ++e) {
          CHECK(gs.cj[e] == cand[e]);
          CHECK((gs.cx[e] == ns.cx[e] && gs.cy[e] == ns.cy[e] && gs.cz[e] == ns.cz[e] && gs.cd2[e] == ns.cd2[e]));
        }
        // the near entries' keys, in order, from both
        for (std::size_t c = 0; c < want[1].size(); ++c) {
          const std::uint32_t e = want[1][c];
          CHECK(ns.keys[c] == neighbourKey(ns.cd2[e], e));
          CHECK(gs.keys[c] == neighbourKey(ns.cd2[e], e));
        }
        // F_con's entries packed: the offsets and squared distances of want[0], in order, from both
        for (std::size_t c = 0; c < want[0].size(); ++c) {
          const std::uint32_t e = want[0][c];
          for (const NearScratch* sc : {&ns, &gs}) {
            CHECK((sc->dx[c] == ns.cx[e] && sc->dy[c] == ns.cy[e] && sc->dz[c] == ns.cz[e] && sc->d2[c] == ns.cd2[e]));
          }
        }
      }
    }
}

TEST_CASE("near kernels: farthestRow2 gives the scalar loop's squared distance on every lane set",
          "[shape][near_kernel]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-2.0f, 2.0f);
  const std::size_t n = 300;
  std::vector<Vec3> pts(n);
  for (Vec3& p : pts) p = Vec3(u(rng), u(rng), u(rng));
  AlignedFloats store;
  const float* rows = rowsOf(store, pts);
  // pos: a permutation (sorted positions of last step's slots), prev: slots
  std::vector<std::uint32_t> pos(n), prev(40);
  for (std::size_t i = 0; i < n; ++i) pos[i] = static_cast<std::uint32_t>((i * 7 + 3) % n);
  for (std::size_t m = 0; m <= prev.size(); ++m) {
    for (int round = 0; round < 5; ++round) {
      for (std::uint32_t& p : prev) p = static_cast<std::uint32_t>(rng() % n);
      const Vec3 q(u(rng), u(rng), u(rng));
      float expect = 0.0f;
      for (std::size_t e = 0; e < m; ++e) {
        const Vec3& p = pts[pos[prev[e]]];
        const float dx = p.x() - q.x(), dy = p.y() - q.y(), dz = p.z() - q.z();
        expect = std::max(expect, dx * dx + dy * dy + dz * dz);
      }
      for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
        CAPTURE(m, round, static_cast<int>(lanes));
        const float got = farthestRow2(m, prev.data(), pos.data(), rows, n + 1, q, lanes);
        REQUIRE(std::memcmp(&got, &expect, sizeof got) == 0);
      }
    }
  }
}

TEST_CASE("near kernels: keepSmallest keeps the K smallest keys in their given order", "[shape][near_kernel]") {
  std::mt19937_64 rng(21);
  for (int round = 0; round < 3000; ++round) {
    const std::size_t K = rng() % 14, m = rng() % 40;
    std::vector<std::uint64_t> keys(m);
    for (std::size_t e = 0; e < m; ++e) {
      // squared distance bits high (with ties), the index low: distinct keys, as neighbourKey makes them
      keys[e] = ((rng() % 50) << 32) | e;
    }
    std::vector<std::uint64_t> sorted = keys;
    std::sort(sorted.begin(), sorted.end());
    const std::size_t keep = std::min(K, m);
    const std::uint64_t limit = keep > 0 ? sorted[keep - 1] : 0;
    std::vector<std::uint64_t> want;
    for (const std::uint64_t k : keys) {
      if (keep > 0 && k <= limit) want.push_back(k);
    }
    std::vector<std::uint64_t> got = keys;
    const std::size_t n = keepSmallest(got.data(), m, K);
    CAPTURE(round, K, m);
    REQUIRE(n == keep);
    got.resize(n);
    REQUIRE(got == want);
  }
}

TEST_CASE(
    "near kernels: nearSums gives what gatherClassify, keepSmallest and zonalForceRows give of the same candidates",
    "[shape][near_kernel]") {
  if (!nearSumsLanes(LaneSet::kAvx512) || !__builtin_cpu_supports("avx512f")) {
    WARN("no AVX-512 with BMI2 on this CPU: nearSums not run");
    return;
  }
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const std::size_t n = 200;
  std::size_t taken = 0, tried = 0, conCases = 0, conPacked = 0, threeChunks = 0;
  for (int round = 0; round < 3000; ++round) {
    // points (some on a coarse lattice: equal distances), velocities, at shuffled sorted positions
    std::vector<Vec3> pts(n), vel(n);
    const bool lattice = round % 5 == 0;
    for (std::size_t i = 0; i < n; ++i) {
      pts[i] = lattice ? Vec3(std::round(4.0f * u(rng)), std::round(4.0f * u(rng)), std::round(4.0f * u(rng))) / 4.0f
                       : Vec3(u(rng), u(rng), u(rng));
      vel[i] = round % 7 == 0 && i % 3 == 0 ? Vec3::Zero() : Vec3(u(rng), u(rng), u(rng));
    }
    std::vector<std::size_t> at(n);
    for (std::size_t i = 0; i < n; ++i) at[i] = (i * 37 + static_cast<std::size_t>(round)) % n;
    AlignedFloats store;
    const float* rows = rowsOf(store, pts, &vel, &at);
    const auto far = static_cast<std::uint32_t>(n);
    // candidates: m sorted positions (the query's own among them at times: d2 = 0)
    const std::size_t m = 1 + static_cast<std::size_t>(rng() % 56);
    std::vector<std::uint32_t> cand(m + 16);
    for (std::size_t e = 0; e < m; ++e) cand[e] = static_cast<std::uint32_t>(at[rng() % n]);
    const std::size_t self = rng() % n;
    const Vec3 q = round % 3 == 0 ? pts[self] : Vec3(0.5f * u(rng), 0.5f * u(rng), 0.5f * u(rng));
    const Vec3 vq(u(rng), u(rng), u(rng));
    const std::size_t Ks[] = {1, 4, 8, 9, 10, 16, 17};
    const std::size_t K = Ks[rng() % 7];
    const float threshold = 0.2f + 1.5f * std::abs(u(rng)), near2 = 0.1f + 2.0f * std::abs(u(rng));
    const float reach2 = 0.5f * std::abs(u(rng));
    const ZoneLanes zl = {0.05f, 0.3f, 1.2f, {0.2f, 3.0f, 13.0f}};
    CAPTURE(round, m, K, threshold, near2, reach2);
    // step by step
    NearScratch ref;
    std::size_t counts[3];
    gatherClassify(m, cand.data(), rows, far, q, threshold, near2, reach2, ref, LaneSet::kAvx2, counts);
    std::vector<std::uint64_t> keys(ref.keys.begin(), ref.keys.begin() + static_cast<std::ptrdiff_t>(counts[1]));
    const std::size_t mk = keepSmallest(keys.data(), counts[1], K);
    std::vector<std::uint32_t> js(mk + kLanes);
    std::uint64_t top = 0;
    for (std::size_t c = 0; c < mk; ++c) {
      js[c] = ref.cj[keyIndex(keys[c])];
      top = std::max(top, keys[c]);
    }
    const std::vector<std::uint32_t> chosen(js.begin(), js.begin() + static_cast<std::ptrdiff_t>(mk));
    const Vec3 fRef = zonalForceRows(mk, js.data(), rows, far, q, vq, zl);
    // at once
    NearScratch ns;
    NearSums sums;
    ++tried;
    const float inv2s2 = 1.0f / (2.0f * 0.3f * 0.3f);
    if (!nearSums(m, cand.data(), rows, far, q, vq, threshold, inv2s2, near2, reach2, K, zl, ns, sums)) {
      // only where it may decline: too many candidates, too few near, K beyond 16, or a tie at the K-th place
      bool tieAtK = false;
      if (counts[1] > K) {
        std::vector<float> d2;
        for (std::size_t c = 0; c < counts[1]; ++c) d2.push_back(keyDistance2(ref.keys[c]));
        std::sort(d2.begin(), d2.end());
        tieAtK = d2[K - 1] == d2[K];
      }
      CHECK((m > 48 || K > 16 || counts[1] < K || counts[1] > 32 || counts[0] > 32 || counts[2] > 32 || tieAtK));
      continue;
    }
    ++taken;
    REQUIRE(mk == K);
    for (int c = 0; c < 3; ++c) REQUIRE(sums.counts[c] == counts[c]);
    CHECK(std::equal(chosen.begin(), chosen.end(), ns.chosen.begin()));
    CHECK(sameBits(sums.fInt, fRef));
    CHECK(sums.far2 == keyDistance2(top));
    CHECK(
        std::equal(ref.mdeIdx.begin(), ref.mdeIdx.begin() + static_cast<std::ptrdiff_t>(counts[2]), ns.mdeIdx.begin()));
    // F_con: its sum, or its entries packed (beyond sixteen)
    Vec3 conRef;
    int countRef = 0;
    NearScratch refCopy = ref;
    constraintSumScratch(counts[0], threshold, inv2s2, refCopy, true, conRef, countRef);
    if (sums.conSummed) {
      CHECK(sameBits(sums.conSum, conRef));
      CHECK(sums.conCount == countRef);
    } else {
      CHECK(counts[0] > 16);
      for (std::size_t c = 0; c < counts[0]; ++c) {
        CHECK((ns.dx[c] == ref.dx[c] && ns.dy[c] == ref.dy[c] && ns.dz[c] == ref.dz[c] && ns.d2[c] == ref.d2[c]));
      }
    }
    conCases += counts[0] > 0 && sums.conSummed ? 1 : 0;
    conPacked += sums.conSummed ? 0 : 1;
    threeChunks += m > 32 ? 1 : 0;
  }
  INFO("taken " << taken << " of " << tried << ", " << conCases << " of them with F_con entries, " << conPacked
                << " with them packed, " << threeChunks << " with three chunks");
  CHECK(taken > tried / 5);  // (most of the others have fewer than K near)
  CHECK(conCases > taken / 4);
  CHECK(conPacked > 10);
  CHECK(threeChunks > 10);
}

TEST_CASE("near kernels: fillRows writes each insect's position and velocity as one row, on every lane set",
          "[shape][near_kernel]") {
  std::mt19937 rng(21);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  const std::size_t n = 45;
  std::vector<float> in[6];
  for (auto& a : in) {
    a.resize(n);
    for (float& v : a) v = u(rng);
  }
  in[4][7] = -0.0f;  // a signed zero stays as it is
  for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
    for (const std::size_t first : {std::size_t{0}, std::size_t{5}, std::size_t{16}}) {
      for (std::size_t count = 0; first + count <= n; ++count) {
        std::vector<float> rows(kRowFloats * n, 99.0f);
        fillRows(in[0].data(), in[1].data(), in[2].data(), in[3].data(), in[4].data(), in[5].data(), first, count,
                 rows.data(), lanes);
        for (std::size_t k = 0; k < n; ++k) {
          const bool inside = k >= first && k < first + count;
          const float want[kRowFloats] = {in[0][k], in[1][k], in[2][k], 0.0f, in[3][k], in[4][k], in[5][k], 0.0f};
          for (std::size_t a = 0; a < kRowFloats; ++a) {
            CAPTURE(static_cast<int>(lanes), first, count, k, a);
            const float got = rows[kRowFloats * k + a];
            if (inside) {
              REQUIRE(std::memcmp(&got, &want[a], sizeof got) == 0);
            } else {
              REQUIRE(got == 99.0f);
            }
          }
        }
      }
    }
  }
}
