#include "models/shape/near_kernel.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/lanes.hpp"
#include "spatial/nearest.hpp"

namespace swarmsim {

namespace {

constexpr float kTiny = 1e-30f;  // floor of squared lengths: a zero vector times a finite reciprocal stays zero

inline std::size_t padded(std::size_t m) { return (m + kLanes - 1) / kLanes * kLanes; }

// lanes 0..7 in order: the same bits for every lane type
inline float laneSum(const float* l) {
  float s = l[0];
  for (std::size_t i = 1; i < kLanes; ++i) s += l[i];
  return s;
}

template <typename L>
inline void constraintLanes(const NearScratch& s, std::size_t m, float threshold, float inv2s2, float out[3][kLanes],
                            int& count) {
  using V = typename L::V;
  V sx = L::set1(0.0f), sy = sx, sz = sx;
  const V thr = L::set1(threshold), c = L::set1(-inv2s2), zero = L::set1(0.0f), tiny = L::set1(kTiny);
  const V sign = L::set1(-0.0f);
  int n = 0;
  for (std::size_t e = 0; e < m; e += kLanes) {
    const V dx = L::load(s.dx.data() + e), dy = L::load(s.dy.data() + e), dz = L::load(s.dz.data() + e);
    const V d2 = L::load(s.d2.data() + e);
    const V man = L::add(L::add(L::andnot(sign, dx), L::andnot(sign, dy)), L::andnot(sign, dz));
    const V in = L::band(L::lt(man, thr), L::gt(d2, zero));
    if (L::mask(in) == 0) continue;
    const V w = L::band(in, L::div(expLanes<L>(L::mul(L::mul(man, man), c)), L::sqrt(L::max(d2, tiny))));
    sx = L::add(sx, L::mul(dx, w));
    sy = L::add(sy, L::mul(dy, w));
    sz = L::add(sz, L::mul(dz, w));
    n += L::count(in);
  }
  L::store(out[0], sx);
  L::store(out[1], sy);
  L::store(out[2], sz);
  count = n;
}

// F_int's zonal sums: one block of eight entries added to acc (acc[3 z + a]: zone z's unit vectors, axis a;
// acc[9 + z]: how many entries zone z has)
template <typename L>
__attribute__((always_inline)) inline void zonalBlock(typename L::V dx, typename L::V dy, typename L::V dz,
                                                      typename L::V d2, typename L::V ux, typename L::V uy,
                                                      typename L::V uz, const ZoneLanes& z, typename L::V acc[12]) {
  using V = typename L::V;
  const V one = L::set1(1.0f), tiny = L::set1(kTiny);
  const V rep2 = L::set1(z.rep2), ali2 = L::set1(z.ali2), att2 = L::set1(z.att2);
  const V u2 = L::add(L::add(L::mul(ux, ux), L::mul(uy, uy)), L::mul(uz, uz));
  const V inRep = L::lt(d2, rep2), inNear = L::lt(d2, ali2);
  const V inAli = L::andnot(inRep, inNear), inAtt = L::andnot(inNear, L::le(d2, att2));
  const V invd = L::div(one, L::sqrt(L::max(d2, tiny)));
  const V invu = L::div(one, L::sqrt(L::max(u2, tiny)));
  const V wr = L::band(inRep, invd), wl = L::band(inAli, invu), wa = L::band(inAtt, invd);
  acc[0] = L::add(acc[0], L::mul(dx, wr));
  acc[1] = L::add(acc[1], L::mul(dy, wr));
  acc[2] = L::add(acc[2], L::mul(dz, wr));
  acc[3] = L::add(acc[3], L::mul(ux, wl));
  acc[4] = L::add(acc[4], L::mul(uy, wl));
  acc[5] = L::add(acc[5], L::mul(uz, wl));
  acc[6] = L::add(acc[6], L::mul(dx, wa));
  acc[7] = L::add(acc[7], L::mul(dy, wa));
  acc[8] = L::add(acc[8], L::mul(dz, wa));
  acc[9] = L::add(acc[9], L::band(inRep, one));  // counts as floats: exact far beyond any K
  acc[10] = L::add(acc[10], L::band(inAli, one));
  acc[11] = L::add(acc[11], L::band(inAtt, one));
}

// every lane sum of acc (an empty zone's are not used), eight at a time, to out[12]
template <typename L>
__attribute__((always_inline)) inline void zonalSums(const typename L::V acc[12], float out[12]) {
  using V = typename L::V;
  const V zero = L::set1(0.0f);
  const V rest[8] = {acc[8], acc[9], acc[10], acc[11], zero, zero, zero, zero};
  float tail[8];
  treeSums8<L>(acc, out);
  treeSums8<L>(rest, tail);
  for (int c = 8; c < 12; ++c) out[c] = tail[c - 8];
}

// F_int's zonal sums over m (a multiple of kLanes) entries of scratch.dx/dy/dz/d2/ux/uy/uz, to out[12]
template <typename L>
inline void zonalLanes(const NearScratch& s, std::size_t m, const ZoneLanes& z, float out[12]) {
  using V = typename L::V;
  V acc[12];
  for (V& a : acc) a = L::set1(0.0f);
  for (std::size_t e = 0; e < m; e += kLanes) {
    zonalBlock<L>(L::load(s.dx.data() + e), L::load(s.dy.data() + e), L::load(s.dz.data() + e),
                  L::load(s.d2.data() + e), L::load(s.ux.data() + e), L::load(s.uy.data() + e),
                  L::load(s.uz.data() + e), z, acc);
  }
  zonalSums<L>(acc, out);
}

// the candidates' positions for classifyLanes: eight at a time from scratch.cx/cy/cz
template <typename L>
struct ScratchPositions {
  const NearScratch& s;
  void operator()(std::size_t e, typename L::V& x, typename L::V& y, typename L::V& z) const {
    x = L::load(s.cx.data() + e);
    y = L::load(s.cy.data() + e);
    z = L::load(s.cz.data() + e);
  }
};

#if SWARMSIM_X86_LANES
// the keys neighbourKey(d2[l], base + l) of the set lanes l of `mask`, in order, to out[0, popcount) (writes
// eight): the index pack's lane permutation applied to the squared distances' bits, then each index and its
// distance's bits interleaved into one 64-bit key (d2: eight floats in memory, as packLaneFloats takes them)
SWARMSIM_AVX2 inline void packNearKeys(unsigned mask, std::uint32_t base, const float* d2, std::uint64_t* out) {
  const __m256i pick = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanePack.lanes[mask]));
  const __m256i index = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(base)), pick);
  const __m256i bits = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(d2)), pick);
  const __m256i lo = _mm256_unpacklo_epi32(index, bits),
                hi = _mm256_unpackhi_epi32(index, bits);  // keys 0 1 4 5, 2 3 6 7
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), _mm256_permute2x128_si256(lo, hi, 0x20));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + 4), _mm256_permute2x128_si256(lo, hi, 0x31));
}
#endif

// kAvx2: the indices of each class packed by an AVX2 table look-up (packSetLanes), without a branch per
// entry; the same result as the loop over the set bits. `positions(e, x, y, z)` gives candidates e..e+7.
template <typename L, bool kAvx2, typename Positions>
inline void classifyLanes(std::size_t m, float qx, float qy, float qz, float threshold, float near2, float reach2,
                          NearScratch& s, std::size_t counts[3], const Positions& positions) {
  using V = typename L::V;
  const V vx = L::set1(qx), vy = L::set1(qy), vz = L::set1(qz), thr = L::set1(threshold);
  const V vnear = L::set1(near2), vreach = L::set1(reach2), zero = L::set1(0.0f), sign = L::set1(-0.0f);
  std::uint32_t* con = s.conIdx.data();
  std::uint32_t* md = s.mdeIdx.data();
  std::size_t nc = 0, nn = 0, nm = 0;
  for (std::size_t e = 0; e < m; e += kLanes) {
    V px, py, pz;
    positions(e, px, py, pz);
    const V dx = L::sub(px, vx), dy = L::sub(py, vy), dz = L::sub(pz, vz);
    const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
    L::store(s.cx.data() + e, dx);
    L::store(s.cy.data() + e, dy);
    L::store(s.cz.data() + e, dz);
    L::store(s.cd2.data() + e, d2);
    const V man = L::add(L::add(L::andnot(sign, dx), L::andnot(sign, dy)), L::andnot(sign, dz));
    const auto base = static_cast<std::uint32_t>(e);
    const unsigned inCon = L::mask(L::band(L::lt(man, thr), L::gt(d2, zero)));
    const unsigned inNear = L::mask(L::le(d2, vnear)), inReach = L::mask(L::le(d2, vreach));
#if SWARMSIM_X86_LANES
    // F_con's entries packed on the way (below: by their indices); few chunks have any (under one an insect on
    // the gathered swarms), so the branch is cheaper than the permutes
    if constexpr (kAvx2) {
      if (inCon != 0) {
        packLaneFloats(inCon, s.cx.data() + e, s.dx.data() + nc);
        packLaneFloats(inCon, s.cy.data() + e, s.dy.data() + nc);
        packLaneFloats(inCon, s.cz.data() + e, s.dz.data() + nc);
        packLaneFloats(inCon, s.cd2.data() + e, s.d2.data() + nc);
      }
    }
#endif
    if (inCon != 0) nc += packSetLanes<kAvx2>(base, inCon, con + nc);
      // F_int's candidates as keys (neighbourKey: the squared distance's bits, then the index)
#if SWARMSIM_X86_LANES
    if constexpr (kAvx2) {
      packNearKeys(inNear, base, s.cd2.data() + e, s.keys.data() + nn);
      nn += static_cast<std::size_t>(__builtin_popcount(inNear));
    }
#endif
    if constexpr (!kAvx2) {
      for (unsigned bits = inNear; bits; bits &= bits - 1u) {
        const std::uint32_t j = base + static_cast<std::uint32_t>(__builtin_ctz(bits));
        s.keys[nn++] = neighbourKey(s.cd2[j], j);
      }
    }
    if (inReach != 0) nm += packSetLanes<kAvx2>(base, inReach, md + nm);  // (as rare as F_con's)
  }
  if constexpr (!kAvx2) {
    for (std::size_t c = 0; c < nc; ++c) {
      const std::uint32_t e = con[c];
      s.dx[c] = s.cx[e];
      s.dy[c] = s.cy[e];
      s.dz[c] = s.cz[e];
      s.d2[c] = s.cd2[e];
    }
  }
  counts[0] = nc;
  counts[1] = nn;
  counts[2] = nm;
}

#if SWARMSIM_X86_LANES
// the candidates' positions for gatherClassify: the sorted positions cand[e..e+7] (past m: the far row, in
// no class) go to scratch.cj, and the first 16 bytes of their rows are transposed to three vectors
struct RowPositions {
  const std::uint32_t* cand;
  std::size_t m;
  const float* rows;
  std::uint32_t far;
  std::uint32_t* cj;
  SWARMSIM_AVX2 __m128 row(std::uint32_t i) const { return _mm_loadu_ps(rows + kRowFloats * std::size_t{i}); }
  SWARMSIM_AVX2 void operator()(std::size_t e, AvxLanes::V& x, AvxLanes::V& y, AvxLanes::V& z) const {
    __m256i pos;
    if (m - e >= kLanes) {
      pos = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(cand + e));
    } else {
      const __m256i in = _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(m - e)),
                                            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
      pos = _mm256_blendv_epi8(_mm256_set1_epi32(static_cast<int>(far)),
                               _mm256_maskload_epi32(reinterpret_cast<const int*>(cand + e), in), in);
    }
    alignas(32) std::uint32_t j[kLanes];
    _mm256_store_si256(reinterpret_cast<__m256i*>(j), pos);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(cj + e), pos);
    const __m256 a0 = _mm256_insertf128_ps(_mm256_castps128_ps256(row(j[0])), row(j[4]), 1);
    const __m256 a1 = _mm256_insertf128_ps(_mm256_castps128_ps256(row(j[1])), row(j[5]), 1);
    const __m256 a2 = _mm256_insertf128_ps(_mm256_castps128_ps256(row(j[2])), row(j[6]), 1);
    const __m256 a3 = _mm256_insertf128_ps(_mm256_castps128_ps256(row(j[3])), row(j[7]), 1);
    const __m256 t0 = _mm256_unpacklo_ps(a0, a1), t1 = _mm256_unpackhi_ps(a0, a1);
    const __m256 t2 = _mm256_unpacklo_ps(a2, a3), t3 = _mm256_unpackhi_ps(a2, a3);
    x.a = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
    y.a = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
    z.a = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
  }
};
#endif

#if SWARMSIM_X86_LANES
__attribute__((flatten)) void classifySse(std::size_t m, float qx, float qy, float qz, float t, float n2, float r2,
                                          NearScratch& s, std::size_t c[3]) {
  classifyLanes<SseLanes, false>(m, qx, qy, qz, t, n2, r2, s, c, ScratchPositions<SseLanes>{s});
}
SWARMSIM_AVX __attribute__((flatten)) void classifyAvx(std::size_t m, float qx, float qy, float qz, float t, float n2,
                                                       float r2, NearScratch& s, std::size_t c[3]) {
  classifyLanes<AvxLanes, false>(m, qx, qy, qz, t, n2, r2, s, c, ScratchPositions<AvxLanes>{s});
}
SWARMSIM_AVX2 __attribute__((flatten)) void classifyAvx2(std::size_t m, float qx, float qy, float qz, float t,
                                                         float n2, float r2, NearScratch& s, std::size_t c[3]) {
  classifyLanes<AvxLanes, true>(m, qx, qy, qz, t, n2, r2, s, c, ScratchPositions<AvxLanes>{s});
}
// classifyLanes<AvxLanes, true> of candidates given by sorted position (RowPositions)
SWARMSIM_AVX2 __attribute__((flatten)) void gatherClassifyAvx2(std::size_t m, const std::uint32_t* cand,
                                                               const float* rows, std::uint32_t far, float qx,
                                                               float qy, float qz, float threshold, float near2,
                                                               float reach2, NearScratch& s, std::size_t counts[3]) {
  classifyLanes<AvxLanes, true>(m, qx, qy, qz, threshold, near2, reach2, s, counts,
                                RowPositions{cand, m, rows, far, s.cj.data()});
}
// zonalLanes of the neighbours at sorted positions js[0, m), from their rows: each row (x, y, z, 0, vx, vy, vz, 0)
// less (q, 0, v, 0), eight rows transposed to the lanes (row q in lane q % 8), the squared distance as
// classifyLanes computes it; js is padded to whole lanes with the far row (beyond every zone)
SWARMSIM_AVX2 __attribute__((flatten)) void zonalRowsAvx2(std::size_t m, const std::uint32_t* js, const float* rows,
                                                          float qx, float qy, float qz, float vx,
                                                          float vy, float vz, const ZoneLanes& z, float out[12]) {
  using V = AvxLanes::V;
  V acc[12];
  for (V& a : acc) a = AvxLanes::set1(0.0f);
  const __m256 self = _mm256_setr_ps(qx, qy, qz, 0.0f, vx, vy, vz, 0.0f);
  for (std::size_t e = 0; e < m; e += kLanes) {
    __m256 r[kLanes];
    for (std::size_t l = 0; l < kLanes; ++l) {
      r[l] = _mm256_sub_ps(_mm256_load_ps(rows + kRowFloats * std::size_t{js[e + l]}), self);
    }
    const __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpackhi_ps(r[0], r[1]);
    const __m256 t2 = _mm256_unpacklo_ps(r[2], r[3]), t3 = _mm256_unpackhi_ps(r[2], r[3]);
    const __m256 t4 = _mm256_unpacklo_ps(r[4], r[5]), t5 = _mm256_unpackhi_ps(r[4], r[5]);
    const __m256 t6 = _mm256_unpacklo_ps(r[6], r[7]), t7 = _mm256_unpackhi_ps(r[6], r[7]);
    // rows 0-3 | 4-7 of each: (x | vx), (y | vy), (z | vz)
    const __m256 a0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)), b0 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(1, 0, 1, 0));
    const __m256 a1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2)), b1 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(3, 2, 3, 2));
    const __m256 a2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)), b2 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(1, 0, 1, 0));
    const V dx{_mm256_permute2f128_ps(a0, b0, 0x20)}, ux{_mm256_permute2f128_ps(a0, b0, 0x31)};
    const V dy{_mm256_permute2f128_ps(a1, b1, 0x20)}, uy{_mm256_permute2f128_ps(a1, b1, 0x31)};
    const V dz{_mm256_permute2f128_ps(a2, b2, 0x20)}, uz{_mm256_permute2f128_ps(a2, b2, 0x31)};
    const V d2 = AvxLanes::add(AvxLanes::add(AvxLanes::mul(dx, dx), AvxLanes::mul(dy, dy)), AvxLanes::mul(dz, dz));
    zonalBlock<AvxLanes>(dx, dy, dz, d2, ux, uy, uz, z, acc);
  }
  zonalSums<AvxLanes>(acc, out);
}

__attribute__((flatten)) void constraintSse(const NearScratch& s, std::size_t m, float t, float c, float o[3][kLanes],
                                            int& n) {
  constraintLanes<SseLanes>(s, m, t, c, o, n);
}
SWARMSIM_AVX __attribute__((flatten)) void constraintAvx(const NearScratch& s, std::size_t m, float t, float c,
                                                         float o[3][kLanes], int& n) {
  constraintLanes<AvxLanes>(s, m, t, c, o, n);
}
__attribute__((flatten)) void zonalSse(const NearScratch& s, std::size_t m, const ZoneLanes& z, float o[12]) {
  zonalLanes<SseLanes>(s, m, z, o);
}
SWARMSIM_AVX __attribute__((flatten)) void zonalAvx(const NearScratch& s, std::size_t m, const ZoneLanes& z,
                                                    float o[12]) {
  zonalLanes<AvxLanes>(s, m, z, o);
}
#endif

#if SWARMSIM_X86_LANES
// farthestRow2 on eight AVX2 lanes (the lanes past m hold 0; the row offsets in 32 bits: pos < 2^28)
SWARMSIM_AVX2 float farthestRow2Avx2(std::size_t m, const std::uint32_t* prev, const std::uint32_t* pos,
                                     const float* rows, float qx, float qy, float qz) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256 vx = _mm256_set1_ps(qx), vy = _mm256_set1_ps(qy), vz = _mm256_set1_ps(qz);
  __m256 best = _mm256_setzero_ps();
  for (std::size_t e = 0; e < m; e += kLanes) {
    const __m256i in = _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(std::min(m - e, kLanes))), lane);
    const __m256i which = _mm256_maskload_epi32(reinterpret_cast<const int*>(prev + e), in);
    const __m256i at =
        _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), reinterpret_cast<const int*>(pos), which, in, 4);
    const __m256i off = _mm256_slli_epi32(at, 3);  // kRowFloats floats a row
    const __m256 inf = _mm256_castsi256_ps(in);
    const __m256 x = _mm256_mask_i32gather_ps(vx, rows, off, inf, 4);
    const __m256 y = _mm256_mask_i32gather_ps(vy, rows + 1, off, inf, 4);
    const __m256 z = _mm256_mask_i32gather_ps(vz, rows + 2, off, inf, 4);
    const __m256 dx = _mm256_sub_ps(x, vx), dy = _mm256_sub_ps(y, vy), dz = _mm256_sub_ps(z, vz);
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    best = _mm256_max_ps(best, d2);
  }
  alignas(32) float l[kLanes];
  _mm256_store_ps(l, best);
  float far2 = 0.0f;
  for (const float v : l) far2 = std::max(far2, v);
  return far2;
}
#endif

}  // namespace

void NearScratch::reserve(std::size_t n) {
  if (dx.size() >= n) return;
  const std::size_t cap = padded(n + n / 2 + 16);
  for (auto* v : {&dx, &dy, &dz, &d2, &ux, &uy, &uz}) v->resize(cap);
}

void NearScratch::growCandidates(std::size_t n) {
  const std::size_t cap = padded(n + n / 2 + 32);
  reserve(cap);
  for (auto* v : {&cx, &cy, &cz, &cd2}) v->resize(cap);
  for (auto* v : {&cj, &conIdx, &mdeIdx, &chosen}) v->resize(cap);
  if (keys.size() < cap) keys.resize(cap);
  room_ = cap;
}

void constraintSumScratch(std::size_t m, float threshold, float inv2s2, NearScratch& s, bool avx, Vec3& sum,
                          int& count) {
  if (m == 0) {  // nothing counts: what the lanes would give
    sum = Vec3::Zero();
    count = 0;
    return;
  }
  const std::size_t mp = padded(m);
  s.reserve(mp);
  for (std::size_t e = m; e < mp; ++e) s.dx[e] = s.dy[e] = s.dz[e] = s.d2[e] = 0.0f;  // d2 = 0: not counted
  alignas(32) float lanes[3][kLanes];
#if SWARMSIM_X86_LANES
  avx ? constraintAvx(s, mp, threshold, inv2s2, lanes, count) : constraintSse(s, mp, threshold, inv2s2, lanes, count);
#else
  (void)avx;
  constraintLanes<ScalarLanes>(s, mp, threshold, inv2s2, lanes, count);
#endif
  sum = Vec3(laneSum(lanes[0]), laneSum(lanes[1]), laneSum(lanes[2]));
}

void classifyCandidates(std::size_t m, const Vec3& q, float threshold, float near2, float reach2, NearScratch& s,
                        LaneSet lanes, std::size_t counts[3]) {
  const std::size_t mp = padded(m);
  s.reserveCandidates(mp);  // room for whole lanes past mp in the index arrays too (packLaneIndices writes 8)
  // padding far away: in no class (its d2 is infinite, never NaN)
  for (std::size_t e = m; e < mp; ++e) s.cx[e] = s.cy[e] = s.cz[e] = 3.0e38f;
#if SWARMSIM_X86_LANES
  switch (lanes) {
    case LaneSet::kAvx2:
    case LaneSet::kAvx512:
      classifyAvx2(mp, q.x(), q.y(), q.z(), threshold, near2, reach2, s, counts);
      break;
    case LaneSet::kAvx:
      classifyAvx(mp, q.x(), q.y(), q.z(), threshold, near2, reach2, s, counts);
      break;
    default:
      classifySse(mp, q.x(), q.y(), q.z(), threshold, near2, reach2, s, counts);
  }
#else
  (void)lanes;
  classifyLanes<ScalarLanes, false>(mp, q.x(), q.y(), q.z(), threshold, near2, reach2, s, counts,
                                    ScratchPositions<ScalarLanes>{s});
#endif
}

void gatherClassify(std::size_t m, const std::uint32_t* cand, const float* rows, std::uint32_t far, const Vec3& q,
                    float threshold, float near2, float reach2, NearScratch& s, LaneSet lanes, std::size_t counts[3]) {
  s.reserveCandidates(padded(m));
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512) {
    gatherClassifyAvx2(m, cand, rows, far, q.x(), q.y(), q.z(), threshold, near2, reach2, s, counts);
    return;
  }
#else
  (void)far;
#endif
  for (std::size_t e = 0; e < m; ++e) {
    const std::uint32_t j = cand[e];
    s.cj[e] = j;
    s.cx[e] = rows[kRowFloats * std::size_t{j}];
    s.cy[e] = rows[kRowFloats * std::size_t{j} + 1];
    s.cz[e] = rows[kRowFloats * std::size_t{j} + 2];
  }
  classifyCandidates(m, q, threshold, near2, reach2, s, lanes, counts);
}

namespace {
// F_int from the zonal sums: Σ_k ω_k / N_k (zone k's sum), zone rep with the sign −1. Without a branch: an empty
// zone's sum is +0 (every lane added +0 or −0 to +0) and its scale 0, and adding +0 leaves the sum as it was (a
// sum that starts at +0 never becomes −0), so the result is that of skipping the empty zones
// (on SSE: the three zones' scales on one register, and no branch at all, which GCC kept in the scalar code)
Vec3 zonalResult(const ZoneLanes& z, const float out[12]) {
#if defined(__SSE2__)
  const __m128 tail = _mm_loadu_ps(out + 8);  // (out[8..11]: the counts in lanes 0..2; lane 3 is not used)
  const __m128 count = _mm_shuffle_ps(tail, tail, _MM_SHUFFLE(3, 3, 2, 1));
  const __m128 signedW = _mm_setr_ps(-1.0f * z.w[0], 1.0f * z.w[1], 1.0f * z.w[2], 0.0f);
  const __m128 scale =
      _mm_and_ps(_mm_cmpgt_ps(count, _mm_setzero_ps()), _mm_div_ps(signedW, _mm_max_ps(count, _mm_set1_ps(1.0f))));
  __m128 f = _mm_setzero_ps();
  for (int zone = 0; zone < 3; ++zone) {
    const __m128 sums = _mm_loadu_ps(out + 3 * zone);  // (lane 3: the next zone's first sum, not used)
    const __m128 s = zone == 0 ? _mm_shuffle_ps(scale, scale, 0x00)
                               : (zone == 1 ? _mm_shuffle_ps(scale, scale, 0x55) : _mm_shuffle_ps(scale, scale, 0xaa));
    f = _mm_add_ps(f, _mm_mul_ps(sums, s));
  }
  alignas(16) float fl[4];
  _mm_store_ps(fl, f);
  return Vec3(fl[0], fl[1], fl[2]);
#else
  float f[3] = {0.0f, 0.0f, 0.0f};
  const float sign[3] = {-1.0f, 1.0f, 1.0f};
  for (int zone = 0; zone < 3; ++zone) {
    const float n = out[9 + zone];
    const float scale = n > 0.0f ? sign[zone] * z.w[zone] / (n > 0.0f ? n : 1.0f) : 0.0f;
    for (int a = 0; a < 3; ++a) f[a] += out[3 * zone + a] * scale;
  }
  return Vec3(f[0], f[1], f[2]);
#endif
}
}  // namespace

#if SWARMSIM_X86_LANES
namespace {
#define SWARMSIM_AVX512_BMI2 __attribute__((target("avx512f,avx2,fma,popcnt,bmi,bmi2")))

// a float vector's halves, lanes 0..7 and 8..15
SWARMSIM_AVX512_BMI2 inline __m256 lowHalf(__m512 x) {
  return _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xf, _mm512_castps_pd(x), 0));
}
SWARMSIM_AVX512_BMI2 inline __m256 highHalf(__m512 x) {
  return _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xf, _mm512_castps_pd(x), 1));
}

SWARMSIM_AVX512_BMI2 inline __m512 absOf(__m512 x, __m512i noSign) {
  return _mm512_castsi512_ps(_mm512_and_si512(_mm512_castps_si512(x), noSign));
}
// one chunk of sixteen candidates (e0 on: lane l is candidate e0 + l, the far row past m): its offsets d, squared
// distances, velocity differences u and sorted positions, and the lanes in each class
struct Chunk16 {
  __m512 dx, dy, dz, d2, ux, uy, uz;
  __m512i pos;
  __mmask16 con, near, reach;
};
SWARMSIM_AVX512_BMI2 inline Chunk16 chunk16(std::size_t e0, std::size_t m, const std::uint32_t* cand, const float* rows,
                                            std::uint32_t far, __m512 self, float threshold, float near2,
                                            float reach2) {
  // 128-bit quarters (0 of a, 0 of b, 2 of a, 2 of b) and (1, 1, 3, 3): from rows 0-3 | 4-7 | 8-11 | 12-15
  const __m512i pickPos = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
  const __m512i pickVel = _mm512_setr_epi32(4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31);
  const __m512i noSign = _mm512_set1_epi32(0x7fffffff);
  Chunk16 c;
  const auto valid = static_cast<__mmask16>(m - e0 >= 16 ? 0xffffu : (1u << (m - e0)) - 1u);
  c.pos = _mm512_mask_loadu_epi32(_mm512_set1_epi32(static_cast<int>(far)), valid, cand + e0);
  // rows l and l + 8 in the halves of r[l] (their indices read from cand, not from the vector just loaded)
  __m512 r[8];
  for (std::size_t l = 0; l < 8; ++l) {
    const std::size_t ea = e0 + l, eb = ea + 8;
    const std::uint32_t ia = ea < m ? cand[std::min(ea, m - 1)] : far;
    const std::uint32_t ib = eb < m ? cand[std::min(eb, m - 1)] : far;
    const __m256 a = _mm256_load_ps(rows + kRowFloats * std::size_t{ia});
    const __m256 b = _mm256_load_ps(rows + kRowFloats * std::size_t{ib});
    const __m512d ab =
        _mm512_maskz_insertf64x4(0xff, _mm512_castpd256_pd512(_mm256_castps_pd(a)), _mm256_castps_pd(b), 1);
    r[l] = _mm512_sub_ps(_mm512_castpd_ps(ab), self);
  }
  const __m512 t0 = _mm512_maskz_unpacklo_ps(0xffff, r[0], r[1]), t1 = _mm512_maskz_unpackhi_ps(0xffff, r[0], r[1]);
  const __m512 t2 = _mm512_maskz_unpacklo_ps(0xffff, r[2], r[3]), t3 = _mm512_maskz_unpackhi_ps(0xffff, r[2], r[3]);
  const __m512 t4 = _mm512_maskz_unpacklo_ps(0xffff, r[4], r[5]), t5 = _mm512_maskz_unpackhi_ps(0xffff, r[4], r[5]);
  const __m512 t6 = _mm512_maskz_unpacklo_ps(0xffff, r[6], r[7]), t7 = _mm512_maskz_unpackhi_ps(0xffff, r[6], r[7]);
  const __m512 a0 = _mm512_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0)),
               b0 = _mm512_shuffle_ps(t4, t6, _MM_SHUFFLE(1, 0, 1, 0));
  const __m512 a1 = _mm512_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2)),
               b1 = _mm512_shuffle_ps(t4, t6, _MM_SHUFFLE(3, 2, 3, 2));
  const __m512 a2 = _mm512_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0)),
               b2 = _mm512_shuffle_ps(t5, t7, _MM_SHUFFLE(1, 0, 1, 0));
  c.dx = _mm512_permutex2var_ps(a0, pickPos, b0);
  c.ux = _mm512_permutex2var_ps(a0, pickVel, b0);
  c.dy = _mm512_permutex2var_ps(a1, pickPos, b1);
  c.uy = _mm512_permutex2var_ps(a1, pickVel, b1);
  c.dz = _mm512_permutex2var_ps(a2, pickPos, b2);
  c.uz = _mm512_permutex2var_ps(a2, pickVel, b2);
  c.d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(c.dx, c.dx), _mm512_mul_ps(c.dy, c.dy)), _mm512_mul_ps(c.dz, c.dz));
  const __m512 man = _mm512_add_ps(_mm512_add_ps(absOf(c.dx, noSign), absOf(c.dy, noSign)), absOf(c.dz, noSign));
  c.con = _mm512_mask_cmp_ps_mask(_mm512_mask_cmp_ps_mask(valid, man, _mm512_set1_ps(threshold), _CMP_LT_OQ), c.d2,
                                  _mm512_setzero_ps(), _CMP_GT_OQ);
  c.near = _mm512_mask_cmp_ps_mask(valid, c.d2, _mm512_set1_ps(near2), _CMP_LE_OQ);
  c.reach = _mm512_mask_cmp_ps_mask(valid, c.d2, _mm512_set1_ps(reach2), _CMP_LE_OQ);
  return c;
}

// the candidates (0..47, of `chunks` chunks) in a mask, packed in order: the first sixteen in lanes 0..15 of the
// result, the next sixteen in `rest` (a caller takes at most 32)
SWARMSIM_AVX512_BMI2 inline __m512i packedLanes(std::uint64_t mask, std::size_t chunks, __m512i& rest) {
  const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  __m512i lo = _mm512_maskz_compress_epi32(static_cast<__mmask16>(mask), iota);
  __m512i hi = _mm512_setzero_si512();
  int n = __builtin_popcount(static_cast<unsigned>(mask & 0xffffu));
  for (std::size_t c = 1; c < chunks; ++c) {
    const auto cm = static_cast<__mmask16>(mask >> (16 * c));
    if (cm == 0) continue;
    const __m512i x =
        _mm512_maskz_compress_epi32(cm, _mm512_add_epi32(iota, _mm512_set1_epi32(16 * static_cast<int>(c))));
    // x's lanes after the n so far: those below 16 in lo, the others in hi (lanes past the count: anything)
    if (n < 16) {
      lo = _mm512_mask_permutexvar_epi32(lo, static_cast<__mmask16>(0xffffu << n),
                                         _mm512_sub_epi32(iota, _mm512_set1_epi32(n)), x);
    }
    const auto inHi = static_cast<__mmask16>(n >= 16 ? 0xffffu << (n - 16) : 0xffffu);
    hi = _mm512_mask_permutexvar_epi32(hi, inHi, _mm512_add_epi32(iota, _mm512_set1_epi32(16 - n)), x);
    n += __builtin_popcount(cm);
  }
  rest = hi;
  return lo;
}

// lanes `at` (0..47) of a field of the chunks (the third only where `third`)
SWARMSIM_AVX512_BMI2 inline __m512 lanesOf(const Chunk16* c, bool third, __m512 Chunk16::*field, __m512i at) {
  const __m512 two = _mm512_permutex2var_ps(c[0].*field, at, c[1].*field);
  if (!third) return two;
  return _mm512_mask_permutexvar_ps(two, _mm512_cmpge_epi32_mask(at, _mm512_set1_epi32(32)), at, c[2].*field);
}

// nearSums on sixteen lanes, for at most 48 candidates in three chunks: each chunk's sixteen rows transposed as
// zonalRowsAvx2 transposes eight, every value computed by the operations classifyLanes and zonalBlock use, on the
// same operands; the entries of a class gathered from the chunks by their packed lane numbers
SWARMSIM_AVX512_BMI2 bool nearSumsAvx512(std::size_t m, const std::uint32_t* cand, const float* rows, std::uint32_t far,
                                         float qx, float qy, float qz, float vx, float vy, float vz, float threshold,
                                         float inv2s2, float near2, float reach2, std::size_t K, const ZoneLanes& z,
                                         NearScratch& s, NearSums& out) {
  if (m > 48 || m == 0 || K == 0 || K > 16) return false;
  const __m512 self = _mm512_setr_ps(qx, qy, qz, 0.0f, vx, vy, vz, 0.0f, qx, qy, qz, 0.0f, vx, vy, vz, 0.0f);
  const std::size_t chunks = (m + 15) / 16;
  const bool third = chunks == 3;
  Chunk16 c[3];
  std::uint64_t con = 0, near = 0, reach = 0;
  for (std::size_t k = 0; k < 3; ++k) {
    if (k < chunks) {
      c[k] = chunk16(16 * k, m, cand, rows, far, self, threshold, near2, reach2);
    } else {
      c[k].dx = c[k].dy = c[k].dz = c[k].d2 = c[k].ux = c[k].uy = c[k].uz = _mm512_setzero_ps();
      c[k].pos = _mm512_setzero_si512();
      c[k].con = c[k].near = c[k].reach = 0;
    }
    con |= std::uint64_t{c[k].con} << (16 * k);
    near |= std::uint64_t{c[k].near} << (16 * k);
    reach |= std::uint64_t{c[k].reach} << (16 * k);
  }
  const auto mk = static_cast<std::size_t>(__builtin_popcountll(near));
  if (mk < K) return false;
  // F_int's K: the near entries' squared distances packed, each one's rank the number of them below it
  std::uint64_t chosen = near;
  if (mk > K) {
    if (mk > 32) return false;
    __m512i nearRest;
    const __m512i nearIdx = packedLanes(near, chunks, nearRest);
    const __m512 inf = _mm512_set1_ps(std::numeric_limits<float>::infinity());
    const auto inLo = static_cast<__mmask16>(mk >= 16 ? 0xffffu : (1u << mk) - 1u);
    const __m512 ndLo = _mm512_mask_mov_ps(inf, inLo, lanesOf(c, third, &Chunk16::d2, nearIdx));
    const __m512i one = _mm512_set1_epi32(1);
    __m512i rankLo = _mm512_setzero_si512();
    std::uint32_t pick;
    if (mk <= 16) {
      for (std::size_t j = 0; j < mk; ++j) {
        const __m512 b = _mm512_maskz_permutexvar_ps(0xffff, _mm512_set1_epi32(static_cast<int>(j)), ndLo);
        rankLo = _mm512_mask_add_epi32(rankLo, _mm512_cmp_ps_mask(ndLo, b, _CMP_GT_OQ), rankLo, one);
      }
      pick = _mm512_mask_cmplt_epi32_mask(inLo, rankLo, _mm512_set1_epi32(static_cast<int>(K)));
    } else {
      const auto inHi = static_cast<__mmask16>((1u << (mk - 16)) - 1u);
      const __m512 ndHi = _mm512_mask_mov_ps(inf, inHi, lanesOf(c, third, &Chunk16::d2, nearRest));
      __m512i rankHi = _mm512_setzero_si512();
      for (std::size_t j = 0; j < mk; ++j) {
        const __m512i at = _mm512_set1_epi32(static_cast<int>(j & 15));
        const __m512 b = _mm512_maskz_permutexvar_ps(0xffff, at, j < 16 ? ndLo : ndHi);
        rankLo = _mm512_mask_add_epi32(rankLo, _mm512_cmp_ps_mask(ndLo, b, _CMP_GT_OQ), rankLo, one);
        rankHi = _mm512_mask_add_epi32(rankHi, _mm512_cmp_ps_mask(ndHi, b, _CMP_GT_OQ), rankHi, one);
      }
      const __m512i vk = _mm512_set1_epi32(static_cast<int>(K));
      pick = _mm512_mask_cmplt_epi32_mask(inLo, rankLo, vk) |
             std::uint32_t{_mm512_mask_cmplt_epi32_mask(inHi, rankHi, vk)} << 16;
    }
    if (static_cast<std::size_t>(__builtin_popcount(pick)) != K) return false;  // a tie at the K-th place
    chosen = _pdep_u64(pick, near);
  }
  // the K in order, lane q for the q-th (gathered from the chunks by their lane numbers)
  __m512i unusedRest;
  const __m512i pick = packedLanes(chosen, chunks, unusedRest);
  const __m512 dx = lanesOf(c, third, &Chunk16::dx, pick), dy = lanesOf(c, third, &Chunk16::dy, pick);
  const __m512 dz = lanesOf(c, third, &Chunk16::dz, pick), d2 = lanesOf(c, third, &Chunk16::d2, pick);
  const __m512 ux = lanesOf(c, third, &Chunk16::ux, pick), uy = lanesOf(c, third, &Chunk16::uy, pick);
  const __m512 uz = lanesOf(c, third, &Chunk16::uz, pick);
  s.reserveCandidates(m + 32);
  __m512i js = _mm512_permutex2var_epi32(c[0].pos, pick, c[1].pos);
  if (third)
    js = _mm512_mask_permutexvar_epi32(js, _mm512_cmpge_epi32_mask(pick, _mm512_set1_epi32(32)), pick, c[2].pos);
  _mm512_storeu_si512(s.chosen.data(), js);
  // F_con: up to sixteen entries summed here as constraintSumScratch sums them (lanes 8..15 after lanes 0..7, then
  // the eight lanes in order), more packed in scratch.dx/dy/dz/d2 for the caller's constraintSumScratch
  const int nc = __builtin_popcountll(con);
  if (nc > 32 || __builtin_popcountll(reach) > 32) return false;
  out.conSum = Vec3::Zero();
  out.conCount = 0;
  out.conSummed = nc <= 16;
  if (con != 0) {
    __m512i rest;
    const __m512i at = packedLanes(con, chunks, rest);
    const __m512 cx = lanesOf(c, third, &Chunk16::dx, at), cy = lanesOf(c, third, &Chunk16::dy, at);
    const __m512 cz = lanesOf(c, third, &Chunk16::dz, at), cd2 = lanesOf(c, third, &Chunk16::d2, at);
    if (nc <= 8) {  // (the usual case: eight lanes, as constraintSumScratch's one block)
      using L = AvxLanes;
      const L::V x{lowHalf(cx)}, y{lowHalf(cy)}, zz{lowHalf(cz)}, dd{lowHalf(cd2)};
      const L::V sign = L::set1(-0.0f);
      const L::V man = L::add(L::add(L::andnot(sign, x), L::andnot(sign, y)), L::andnot(sign, zz));
      const L::V w =
          L::div(expLanes<L>(L::mul(L::mul(man, man), L::set1(-inv2s2))), L::sqrt(L::max(dd, L::set1(kTiny))));
      const __m256 keep =
          _mm256_castsi256_ps(_mm256_cmpgt_epi32(_mm256_set1_epi32(nc), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7)));
      const __m256 parts[3] = {_mm256_and_ps(keep, _mm256_mul_ps(x.a, w.a)),
                               _mm256_and_ps(keep, _mm256_mul_ps(y.a, w.a)),
                               _mm256_and_ps(keep, _mm256_mul_ps(zz.a, w.a))};
      for (int a = 0; a < 3; ++a) {
        alignas(32) float l[kLanes];
        _mm256_store_ps(l, _mm256_add_ps(_mm256_setzero_ps(), parts[a]));
        out.conSum[a] = laneSum(l);
      }
      out.conCount = nc;
    } else if (nc <= 16) {
      const auto in = static_cast<__mmask16>((1u << nc) - 1u);
      const __m512i noSign = _mm512_set1_epi32(0x7fffffff);
      const __m512 man = _mm512_add_ps(_mm512_add_ps(absOf(cx, noSign), absOf(cy, noSign)), absOf(cz, noSign));
      const Avx512Lanes::V e = expLanes<Avx512Lanes>({_mm512_mul_ps(_mm512_mul_ps(man, man), _mm512_set1_ps(-inv2s2))});
      const __m512 w =
          _mm512_div_ps(e.a, _mm512_maskz_sqrt_ps(0xffff, _mm512_maskz_max_ps(0xffff, cd2, _mm512_set1_ps(kTiny))));
      const __m512 parts[3] = {_mm512_maskz_mul_ps(in, cx, w), _mm512_maskz_mul_ps(in, cy, w),
                               _mm512_maskz_mul_ps(in, cz, w)};
      for (int a = 0; a < 3; ++a) {
        alignas(32) float l[kLanes];
        _mm256_store_ps(l, _mm256_add_ps(_mm256_add_ps(_mm256_setzero_ps(), lowHalf(parts[a])), highHalf(parts[a])));
        out.conSum[a] = laneSum(l);
      }
      out.conCount = nc;
    } else {
      s.reserve(m + 32);
      _mm512_storeu_ps(s.dx.data(), cx);
      _mm512_storeu_ps(s.dy.data(), cy);
      _mm512_storeu_ps(s.dz.data(), cz);
      _mm512_storeu_ps(s.d2.data(), cd2);
      _mm512_storeu_ps(s.dx.data() + 16, lanesOf(c, third, &Chunk16::dx, rest));
      _mm512_storeu_ps(s.dy.data() + 16, lanesOf(c, third, &Chunk16::dy, rest));
      _mm512_storeu_ps(s.dz.data() + 16, lanesOf(c, third, &Chunk16::dz, rest));
      _mm512_storeu_ps(s.d2.data() + 16, lanesOf(c, third, &Chunk16::d2, rest));
    }
  }
  if (reach != 0) {
    __m512i rest;
    _mm512_storeu_si512(s.mdeIdx.data(), packedLanes(reach, chunks, rest));
    _mm512_storeu_si512(s.mdeIdx.data() + 16, rest);
  }
  out.counts[0] = static_cast<std::size_t>(nc);
  out.counts[1] = mk;
  out.counts[2] = static_cast<std::size_t>(__builtin_popcountll(reach));
  // zonalBlock's sums over the K (lanes from K on in no zone), lanes 8..15 added after lanes 0..7 as the
  // eight-lane kernel adds its second block
  const auto inK = static_cast<__mmask16>(K >= 16 ? 0xffffu : (1u << K) - 1u);
  const __m512 one = _mm512_set1_ps(1.0f), tiny = _mm512_set1_ps(kTiny);
  const __m512 u2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(ux, ux), _mm512_mul_ps(uy, uy)), _mm512_mul_ps(uz, uz));
  const __mmask16 inRep = _mm512_mask_cmp_ps_mask(inK, d2, _mm512_set1_ps(z.rep2), _CMP_LT_OQ);
  const __mmask16 nearer = _mm512_mask_cmp_ps_mask(inK, d2, _mm512_set1_ps(z.ali2), _CMP_LT_OQ);
  const __mmask16 inAli = static_cast<__mmask16>(nearer & ~inRep);
  const __mmask16 inAtt =
      static_cast<__mmask16>(_mm512_mask_cmp_ps_mask(inK, d2, _mm512_set1_ps(z.att2), _CMP_LE_OQ) & ~nearer);
  const __m512 invd = _mm512_div_ps(one, _mm512_maskz_sqrt_ps(0xffff, _mm512_maskz_max_ps(0xffff, d2, tiny)));
  const __m512 invu = _mm512_div_ps(one, _mm512_maskz_sqrt_ps(0xffff, _mm512_maskz_max_ps(0xffff, u2, tiny)));
  const __m512 sums[9] = {
      _mm512_maskz_mul_ps(inRep, dx, invd), _mm512_maskz_mul_ps(inRep, dy, invd), _mm512_maskz_mul_ps(inRep, dz, invd),
      _mm512_maskz_mul_ps(inAli, ux, invu), _mm512_maskz_mul_ps(inAli, uy, invu), _mm512_maskz_mul_ps(inAli, uz, invu),
      _mm512_maskz_mul_ps(inAtt, dx, invd), _mm512_maskz_mul_ps(inAtt, dy, invd), _mm512_maskz_mul_ps(inAtt, dz, invd)};
  AvxLanes::V acc[9];
  for (int a = 0; a < 9; ++a) {
    acc[a].a = _mm256_add_ps(_mm256_add_ps(_mm256_setzero_ps(), lowHalf(sums[a])), highHalf(sums[a]));
  }
  float sum[12];
  AvxLanes::treeSums8(acc, sum);
  sum[8] = treeSum<AvxLanes>(acc[8]);
  sum[9] = static_cast<float>(__builtin_popcount(inRep));
  sum[10] = static_cast<float>(__builtin_popcount(inAli));
  sum[11] = static_cast<float>(__builtin_popcount(inAtt));
  out.fInt = zonalResult(z, sum);
  const __m512 kept2 = _mm512_maskz_mov_ps(inK, d2);  // (squared distances: none below zero)
  const __m256 m8 = _mm256_max_ps(lowHalf(kept2), highHalf(kept2));
  const __m128 m4 = _mm_max_ps(_mm256_castps256_ps128(m8), _mm256_extractf128_ps(m8, 1));
  const __m128 m2 = _mm_max_ps(m4, _mm_movehl_ps(m4, m4));
  out.far2 = _mm_cvtss_f32(_mm_max_ss(m2, _mm_shuffle_ps(m2, m2, 1)));
  return true;
}
}  // namespace
#endif

bool nearSumsLanes(LaneSet lanes) {
#if SWARMSIM_X86_LANES
  static const bool bmi2 = __builtin_cpu_supports("bmi2");
  return lanes == LaneSet::kAvx512 && bmi2;
#else
  (void)lanes;
  return false;
#endif
}

bool nearSums(std::size_t m, const std::uint32_t* cand, const float* rows, std::uint32_t far, const Vec3& q,
              const Vec3& v, float threshold, float inv2s2, float near2, float reach2, std::size_t K,
              const ZoneLanes& zones, NearScratch& scratch, NearSums& out) {
#if SWARMSIM_X86_LANES
  return nearSumsAvx512(m, cand, rows, far, q.x(), q.y(), q.z(), v.x(), v.y(), v.z(), threshold, inv2s2, near2, reach2,
                        K, zones, scratch, out);
#else
  (void)m, (void)cand, (void)rows, (void)far, (void)q, (void)v, (void)threshold, (void)inv2s2, (void)near2;
  (void)reach2, (void)K, (void)zones, (void)scratch, (void)out;
  throw std::logic_error("nearSums without AVX-512");
#endif
}

#if SWARMSIM_X86_LANES
namespace {
// the whole eights of rows from first on; returns where they end
SWARMSIM_AVX std::size_t fillRowsAvx(const float* x, const float* y, const float* z, const float* vx, const float* vy,
                                     const float* vz, std::size_t first, std::size_t end, float* rows) {
  std::size_t k = first;
  for (; k + kLanes <= end; k += kLanes) {
    const __m256 zero = _mm256_setzero_ps();
    const __m256 r0 = _mm256_loadu_ps(x + k), r1 = _mm256_loadu_ps(y + k), r2 = _mm256_loadu_ps(z + k);
    const __m256 r4 = _mm256_loadu_ps(vx + k), r5 = _mm256_loadu_ps(vy + k), r6 = _mm256_loadu_ps(vz + k);
    // (x y, z 0) pairs, then (x y z 0) quads of insects l and l + 4 in the halves
    const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
    const __m256 t2 = _mm256_unpacklo_ps(r2, zero), t3 = _mm256_unpackhi_ps(r2, zero);
    const __m256 t4 = _mm256_unpacklo_ps(r4, r5), t5 = _mm256_unpackhi_ps(r4, r5);
    const __m256 t6 = _mm256_unpacklo_ps(r6, zero), t7 = _mm256_unpackhi_ps(r6, zero);
    const __m256 p[4] = {_mm256_shuffle_ps(t0, t2, 0x44), _mm256_shuffle_ps(t0, t2, 0xee),
                         _mm256_shuffle_ps(t1, t3, 0x44), _mm256_shuffle_ps(t1, t3, 0xee)};
    const __m256 v[4] = {_mm256_shuffle_ps(t4, t6, 0x44), _mm256_shuffle_ps(t4, t6, 0xee),
                         _mm256_shuffle_ps(t5, t7, 0x44), _mm256_shuffle_ps(t5, t7, 0xee)};
    float* out = rows + kRowFloats * k;
    for (std::size_t l = 0; l < 4; ++l) {
      _mm256_storeu_ps(out + kRowFloats * l, _mm256_permute2f128_ps(p[l], v[l], 0x20));
      _mm256_storeu_ps(out + kRowFloats * (l + 4), _mm256_permute2f128_ps(p[l], v[l], 0x31));
    }
  }
  return k;
}
}  // namespace
#endif

void fillRows(const float* x, const float* y, const float* z, const float* vx, const float* vy, const float* vz,
              std::size_t first, std::size_t count, float* rows, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  const std::size_t done =
      lanes != LaneSet::kSse ? fillRowsAvx(x, y, z, vx, vy, vz, first, first + count, rows) : first;
#else
  (void)lanes;
  const std::size_t done = first;
#endif
  for (std::size_t k = done; k < first + count; ++k) {
    float* row = rows + kRowFloats * k;
    const float r[kRowFloats] = {x[k], y[k], z[k], 0.0f, vx[k], vy[k], vz[k], 0.0f};
    std::copy(r, r + kRowFloats, row);
  }
}

bool zonalFromRows(LaneSet lanes) {
#if SWARMSIM_X86_LANES
  return lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512;
#else
  (void)lanes;
  return false;
#endif
}

Vec3 zonalForceRows(std::size_t m, std::uint32_t* js, const float* rows, std::uint32_t far, const Vec3& q,
                    const Vec3& v, const ZoneLanes& z) {
  float out[12];
  for (std::size_t e = m; e % kLanes != 0; ++e) js[e] = far;
#if SWARMSIM_X86_LANES
  zonalRowsAvx2(m, js, rows, q.x(), q.y(), q.z(), v.x(), v.y(), v.z(), z, out);
#else
  (void)rows;
  (void)q;
  (void)v;
  throw std::logic_error("zonalForceRows without AVX2");
#endif
  return zonalResult(z, out);
}

Vec3 zonalForce(std::size_t m, const ZoneLanes& z, NearScratch& s, bool avx) {
  const std::size_t mp = padded(m);
  s.reserve(m + kLanes);
  // beyond every zone: a whole lane block from m (a fixed count, so a vector store each)
  for (float* a : {s.dx.data(), s.dy.data(), s.dz.data(), s.ux.data(), s.uy.data(), s.uz.data()}) {
    for (std::size_t l = 0; l < kLanes; ++l) a[m + l] = 0.0f;
  }
  for (std::size_t l = 0; l < kLanes; ++l) s.d2[m + l] = 3.0e38f;
  float out[12];
#if SWARMSIM_X86_LANES
  avx ? zonalAvx(s, mp, z, out) : zonalSse(s, mp, z, out);
#else
  (void)avx;
  zonalLanes<ScalarLanes>(s, mp, z, out);
#endif
  return zonalResult(z, out);
}

float farthestRow2(std::size_t m, const std::uint32_t* prev, const std::uint32_t* pos, const float* rows,
                   std::size_t count, const Vec3& q, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kAvx2 && m > 0 && count < (std::size_t{1} << 28)) {  // (not kAvx512: see the header)
    return farthestRow2Avx2(m, prev, pos, rows, q.x(), q.y(), q.z());
  }
#else
  (void)lanes;
#endif
  float far2 = 0.0f;
  for (std::size_t e = 0; e < m; ++e) {
    const float* row = rows + kRowFloats * std::size_t{pos[prev[e]]};
    const float dx = row[0] - q.x(), dy = row[1] - q.y(), dz = row[2] - q.z();
    far2 = std::max(far2, dx * dx + dy * dy + dz * dz);
  }
  return far2;
}

namespace {

// the D-th largest of the keys[0, m) (m >= D; 0 for a place not filled): the D largest so far kept in
// descending order in registers, each key passed down through them by compare-and-swap (no branch on the
// data; a key's trip depends on the previous key's only one place at a time, so the keys overlap)
template <int D>
std::uint64_t dthLargest(const std::uint64_t* keys, std::size_t m) {
  std::uint64_t top[D];
  for (int j = 0; j < D; ++j) top[j] = 0;
  for (std::size_t e = 0; e < m; ++e) {
    std::uint64_t x = keys[e];
    for (int j = 0; j < D; ++j) {
      const std::uint64_t t = top[j];
      const bool above = t > x;
      top[j] = above ? t : x;
      x = above ? x : t;
    }
  }
  return top[D - 1];
}

}  // namespace

std::size_t keepSmallest(std::uint64_t* keys, std::size_t m, std::size_t K) {
  if (m <= K) return m;
  if (K == 0) return 0;
  if (m - K <= 8) {
    // the cut: the (m − K)-th largest key (above the K smallest), then the keys below it, in order
    using Cut = std::uint64_t (*)(const std::uint64_t*, std::size_t);
    static constexpr Cut kCut[8] = {dthLargest<1>, dthLargest<2>, dthLargest<3>, dthLargest<4>,
                                    dthLargest<5>, dthLargest<6>, dthLargest<7>, dthLargest<8>};
    const std::uint64_t cut = kCut[m - K - 1](keys, m);
    std::size_t out = 0;
    for (std::size_t e = 0; e < m; ++e) {
      const std::uint64_t x = keys[e];
      keys[out] = x;
      out += static_cast<std::size_t>(x < cut);
    }
    return out;
  }
  // many: order by key, keep K, and put them back in their given order (the low half of a key)
  std::nth_element(keys, keys + K, keys + m);
  std::sort(keys, keys + K, [](std::uint64_t x, std::uint64_t y) { return keyIndex(x) < keyIndex(y); });
  return K;
}

}  // namespace swarmsim
