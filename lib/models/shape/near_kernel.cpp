#include "models/shape/near_kernel.hpp"

#include <algorithm>
#include <cmath>

#include "core/lanes.hpp"

namespace swarmsim {

namespace {

constexpr float kTiny = 1e-30f;  // floor of squared lengths: a zero vector times a finite reciprocal stays zero

static_assert(kLanes <= CellBlock::kSlack, "collectLanes loads whole lanes past a block's size");

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

template <typename L>
inline std::size_t collectLanes(const CellBlock& block, std::uint32_t k, float r2, std::uint32_t* pick) {
  using V = typename L::V;
  const V r = L::set1(r2);
  const float* d2 = block.d2.data();  // at least size + CellBlock::kSlack entries (kLanes <= kSlack)
  const std::uint32_t* index = block.index.data();
  std::size_t m = 0;
  for (std::size_t j = 0; j < block.size; j += kLanes) {
    unsigned bits = L::mask(L::le(L::load(d2 + j), r));
    if (block.size - j < kLanes) bits &= (1u << (block.size - j)) - 1u;
    while (bits) {
      const auto b = static_cast<std::uint32_t>(j + static_cast<std::size_t>(__builtin_ctz(bits)));
      pick[m] = b;
      m += index[b] != k ? 1 : 0;
      bits &= bits - 1u;
    }
  }
  return m;
}

template <typename L>
inline void zonalLanes(const NearScratch& s, std::size_t m, const ZoneLanes& z, float out[9][kLanes], int counts[3]) {
  using V = typename L::V;
  V acc[9];
  for (V& a : acc) a = L::set1(0.0f);
  const V one = L::set1(1.0f), tiny = L::set1(kTiny);
  const V rep2 = L::set1(z.rep2), ali2 = L::set1(z.ali2), att2 = L::set1(z.att2);
  int c[3] = {0, 0, 0};
  for (std::size_t e = 0; e < m; e += kLanes) {
    const V dx = L::load(s.dx.data() + e), dy = L::load(s.dy.data() + e), dz = L::load(s.dz.data() + e);
    const V ux = L::load(s.ux.data() + e), uy = L::load(s.uy.data() + e), uz = L::load(s.uz.data() + e);
    const V d2 = L::load(s.d2.data() + e);
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
    c[0] += L::count(inRep);
    c[1] += L::count(inAli);
    c[2] += L::count(inAtt);
  }
  for (int a = 0; a < 9; ++a) L::store(out[a], acc[a]);
  for (int a = 0; a < 3; ++a) counts[a] = c[a];
}

#if SWARMSIM_X86_LANES
__attribute__((flatten)) void constraintSse(const NearScratch& s, std::size_t m, float t, float c, float o[3][kLanes],
                                            int& n) {
  constraintLanes<SseLanes>(s, m, t, c, o, n);
}
SWARMSIM_AVX __attribute__((flatten)) void constraintAvx(const NearScratch& s, std::size_t m, float t, float c,
                                                         float o[3][kLanes], int& n) {
  constraintLanes<AvxLanes>(s, m, t, c, o, n);
}
__attribute__((flatten)) std::size_t collectSse(const CellBlock& b, std::uint32_t k, float r2, std::uint32_t* p) {
  return collectLanes<SseLanes>(b, k, r2, p);
}
SWARMSIM_AVX __attribute__((flatten)) std::size_t collectAvx(const CellBlock& b, std::uint32_t k, float r2,
                                                             std::uint32_t* p) {
  return collectLanes<AvxLanes>(b, k, r2, p);
}
__attribute__((flatten)) void zonalSse(const NearScratch& s, std::size_t m, const ZoneLanes& z, float o[9][kLanes],
                                       int c[3]) {
  zonalLanes<SseLanes>(s, m, z, o, c);
}
SWARMSIM_AVX __attribute__((flatten)) void zonalAvx(const NearScratch& s, std::size_t m, const ZoneLanes& z,
                                                    float o[9][kLanes], int c[3]) {
  zonalLanes<AvxLanes>(s, m, z, o, c);
}
#endif

}  // namespace

void NearScratch::reserve(std::size_t n) {
  if (dx.size() >= n) return;
  const std::size_t cap = padded(n + n / 2 + 16);
  for (auto* v : {&dx, &dy, &dz, &d2, &ux, &uy, &uz}) v->resize(cap);
  pick.resize(cap);
}

void constraintSum(const CellBlock& block, const std::uint32_t* hits, std::size_t m, const Vec3& q, float threshold,
                   float inv2s2, NearScratch& s, bool avx, Vec3& sum, int& count) {
  const std::size_t mp = padded(m);
  s.reserve(mp);
  for (std::size_t e = 0; e < m; ++e) {
    const std::uint32_t b = hits[e];
    s.dx[e] = block.x[b] - q.x();
    s.dy[e] = block.y[b] - q.y();
    s.dz[e] = block.z[b] - q.z();
    s.d2[e] = block.d2[b];
  }
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

std::size_t collectWithin(const CellBlock& block, std::uint32_t k, float r2, NearScratch& s, bool avx) {
  s.reserve(block.size);
#if SWARMSIM_X86_LANES
  return avx ? collectAvx(block, k, r2, s.pick.data()) : collectSse(block, k, r2, s.pick.data());
#else
  (void)avx;
  return collectLanes<ScalarLanes>(block, k, r2, s.pick.data());
#endif
}

Vec3 zonalForce(std::size_t m, const ZoneLanes& z, NearScratch& s, bool avx) {
  const std::size_t mp = padded(m);
  for (std::size_t e = m; e < mp; ++e) {  // beyond every zone
    s.dx[e] = s.dy[e] = s.dz[e] = s.ux[e] = s.uy[e] = s.uz[e] = 0.0f;
    s.d2[e] = 3.0e38f;
  }
  alignas(32) float lanes[9][kLanes];
  int counts[3];
#if SWARMSIM_X86_LANES
  avx ? zonalAvx(s, mp, z, lanes, counts) : zonalSse(s, mp, z, lanes, counts);
#else
  (void)avx;
  zonalLanes<ScalarLanes>(s, mp, z, lanes, counts);
#endif
  Vec3 f = Vec3::Zero();
  const float sign[3] = {-1.0f, 1.0f, 1.0f};
  for (int zone = 0; zone < 3; ++zone) {
    if (counts[zone] == 0) continue;
    const Vec3 sum(laneSum(lanes[3 * zone]), laneSum(lanes[3 * zone + 1]), laneSum(lanes[3 * zone + 2]));
    f += sum * (sign[zone] * z.w[zone] / static_cast<float>(counts[zone]));
  }
  return f;
}

}  // namespace swarmsim
