#include "models/boids/boids_kernel.hpp"

#include <algorithm>
#include <cstring>

#include "core/lanes.hpp"

namespace swarmsim {

namespace {

constexpr float kTiny = 1e-30f;  // floor of squared lengths: the masked-off lanes stay finite

// lane masks (all bits set in the lanes [lo, hi), none elsewhere) for 0 <= lo <= hi <= 8: rangeMask(lo, hi) is
// the offset of one in rangeMasks()
constexpr std::uint32_t rangeMask(std::uint32_t lo, std::uint32_t hi) {
  return static_cast<std::uint32_t>(kLanes) * (lo * (static_cast<std::uint32_t>(kLanes) + 1) + hi);
}
const float* rangeMasks() {
  struct Table {
    alignas(32) float m[(kLanes + 1) * (kLanes + 1) * kLanes];
    Table() {
      for (std::uint32_t lo = 0; lo <= kLanes; ++lo) {
        for (std::uint32_t hi = 0; hi <= kLanes; ++hi) {
          for (std::uint32_t l = 0; l < kLanes; ++l) {
            const std::uint32_t bits = l >= lo && l < hi ? 0xffffffffu : 0u;
            std::memcpy(m + rangeMask(lo, hi) + l, &bits, sizeof bits);
          }
        }
      }
    }
  };
  static const Table table;
  return table.m;
}

#if SWARMSIM_X86_LANES
// base[idx[0..7]] to out[0..7] by one AVX2 gather
SWARMSIM_AVX2 inline void gather8(const float* base, const std::uint32_t* idx, float* out) {
  _mm256_store_ps(out, _mm256_i32gather_ps(base, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(idx)), 4));
}
#endif

// the values base[idx[0..7]] as lanes
// (through memory: no function here without the AVX target passes an AVX vector, which would change the ABI)
template <typename L, bool kAvx2>
inline typename L::V gatherLanes(const float* base, const std::uint32_t* idx) {
  alignas(32) float t[kLanes];
#if SWARMSIM_X86_LANES
  if constexpr (kAvx2) {
    gather8(base, idx, t);
    return L::load(t);
  }
#endif
  for (std::size_t l = 0; l < kLanes; ++l) t[l] = base[idx[l]];
  return L::load(t);
}

// the hits idx[0, m) (sorted positions) into acc, eight at a time, hit e in lane e % 8 (the lanes at or past m
// in the last group are off; idx has room for whole lanes)
template <typename L, bool kAvx2>
inline void addHits(const BoidsLanesInput& in, std::uint32_t* idx, std::size_t m, const typename L::V q[6],
                    const BoidsZones& z, typename L::V acc[9]) {
  using V = typename L::V;
  const V lane = L::load(kLaneIndex), one = L::set1(1.0f), tiny = L::set1(kTiny);
  const V r1 = L::set1(z.r1sq), r2 = L::set1(z.r2sq), cosFov = L::set1(z.cosHalfFov);
  if (m == 0) return;
  for (std::size_t l = m; l % kLanes != 0; ++l) idx[l] = idx[0];  // lanes past m: any valid index (masked off)
  for (std::size_t e = 0; e < m; e += kLanes) {
    const V live = L::lt(lane, L::set1(static_cast<float>(m - e)));
    const V dx = L::sub(gatherLanes<L, kAvx2>(in.x, idx + e), q[0]);
    const V dy = L::sub(gatherLanes<L, kAvx2>(in.y, idx + e), q[1]);
    const V dz = L::sub(gatherLanes<L, kAvx2>(in.z, idx + e), q[2]);
    const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
    const V inv = L::div(one, L::sqrt(L::max(d2, tiny)));
    const V ex = L::mul(dx, inv), ey = L::mul(dy, inv), ez = L::mul(dz, inv);
    const V rep = L::band(live, L::le(d2, r1));
    const V nearer = L::le(d2, r2);
    const V ali = L::andnot(rep, L::band(live, nearer));
    const V dot = L::add(L::add(L::mul(q[3], ex), L::mul(q[4], ey)), L::mul(q[5], ez));
    const V att = L::band(L::andnot(nearer, live), L::le(cosFov, dot));
    acc[0] = L::add(acc[0], L::band(rep, ex));
    acc[1] = L::add(acc[1], L::band(rep, ey));
    acc[2] = L::add(acc[2], L::band(rep, ez));
    acc[3] = L::add(acc[3], L::band(ali, gatherLanes<L, kAvx2>(in.ux.data(), idx + e)));
    acc[4] = L::add(acc[4], L::band(ali, gatherLanes<L, kAvx2>(in.uy.data(), idx + e)));
    acc[5] = L::add(acc[5], L::band(ali, gatherLanes<L, kAvx2>(in.uz.data(), idx + e)));
    acc[6] = L::add(acc[6], L::band(att, ex));
    acc[7] = L::add(acc[7], L::band(att, ey));
    acc[8] = L::add(acc[8], L::band(att, ez));
  }
}

// out[a][0..8] for each agent a0 + a of the cell whose rows are h.chunkStart/chunkLive[0, nChunks) (chunks of up
// to eight sorted positions): the lane-tree sums of rep (before negation), ali and att, axis by axis. Each agent tests the
// chunks eight candidates at a time for those within R3 (squared distances only); the hits' sorted positions
// are packed in scan order and summed eight at a time (hit e in lane e % 8), so square roots and divisions go
// to hits alone. kAvx2: pack by AVX2's table look-up (packSetLanes) and load hits with its gathers (the same
// result as the plain loops).
template <typename L, bool kAvx2>
inline void boidsLanes(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, std::size_t nChunks,
                       const BoidsZones& z, BoidsScratch& h, std::array<float, 9>* out) {
  using V = typename L::V;
  const V r3sq = L::set1(z.r3sq), zero = L::set1(0.0f);
  const float* px = in.x;
  const float* py = in.y;
  const float* pz = in.z;
  const std::uint32_t* chunkStart = h.chunkStart.data();
  const std::uint32_t* chunkLive = h.chunkLive.data();
  const float* masks = rangeMasks();
  std::uint32_t* hit = h.hits.data();
  const std::size_t room = h.hits.size() - 2 * kLanes;
  for (std::uint32_t k = a0; k < a1; ++k) {
    const V q[6] = {L::set1(px[k]), L::set1(py[k]), L::set1(pz[k]),
                    L::set1(in.ux[k]), L::set1(in.uy[k]), L::set1(in.uz[k])};
    V acc[9];
    for (V& a : acc) a = zero;
    std::size_t m = 0;
    // one loop over the cell's chunks (the same trip count for every agent of the cell), no branch on the
    // hits: a chunk without any packs nothing
    for (std::size_t c = 0; c < nChunks; ++c) {
      const std::uint32_t j = chunkStart[c];
      const V live = L::load(masks + chunkLive[c]);  // the lanes in the run
      const V dx = L::sub(L::load(px + j), q[0]), dy = L::sub(L::load(py + j), q[1]);
      const V dz = L::sub(L::load(pz + j), q[2]);
      const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
      m += packSetLanes<kAvx2>(j, L::mask(L::band(live, L::band(L::le(d2, r3sq), L::gt(d2, zero)))), hit + m);
      if (m >= room) {  // full: sum the whole groups, keep the rest at the start
        const std::size_t whole = m / kLanes * kLanes;
        addHits<L, kAvx2>(in, hit, whole, q, z, acc);
        std::copy(hit + whole, hit + m, hit);
        m -= whole;
      }
    }
    addHits<L, kAvx2>(in, hit, m, q, z, acc);
    for (int c = 0; c < 9; ++c) out[k - a0][c] = treeSum<L>(acc[c]);
  }
}

#if SWARMSIM_X86_LANES
#define SWARMSIM_BOIDS_ARGS                                                                               \
  const BoidsLanesInput &in, std::uint32_t a0, std::uint32_t a1, std::size_t nChunks, const BoidsZones &z, \
      BoidsScratch &h, std::array<float, 9> *out
__attribute__((flatten)) void boidsSse(SWARMSIM_BOIDS_ARGS) {
  boidsLanes<SseLanes, false>(in, a0, a1, nChunks, z, h, out);
}
SWARMSIM_AVX __attribute__((flatten)) void boidsAvx(SWARMSIM_BOIDS_ARGS) {
  boidsLanes<AvxLanes, false>(in, a0, a1, nChunks, z, h, out);
}
SWARMSIM_AVX2 __attribute__((flatten)) void boidsAvx2(SWARMSIM_BOIDS_ARGS) {
  boidsLanes<AvxLanes, true>(in, a0, a1, nChunks, z, h, out);
}
#undef SWARMSIM_BOIDS_ARGS
#endif

}  // namespace

void BoidsLanesInput::prepare(const float* px, const float* py, const float* pz, std::size_t count) {
  n = count;
  x = px;
  y = py;
  z = pz;
  if (n < kLanes) {  // too few to shift a chunk back inside them: padded copies
    for (auto* a : {&tx_, &ty_, &tz_}) a->assign(kLanes + kPad, 0.0f);
    std::copy(px, px + n, tx_.begin());
    std::copy(py, py + n, ty_.begin());
    std::copy(pz, pz + n, tz_.begin());
    x = tx_.data();
    y = ty_.data();
    z = tz_.data();
  }
  for (auto* a : {&ux, &uy, &uz}) {
    a->resize(n + kPad);
    std::fill(a->begin() + static_cast<std::ptrdiff_t>(n), a->end(), 0.0f);
  }
}

BoidsScratch::BoidsScratch() {
  hits.resize(kRoom);
  chunkStart.resize(64);
  chunkLive.resize(64);
}

void boidsCellSums(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, const std::uint32_t* runs,
                   std::size_t nRuns, const BoidsZones& zones, LaneSet lanes, BoidsScratch& scratch,
                   std::array<float, 9>* out) {
  static_assert(BoidsLanesInput::kPad >= kLanes, "the hits' gathers may read the unit velocities' padding");
  if (a0 == a1) return;
  // the rows cut into chunks of up to eight
  std::size_t most = 0;
  for (std::size_t r = 0; r < nRuns; ++r) most += (runs[2 * r + 1] - runs[2 * r] + kLanes - 1) / kLanes;
  if (scratch.chunkStart.size() < most) {
    scratch.chunkStart.resize(2 * most);
    scratch.chunkLive.resize(2 * most);
  }
  std::uint32_t* start = scratch.chunkStart.data();
  std::uint32_t* live = scratch.chunkLive.data();
  // a chunk loads eight positions from its start: one that would read past the last agent starts earlier (by
  // `back` lanes), its run's lanes then [back, back + size); fewer than eight agents are padded (prepare)
  const std::size_t last = std::max<std::size_t>(in.n, kLanes) - kLanes;
  std::size_t nChunks = 0;
  for (std::size_t r = 0; r < nRuns; ++r) {
    const std::uint32_t b = runs[2 * r], e = runs[2 * r + 1];
    for (std::uint32_t j = b; j < e; j += kLanes, ++nChunks) {
      const std::uint32_t back = j > last ? static_cast<std::uint32_t>(j - last) : 0u;
      const std::uint32_t end = back + std::min<std::uint32_t>(e - j, kLanes);
      start[nChunks] = j - back;
      live[nChunks] = rangeMask(back, end);
    }
  }
#if SWARMSIM_X86_LANES
  switch (lanes) {
    case LaneSet::kAvx2:
    case LaneSet::kAvx512:  // (no AVX-512 variant: sixteen lanes measured no faster, docs/performance.md)
      boidsAvx2(in, a0, a1, nChunks, zones, scratch, out);
      break;
    case LaneSet::kAvx:
      boidsAvx(in, a0, a1, nChunks, zones, scratch, out);
      break;
    default:
      boidsSse(in, a0, a1, nChunks, zones, scratch, out);
  }
#else
  (void)lanes;
  boidsLanes<ScalarLanes, false>(in, a0, a1, nChunks, zones, scratch, out);
#endif
}

}  // namespace swarmsim
