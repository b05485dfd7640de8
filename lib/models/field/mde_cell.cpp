// mdeCellPairs (mde.hpp): the field model's within-cell minimum distance enforcement, close pairs listed first.
#include <cstdint>

#include "models/field/mde.hpp"

namespace swarmsim {
namespace {

// the pair lists are flushed to the second pass when fewer than a chunk's entries remain free
constexpr std::size_t kListSize = 256;

// the second pass: the listed pairs (k, j), k < j, in the list's order
inline void listedPushes(const float* x, const float* y, const float* z, const std::uint32_t* ks,
                         const std::uint32_t* js, std::size_t count, float md, float md2, float* px, float* py,
                         float* pz, std::int32_t* hits, bool& coincident) {
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint32_t k = ks[i], j = js[i];
    const float dx = x[j] - x[k], dy = y[j] - y[k], dz = z[j] - z[k];
    const float d2 = dx * dx + dy * dy + dz * dz;
    if (d2 == 0.0f) {
      coincident = true;
      continue;
    }
    float w;
    if (!mdeWeight(d2, md, md2, w)) continue;
    const float fx = dx * w, fy = dy * w, fz = dz * w;
    px[k] -= fx;
    py[k] -= fy;
    pz[k] -= fz;
    px[j] += fx;
    py[j] += fy;
    pz[j] += fz;
    ++hits[k];
    ++hits[j];
  }
}

// compact(kOut, out, k, j, m) (core/lanes.hpp's kLanePack): writes j + the lane numbers of m's set bits to out[0 ..]
// and k beside each to kOut[0 ..] (eight entries written to each), and returns how many are set
template <class L, class Compact>
inline bool cellPairs(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e, float md,
                      float* px, float* py, float* pz, std::int32_t* hits, Compact compact) {
  const float md2 = md * md;
  for (std::uint32_t k = b; k < e; ++k) px[k] = py[k] = pz[k] = 0.0f, hits[k] = 0;
  bool coincident = false;
  std::uint32_t ks[kListSize], js[kListSize];
  const typename L::V close2 = L::set1(md2);
  std::size_t n = 0;
  for (std::uint32_t k = b; k < e; ++k) {
    const typename L::V qx = L::set1(x[k]), qy = L::set1(y[k]), qz = L::set1(z[k]);
    for (std::uint32_t j = k + 1; j < e; j += 8) {
      const typename L::V dx = L::sub(L::load(x + j), qx), dy = L::sub(L::load(y + j), qy);
      const typename L::V dz = L::sub(L::load(z + j), qz);
      const typename L::V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
      n += compact(ks + n, js + n, k, j, L::mask(L::lt(d2, close2)) & firstLanes(e - j, 8));
      if (n > kListSize - 8) {
        listedPushes(x, y, z, ks, js, n, md, md2, px, py, pz, hits, coincident);
        n = 0;
      }
    }
  }
  listedPushes(x, y, z, ks, js, n, md, md2, px, py, pz, hits, coincident);
  return coincident;
}

#if SWARMSIM_X86_LANES
SWARMSIM_AVX2 __attribute__((flatten)) bool cellPairsAvx2(const float* x, const float* y, const float* z,
                                                          std::uint32_t b, std::uint32_t e, float md, float* px,
                                                          float* py, float* pz, std::int32_t* hits) {
  return cellPairs<AvxLanes>(
      x, y, z, b, e, md, px, py, pz, hits,
      [](std::uint32_t* kOut, std::uint32_t* out, std::uint32_t k, std::uint32_t j, unsigned m) SWARMSIM_AVX2 {
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(kOut), _mm256_set1_epi32(static_cast<int>(k)));
        return packLaneIndices(j, m, out);
      });
}
using PortableLanes = SseLanes;
#else
using PortableLanes = ScalarLanes;
#endif

bool cellPairsPortable(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e, float md,
                       float* px, float* py, float* pz, std::int32_t* hits) {
  return cellPairs<PortableLanes>(
      x, y, z, b, e, md, px, py, pz, hits,
      [](std::uint32_t* kOut, std::uint32_t* out, std::uint32_t k, std::uint32_t j, unsigned m) {
        for (unsigned l = 0; l < 8; ++l) {
          kOut[l] = k;
          out[l] = j + kLanePack.lanes[m][l];
        }
        return static_cast<std::size_t>(laneCount(m));
      });
}

}  // namespace

bool mdeCellPairs(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e, float md, float* px,
                  float* py, float* pz, std::int32_t* hits, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512) return cellPairsAvx2(x, y, z, b, e, md, px, py, pz, hits);
#else
  (void)lanes;
#endif
  return cellPairsPortable(x, y, z, b, e, md, px, py, pz, hits);
}

}  // namespace swarmsim
