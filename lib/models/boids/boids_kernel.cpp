#include "models/boids/boids_kernel.hpp"

#include <algorithm>

#include "core/lanes.hpp"

namespace swarmsim {

namespace {

constexpr float kFar = 3.0e38f;  // the padding's coordinates: its squared distance to any agent is +inf
constexpr std::size_t kBlock = 16;

// the cell's candidates: six arrays of `stride` floats in one buffer, `room` of them used (whole sixteens)
struct Candidates {
  const float *x, *y, *z, *ux, *uy, *uz;
  std::size_t room;
};

// Copy::run(in, b, e, a, at) puts the candidates [b, e) at index `at` of the six arrays a, and may write up to
// Copy::kSlack floats past e - b (each array has that room beyond `room`); the rest of the last sixteen becomes
// padding
template <typename Copy>
inline Candidates gatherCandidates(const BoidsLanesInput& in, const std::uint32_t* runs, std::size_t nRuns,
                                   std::vector<float>& buffer) {
  constexpr std::size_t slack = Copy::kSlack;
  std::size_t total = 0;
  for (std::size_t r = 0; r < nRuns; ++r) total += runs[2 * r + 1] - runs[2 * r];
  const std::size_t room = (total + kBlock - 1) / kBlock * kBlock;
  const std::size_t stride = room + std::max(slack, kBlock);
  if (buffer.size() < 6 * stride) buffer.resize(6 * stride);  // (grows only: no allocation once sized)
  float* base = buffer.data();
  float* a[6] = {base, base + stride, base + 2 * stride, base + 3 * stride, base + 4 * stride, base + 5 * stride};
  std::size_t at = 0;
  for (std::size_t r = 0; r < nRuns; ++r) {
    Copy::run(in, runs[2 * r], runs[2 * r + 1], a, at);
    at += runs[2 * r + 1] - runs[2 * r];
  }
  for (std::size_t e = total; e < room; ++e) {
    a[0][e] = a[1][e] = a[2][e] = kFar;
    a[3][e] = a[4][e] = a[5][e] = 0.0f;
  }
  return {a[0], a[1], a[2], a[3], a[4], a[5], room};
}

// element by element (any CPU)
struct CopyPlain {
  static constexpr std::size_t kSlack = 0;
  static void run(const BoidsLanesInput& in, std::uint32_t b, std::uint32_t e, float* const a[6], std::size_t at) {
    const float* from[6] = {in.x, in.y, in.z, in.ux.data(), in.uy.data(), in.uz.data()};
    for (int c = 0; c < 6; ++c) std::copy(from[c] + b, from[c] + e, a[c] + at);
  }
};

// the sums of one agent over eight candidates at index e of the arrays, into acc (the zones' terms, kernel header)
// (q: the agent's position and unit velocity, broadcast where used, so that its nine sums keep the registers).
// Every eight is computed, with or without a neighbour: a branch on that cost 13 % at 1 thread on an AMD Zen 4.
template <typename L>
inline void addEight(const Candidates& c, std::size_t e, const float q[6], const BoidsZones& z, typename L::V acc[9]) {
  using V = typename L::V;
  const V zero = L::set1(0.0f);
  const V dx = L::sub(L::load(c.x + e), L::set1(q[0])), dy = L::sub(L::load(c.y + e), L::set1(q[1]));
  const V dz = L::sub(L::load(c.z + e), L::set1(q[2]));
  const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
  const V hit = L::band(L::le(d2, L::set1(z.r3sq)), L::gt(d2, zero));
  // (1 / |d|: finite for every neighbour, d² > 0; inf or NaN in the lanes without one, which add nothing)
  const V inv = L::div(L::set1(1.0f), L::sqrt(d2));
  const V ex = L::mul(dx, inv), ey = L::mul(dy, inv), ez = L::mul(dz, inv);
  const V rep = L::band(hit, L::le(d2, L::set1(z.r1sq)));
  const V nearer = L::le(d2, L::set1(z.r2sq));
  const V ali = L::andnot(rep, L::band(hit, nearer));
  const V dot = L::add(L::add(L::mul(L::set1(q[3]), ex), L::mul(L::set1(q[4]), ey)), L::mul(L::set1(q[5]), ez));
  const V att = L::band(L::andnot(nearer, hit), L::le(L::set1(z.cosHalfFov), dot));
  acc[0] = L::add(acc[0], L::band(rep, ex));
  acc[1] = L::add(acc[1], L::band(rep, ey));
  acc[2] = L::add(acc[2], L::band(rep, ez));
  acc[3] = L::add(acc[3], L::band(ali, L::load(c.ux + e)));
  acc[4] = L::add(acc[4], L::band(ali, L::load(c.uy + e)));
  acc[5] = L::add(acc[5], L::band(ali, L::load(c.uz + e)));
  acc[6] = L::add(acc[6], L::band(att, ex));
  acc[7] = L::add(acc[7], L::band(att, ey));
  acc[8] = L::add(acc[8], L::band(att, ez));
}

// every agent of the cell on eight lanes: lanes 0-7 of every sixteen in nine sums, then lanes 8-15 in nine more
// (one set at a time: nine sums and the temporaries fit sixteen AVX registers, eighteen do not), added at the end
template <typename L>
inline void boidsLanes(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, const Candidates& c,
                       const BoidsZones& z, float* const out[9]) {
  using V = typename L::V;
  for (std::uint32_t k = a0; k < a1; ++k) {
    const float q[6] = {in.x[k], in.y[k], in.z[k], in.ux[k], in.uy[k], in.uz[k]};
    V lo[9], hi[9];
    for (int a = 0; a < 9; ++a) lo[a] = L::set1(0.0f);
    for (std::size_t e = 0; e < c.room; e += kBlock) addEight<L>(c, e, q, z, lo);
    for (int a = 0; a < 9; ++a) hi[a] = L::set1(0.0f);
    for (std::size_t e = kLanes; e < c.room; e += kBlock) addEight<L>(c, e, q, z, hi);
    V eight[9];
    for (int a = 0; a < 9; ++a) eight[a] = L::add(lo[a], hi[a]);
    float sums[8];
    treeSums8<L>(eight, sums);  // (treeSum of each: the same bits)
    for (int a = 0; a < 8; ++a) out[a][k - a0] = sums[a];
    out[8][k - a0] = treeSum<L>(eight[8]);
  }
}

#if SWARMSIM_X86_LANES
// eight floats at a time by masked loads (none read past e), whole stores into the arrays' slack
struct CopyAvx {
  static constexpr std::size_t kSlack = 8;
  SWARMSIM_AVX static void run(const BoidsLanesInput& in, std::uint32_t b, std::uint32_t e, float* const a[6],
                               std::size_t at) {
    const float* from[6] = {in.x, in.y, in.z, in.ux.data(), in.uy.data(), in.uz.data()};
    const __m256 laneIndex = _mm256_load_ps(kLaneIndex);
    for (std::uint32_t j = b; j < e; j += 8) {
      const __m256i live =
          _mm256_castps_si256(_mm256_cmp_ps(laneIndex, _mm256_set1_ps(static_cast<float>(e - j)), _CMP_LT_OQ));
      for (int c = 0; c < 6; ++c) _mm256_storeu_ps(a[c] + at + (j - b), _mm256_maskload_ps(from[c] + j, live));
    }
  }
};
// sixteen at a time by masked loads
struct CopyAvx512 {
  static constexpr std::size_t kSlack = 16;
  SWARMSIM_AVX512 static void run(const BoidsLanesInput& in, std::uint32_t b, std::uint32_t e, float* const a[6],
                                  std::size_t at) {
    const float* from[6] = {in.x, in.y, in.z, in.ux.data(), in.uy.data(), in.uz.data()};
    for (std::uint32_t j = b; j < e; j += 16) {
      const auto live = static_cast<__mmask16>(firstLanes(e - j, 16));
      for (int c = 0; c < 6; ++c) _mm512_storeu_ps(a[c] + at + (j - b), _mm512_maskz_loadu_ps(live, from[c] + j));
    }
  }
};

// boidsLanes on sixteen lanes: each operation as the eight-lane kernel does it per lane; the neighbour terms by
// masked additions (a lane left out keeps its sum, as adding the eight-lane kernel's zero does). Every sixteen is
// computed, with or without a neighbour: a branch on that costs more here (9 % at 1 thread on an AMD Zen 4)
// than the sixteen's work
SWARMSIM_AVX512 __attribute__((flatten)) void boidsAvx512(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1,
                                                          const Candidates& c, const BoidsZones& z,
                                                          float* const out[9]) {
  const __m512 r1 = _mm512_set1_ps(z.r1sq), r2 = _mm512_set1_ps(z.r2sq), r3 = _mm512_set1_ps(z.r3sq);
  const __m512 cosFov = _mm512_set1_ps(z.cosHalfFov), zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.0f);
  for (std::uint32_t k = a0; k < a1; ++k) {
    const __m512 qx = _mm512_set1_ps(in.x[k]), qy = _mm512_set1_ps(in.y[k]), qz = _mm512_set1_ps(in.z[k]);
    const __m512 ux = _mm512_set1_ps(in.ux[k]), uy = _mm512_set1_ps(in.uy[k]), uz = _mm512_set1_ps(in.uz[k]);
    __m512 acc[9];
    for (__m512& a : acc) a = zero;
    for (std::size_t e = 0; e < c.room; e += kBlock) {
      const __m512 dx = _mm512_sub_ps(_mm512_loadu_ps(c.x + e), qx);
      const __m512 dy = _mm512_sub_ps(_mm512_loadu_ps(c.y + e), qy);
      const __m512 dz = _mm512_sub_ps(_mm512_loadu_ps(c.z + e), qz);
      const __m512 d2 =
          _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
      const __mmask16 hit = _mm512_mask_cmp_ps_mask(_mm512_cmp_ps_mask(d2, r3, _CMP_LE_OQ), d2, zero, _CMP_GT_OQ);
      const __m512 inv = _mm512_div_ps(one, _mm512_maskz_sqrt_ps(0xffff, d2));
      const __m512 ex = _mm512_mul_ps(dx, inv), ey = _mm512_mul_ps(dy, inv), ez = _mm512_mul_ps(dz, inv);
      const __mmask16 rep = _mm512_mask_cmp_ps_mask(hit, d2, r1, _CMP_LE_OQ);
      const __mmask16 nearer = _mm512_mask_cmp_ps_mask(hit, d2, r2, _CMP_LE_OQ);
      const auto ali = static_cast<__mmask16>(nearer & ~rep);
      const __m512 dot =
          _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(ux, ex), _mm512_mul_ps(uy, ey)), _mm512_mul_ps(uz, ez));
      const __mmask16 att = _mm512_mask_cmp_ps_mask(static_cast<__mmask16>(hit & ~nearer), cosFov, dot, _CMP_LE_OQ);
      acc[0] = _mm512_mask_add_ps(acc[0], rep, acc[0], ex);
      acc[1] = _mm512_mask_add_ps(acc[1], rep, acc[1], ey);
      acc[2] = _mm512_mask_add_ps(acc[2], rep, acc[2], ez);
      acc[3] = _mm512_mask_add_ps(acc[3], ali, acc[3], _mm512_loadu_ps(c.ux + e));
      acc[4] = _mm512_mask_add_ps(acc[4], ali, acc[4], _mm512_loadu_ps(c.uy + e));
      acc[5] = _mm512_mask_add_ps(acc[5], ali, acc[5], _mm512_loadu_ps(c.uz + e));
      acc[6] = _mm512_mask_add_ps(acc[6], att, acc[6], ex);
      acc[7] = _mm512_mask_add_ps(acc[7], att, acc[7], ey);
      acc[8] = _mm512_mask_add_ps(acc[8], att, acc[8], ez);
    }
    // lanes l and l + 8 added, then the eight lanes' tree (treeSum's order; eight of the sums at once)
    AvxLanes::V eight[9];
    for (int a = 0; a < 9; ++a) {
      const __m256d lo = _mm512_maskz_extractf64x4_pd(0xf, _mm512_castps_pd(acc[a]), 0);
      const __m256d hi = _mm512_maskz_extractf64x4_pd(0xf, _mm512_castps_pd(acc[a]), 1);
      eight[a].a = _mm256_add_ps(_mm256_castpd_ps(lo), _mm256_castpd_ps(hi));
    }
    float sums[8];
    treeSums8<AvxLanes>(eight, sums);
    for (int a = 0; a < 8; ++a) out[a][k - a0] = sums[a];
    out[8][k - a0] = treeSum<AvxLanes>(eight[8]);
  }
}

#define SWARMSIM_BOIDS_ARGS                                                                                    \
  const BoidsLanesInput &in, std::uint32_t a0, std::uint32_t a1, const std::uint32_t *runs, std::size_t nRuns, \
      const BoidsZones &z, BoidsScratch &h, float *const out[9]
__attribute__((flatten)) void boidsSse(SWARMSIM_BOIDS_ARGS) {
  boidsLanes<SseLanes>(in, a0, a1, gatherCandidates<CopyPlain>(in, runs, nRuns, h.candidates), z, out);
}
SWARMSIM_AVX __attribute__((flatten)) void boidsAvx(SWARMSIM_BOIDS_ARGS) {
  boidsLanes<AvxLanes>(in, a0, a1, gatherCandidates<CopyAvx>(in, runs, nRuns, h.candidates), z, out);
}
SWARMSIM_AVX512 __attribute__((flatten)) void boidsAvx512Cell(SWARMSIM_BOIDS_ARGS) {
  boidsAvx512(in, a0, a1, gatherCandidates<CopyAvx512>(in, runs, nRuns, h.candidates), z, out);
}
#undef SWARMSIM_BOIDS_ARGS
#endif

}  // namespace

void BoidsLanesInput::prepare(const float* px, const float* py, const float* pz, std::size_t count) {
  n = count;
  x = px;
  y = py;
  z = pz;
  for (auto* a : {&ux, &uy, &uz}) a->resize(n);
}

void boidsCellSums(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, const std::uint32_t* runs,
                   std::size_t nRuns, const BoidsZones& zones, LaneSet lanes, BoidsScratch& scratch,
                   float* const out[9]) {
  if (a0 == a1) return;
#if SWARMSIM_X86_LANES
  switch (lanes) {
    case LaneSet::kAvx512:
      boidsAvx512Cell(in, a0, a1, runs, nRuns, zones, scratch, out);
      break;
    case LaneSet::kAvx2:
    case LaneSet::kAvx:
      boidsAvx(in, a0, a1, runs, nRuns, zones, scratch, out);
      break;
    default:
      boidsSse(in, a0, a1, runs, nRuns, zones, scratch, out);
  }
#else
  (void)lanes;
  boidsLanes<ScalarLanes>(in, a0, a1, gatherCandidates<CopyPlain>(in, runs, nRuns, scratch.candidates), zones, out);
#endif
}

}  // namespace swarmsim
