#include "orca/orca.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

#include "core/lanes.hpp"
#include "core/parallel.hpp"
#include "geometry/signed_distance.hpp"
#include "orca/lp_lanes.hpp"

namespace swarmsim::orca {

namespace {

// Plain float 3-vectors for the hot loops (no expression templates, and the
// arithmetic is exactly what is written, the same for every thread).
struct F3 {
  float x, y, z;
};
inline F3 operator+(F3 a, F3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline F3 operator-(F3 a, F3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline F3 operator*(F3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline float dot(F3 a, F3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline F3 cross(F3 a, F3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline F3 normalOf(const Plane& p) { return {p.nx, p.ny, p.nz}; }
inline Plane makePlane(F3 n, float b) { return {n.x, n.y, n.z, b}; }

// ---- the linear programs ---------------------------------------------------
// Maximise closeness to pref (or, with `direction`, the component along the unit
// vector pref) over {v : n_k . v >= b_k for the given planes, |v| <= R}.

// 1-D: on the line p + t d (|d| = 1), planes [0, count).
bool lineProgram(const Plane* planes, std::size_t count, F3 p, F3 d, float R, F3 pref, bool direction, F3& v) {
  const float pd = dot(p, d);
  const float disc = pd * pd + R * R - dot(p, p);
  if (disc < 0.0f) return false;  // the line misses the speed ball
  const float s = std::sqrt(disc);
  float lo = -pd - s, hi = -pd + s;
  for (std::size_t k = 0; k < count; ++k) {
    const F3 nk = normalOf(planes[k]);
    const float den = dot(nk, d), num = planes[k].b - dot(nk, p);  // need t * den >= num
    if (std::fabs(den) < 1e-6f) {  // line parallel to plane k: all of it inside or all outside
      if (num > kTolerance) return false;
      continue;
    }
    const float t = num / den;
    if (den > 0.0f) {
      lo = std::max(lo, t);
    } else {
      hi = std::min(hi, t);
    }
    if (lo > hi + kTolerance) return false;
  }
  float t;
  if (direction) {
    t = dot(pref, d) > 0.0f ? hi : lo;
  } else {
    t = std::max(lo, std::min(hi, dot(pref - p, d)));
  }
  v = p + d * std::max(lo, t);  // lo > hi only by rounding: take lo
  return true;
}

// 2-D: on plane i, planes [0, i).
bool planeProgram(const Plane* planes, std::size_t i, float R, F3 pref, bool direction, F3& out) {
  const F3 n = normalOf(planes[i]);
  const float b = planes[i].b;
  const float disc2 = R * R - b * b;  // squared radius of the plane's disc inside the ball
  if (disc2 < 0.0f) return false;
  const F3 c = n * b;  // disc centre
  F3 v;
  if (direction) {
    const F3 t = pref - n * dot(pref, n);
    const float t2 = dot(t, t);
    v = t2 > 1e-12f ? c + t * std::sqrt(disc2 / t2) : c;
  } else {
    const F3 q = pref + n * (b - dot(pref, n));  // pref projected on the plane
    const F3 e = q - c;
    const float e2 = dot(e, e);
    v = e2 > disc2 ? c + e * std::sqrt(disc2 / e2) : q;
  }
  for (std::size_t j = 0; j < i; ++j) {
    const F3 nj = normalOf(planes[j]);
    if (dot(nj, v) >= planes[j].b - kTolerance) continue;
    const F3 cr = cross(n, nj);
    const float cr2 = dot(cr, cr);
    if (cr2 < 1e-12f) return false;  // parallel: plane j is violated on all of plane i
    const float crl = std::sqrt(cr2);
    const F3 d = cr * (1.0f / crl);
    // point of the line i ∩ j: from c along e = d x n (in plane i, n_j . e = |n x n_j|)
    const F3 p = c + cross(d, n) * ((planes[j].b - b * dot(n, nj)) / crl);
    if (!lineProgram(planes, j, p, d, R, pref, direction, v)) return false;
  }
  out = v;
  return true;
}

// 3-D: planes [0, count) in order. Returns count on success; otherwise the
// first plane that cannot be satisfied, with v the optimum of the planes before it.
std::size_t ballProgram(const Plane* planes, std::size_t count, float R, F3 pref, bool direction, F3& v) {
  if (direction) {
    v = pref * R;
  } else {
    const float p2 = dot(pref, pref);
    v = p2 > R * R ? pref * (R / std::sqrt(p2)) : pref;
  }
  for (std::size_t i = 0; i < count; ++i) {
    if (dot(normalOf(planes[i]), v) >= planes[i].b - kTolerance) continue;
    const F3 before = v;
    if (!planeProgram(planes, i, R, pref, direction, v)) {
      v = before;
      return i;
    }
  }
  return count;
}

// The fallback: minimise the worst violation max_k (b_k - n_k . v) over the soft
// planes [hard, count) with |v| <= R, the planes [0, hard) kept as hard
// constraints. This is a 4-D LP in (v, violation); it is solved incrementally
// from `begin` (v satisfies the planes before it): when plane i is violated more
// than the worst so far, the new optimum maximises n_i . v over the velocities
// where no earlier soft plane j is violated more than i, i.e. the half-spaces
// (n_j - n_i) . v >= b_j - b_i, which is a 3-D LP with a direction objective.
void leastViolation(const Plane* planes, std::size_t begin, std::size_t count, std::size_t hard, float R,
                    Plane* projected, F3& v) {
  float worst = 0.0f;
  for (std::size_t i = std::max(begin, hard); i < count; ++i) {
    const F3 ni = normalOf(planes[i]);
    if (planes[i].b - dot(ni, v) <= worst) continue;
    std::size_t m = 0;
    for (std::size_t h = 0; h < hard; ++h) projected[m++] = planes[h];
    for (std::size_t j = hard; j < i; ++j) {
      const F3 d = normalOf(planes[j]) - ni;
      const float l2 = dot(d, d);
      if (l2 < 1e-10f) continue;  // same normal: j is never the worse of the two here
      const float inv = 1.0f / std::sqrt(l2);
      projected[m++] = makePlane(d * inv, (planes[j].b - planes[i].b) * inv);
    }
    F3 candidate;
    // failure is rounding on a degenerate set: keep the previous velocity
    if (ballProgram(projected, m, R, ni, true, candidate) == m) v = candidate;
    worst = planes[i].b - dot(ni, v);
  }
}

// ---- half-spaces -------------------------------------------------------------

// a unit vector perpendicular to the unit vector a, odd in a (perp(-a) =
// -perp(a)), so the two agents of a pair that both need one pick opposite ones
F3 perpendicular(F3 a) {
  const float ax = std::fabs(a.x), ay = std::fabs(a.y), az = std::fabs(a.z);
  const F3 e = ax <= ay && ax <= az ? F3{1, 0, 0} : (ay <= az ? F3{0, 1, 0} : F3{0, 0, 1});
  const F3 c = cross(a, e);  // |c|^2 = 1 - a_e^2 >= 2/3
  return c * (1.0f / std::sqrt(dot(c, c)));
}

struct AgentConstants {
  float R, R2;          // combined radius and its square
  float invTau, invDt;  // 1 / time horizon, 1 / dt
};

// The ORCA half-space of agent i (sorted index ki) for neighbour j (kj): p = x_j - x_i,
// rv = v_i - v_j. The velocity obstacle {v : |v t - p| < R for some t in [0, tau]} is the
// cone of apex 0 around p with half-angle asin(R/|p|), cut off by the sphere of centre
// p/tau and radius R/tau (overlapping agents: centre p/dt, radius R/dt, the whole cone).
// u = (closest point of its boundary) - rv, n the outward normal there; agent i takes half:
// n . v >= n . (v_i + u/2) = n . v_i + (signed distance)/2.
Plane agentPlane(F3 p, F3 vi, F3 rv, std::uint32_t ki, std::uint32_t kj, const AgentConstants& a) {
  const float dist2 = dot(p, p);
  F3 n;
  float along;  // u . n: how far rv must move along n to reach the boundary
  if (dist2 > a.R2) {
    const F3 w = rv - p * a.invTau;  // from the cut-off centre to rv
    const float w2 = dot(w, w), wp = dot(w, p);
    if (wp < 0.0f && wp * wp > a.R2 * w2) {
      // closest to the cut-off cap: the part of the sphere between its two tangent
      // points seen from the apex (angle between w and -p below acos(R/|p|))
      const float wl = std::sqrt(w2);  // > 0 here
      n = w * (1.0f / wl);
      along = a.R * a.invTau - wl;
    } else {
      // closest to the cone surface, in the plane through the axis and rv
      const float dist = std::sqrt(dist2);
      const F3 axis = p * (1.0f / dist);
      const float sinA = a.R / dist, cosA = std::sqrt(dist2 - a.R2) / dist;
      const F3 q = rv - axis * dot(rv, axis);  // rv's part across the axis
      const float q2 = dot(q, q);
      const F3 across = q2 > 1e-20f ? q * (1.0f / std::sqrt(q2)) : perpendicular(axis);
      n = across * cosA - axis * sinA;  // normal of the generator cosA axis + sinA across
      along = -dot(rv, n);
    }
  } else {
    // overlapping: leave the sphere of centre p/dt, radius R/dt within this step
    const F3 w = rv - p * a.invDt;
    const float w2 = dot(w, w);
    if (w2 > 1e-20f) {
      const float wl = std::sqrt(w2);
      n = w * (1.0f / wl);
      along = a.R * a.invDt - wl;
    } else {
      // at the centre: any direction is as short; move apart along -p, or for coincident
      // agents along x, opposite ways by index
      n = dist2 > 1e-20f ? p * (-1.0f / std::sqrt(dist2)) : F3{ki < kj ? -1.0f : 1.0f, 0.0f, 0.0f};
      along = a.R * a.invDt;
    }
  }
  return makePlane(n, dot(n, vi) + 0.5f * along);
}

// Branch-free selection on the bits: with plain selects or 0/1 blends, GCC turns some
// floating-point operations conditional, and (they could trap) then gives up making
// the loop branch-free, so it does not vectorise.
inline std::uint32_t bitsOf(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}
inline float fromBits(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}
inline std::uint32_t maskOf(bool c) { return 0u - static_cast<std::uint32_t>(c); }  // all ones when c
inline float pick(std::uint32_t mask, float x, float y) { return fromBits((mask & bitsOf(x)) | (~mask & bitsOf(y))); }
inline float maxOf(float a, float b) { return pick(maskOf(a > b), a, b); }

// agentPlane for a batch of neighbours at once, branch-free so that it vectorises (the
// sqrt and divisions dominate otherwise): both candidates, cap and cone, are computed,
// then one is picked. In: p and rv as six arrays of `count` (a multiple of 4, padded);
// out: n and b in four arrays, and `degenerate` = 1 for the neighbours whose normal is
// undefined here (rv on the cone's axis, or an overlapping pair's rv at the centre),
// which agentPlane redoes.
void agentPlanes(std::size_t count, const float* __restrict px, const float* __restrict py, const float* __restrict pz,
                 const float* __restrict rx, const float* __restrict ry, const float* __restrict rz, F3 vi,
                 const AgentConstants& a, float* __restrict nx, float* __restrict ny, float* __restrict nz,
                 float* __restrict b, float* __restrict degenerate) {
  constexpr float kTiny = 1e-20f;
  const float R = a.R, R2 = a.R2, invTau = a.invTau, invDt = a.invDt;
  for (std::size_t t = 0; t < count; ++t) {
    const float dist2 = px[t] * px[t] + py[t] * py[t] + pz[t] * pz[t];
    const std::uint32_t over = maskOf(!(dist2 > R2));
    const float inv = pick(over, invDt, invTau);
    const float wx = rx[t] - px[t] * inv, wy = ry[t] - py[t] * inv, wz = rz[t] - pz[t] * inv;
    const float w2 = wx * wx + wy * wy + wz * wz, wp = wx * px[t] + wy * py[t] + wz * pz[t];
    const std::uint32_t cap = over | (maskOf(wp < 0.0f) & maskOf(wp * wp > R2 * w2));
    const float wl = std::sqrt(w2);
    const float iw = 1.0f / maxOf(wl, kTiny);
    const float dist = std::sqrt(dist2);
    const float id = 1.0f / maxOf(dist, kTiny);
    const float ax = px[t] * id, ay = py[t] * id, az = pz[t] * id;
    const float sinA = R * id, cosA = std::sqrt(maxOf(dist2 - R2, 0.0f)) * id;
    const float s = rx[t] * ax + ry[t] * ay + rz[t] * az;
    const float qx = rx[t] - ax * s, qy = ry[t] - ay * s, qz = rz[t] - az * s;
    const float q2 = qx * qx + qy * qy + qz * qz;
    const float iq = 1.0f / std::sqrt(maxOf(q2, kTiny));
    const float cx = qx * iq * cosA - ax * sinA, cy = qy * iq * cosA - ay * sinA, cz = qz * iq * cosA - az * sinA;
    const float coneAlong = -(rx[t] * cx + ry[t] * cy + rz[t] * cz);
    const float mx = pick(cap, wx * iw, cx), my = pick(cap, wy * iw, cy), mz = pick(cap, wz * iw, cz);
    const float along = pick(cap, R * inv - wl, coneAlong);
    nx[t] = mx;
    ny[t] = my;
    nz[t] = mz;
    b[t] = mx * vi.x + my * vi.y + mz * vi.z + 0.5f * along;
    degenerate[t] = pick(maskOf(pick(cap, w2, q2) > kTiny), 0.0f, 1.0f);
  }
}

// The half-space of an obstacle at distance phi (from the agent centre to the surface)
// with outward unit normal n, treating the surface as its tangent plane: the clearance
// phi + t n . v must stay >= r, i.e. n . v >= (r - phi) / T, with T the obstacle time
// horizon while phi >= r and dt once the agent is closer (then it must get out now).
Plane obstaclePlane(F3 n, float phi, float r, float tauObstacle, float dt) {
  const float gap = r - phi;
  return makePlane(n, gap / (gap > 0.0f ? dt : tauObstacle));
}

// best[0, K) ascending, empty slots ~0: insert key, dropping the largest.
// Branch-free (min/max): the keys arrive in no useful order, so a shifting
// loop mispredicts about once per insertion.
inline void insertBest(std::uint64_t* best, std::size_t K, std::uint64_t key) {
  if (key >= best[K - 1]) return;
  for (std::size_t p = K - 1; p > 0; --p) best[p] = std::max(best[p - 1], std::min(best[p], key));
  best[0] = std::min(best[0], key);
}

// (squared distance, index) as one integer: non-negative floats order like their bits,
// so one compare gives the order by distance, then index
inline std::uint64_t neighborKey(float d2, std::uint32_t index) {
  std::uint32_t bits;
  std::memcpy(&bits, &d2, sizeof bits);
  return (static_cast<std::uint64_t>(bits) << 32) | index;
}
constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
inline float keyDistance2(std::uint64_t key) {
  const auto bits = static_cast<std::uint32_t>(key >> 32);
  float d2;
  std::memcpy(&d2, &bits, sizeof d2);
  return d2;
}

// The k nearest of an agent's block candidates, best[0, K) ascending (kEmpty past the found ones), as
// insertBest of each hit in turn gives them. keys[0, h): the hits' keys (distinct: the index is in them).
inline void selectNearestScalar(const std::uint64_t* keys, std::size_t h, std::uint64_t* best, std::size_t K) {
  std::fill(best, best + K, kEmpty);
  for (std::size_t t = 0; t < h; ++t) insertBest(best, K, keys[t]);
}

#if SWARMSIM_X86_LANES
// at most this many hits go through the rank count (quadratic); more take the scalar insertion
constexpr std::size_t kRankMax = 64;

// selectNearestScalar's result without a branch per comparison: each key's rank is the number of smaller keys
// (they are distinct), counted four at a time, and a key of rank below K goes to best[rank]. Keys are below
// 2^63 (a squared distance's bits, never negative, above the index), so signed 64-bit compares order them.
// keys[] has room for whole lanes: the entries from h on are set to the largest key here.
// Up to 32 keys are held in eight registers, so each key's rank takes no branch; best[] has a slot past K for the
// keys of rank K and more.
SWARMSIM_AVX2 void selectNearestAvx2(std::uint64_t* keys, std::size_t h, std::uint64_t* best, std::size_t K) {
  std::fill(best, best + K, kEmpty);
  const std::size_t padded = (h + 3) / 4 * 4;
  for (std::size_t t = h; t < padded; ++t) keys[t] = std::numeric_limits<std::int64_t>::max();
  if (padded <= 32) {
    const __m256i pad = _mm256_set1_epi64x(std::numeric_limits<std::int64_t>::max());
    __m256i k[8];
    for (std::size_t c = 0; c < 8; ++c) {
      k[c] = 4 * c < padded ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys + 4 * c)) : pad;
    }
    for (std::size_t i = 0; i < h; ++i) {
      const __m256i key = _mm256_set1_epi64x(static_cast<long long>(keys[i]));
      // each compare's lanes as four bits of one word
      unsigned bits = 0;
      for (unsigned c = 0; c < 8; ++c) {
        bits |= static_cast<unsigned>(_mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpgt_epi64(key, k[c]))))
                << (4 * c);
      }
      best[std::min(static_cast<std::size_t>(__builtin_popcount(bits)), K)] = keys[i];
    }
    return;
  }
  for (std::size_t i = 0; i < h; ++i) {
    const __m256i key = _mm256_set1_epi64x(static_cast<long long>(keys[i]));
    std::size_t rank = 0;
    for (std::size_t j = 0; j < padded; j += 4) {
      const __m256i other = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(keys + j));
      rank += static_cast<std::size_t>(
          __builtin_popcount(static_cast<unsigned>(_mm256_movemask_pd(_mm256_castsi256_pd(_mm256_cmpgt_epi64(key, other))))));
    }
    if (rank < K) best[rank] = keys[i];
  }
}

// selectNearestAvx2's result, eight keys a compare (AVX-512). keys[] has room for whole lanes of eight.
// Up to 32 keys are held in four registers, so each key's rank takes no branch; best[] has a slot past K for the
// keys of rank K and more.
SWARMSIM_AVX512 void selectNearestAvx512(std::uint64_t* keys, std::size_t h, std::uint64_t* best, std::size_t K) {
  std::fill(best, best + K, kEmpty);
  const std::size_t padded = (h + 7) / 8 * 8;
  for (std::size_t t = h; t < padded; ++t) keys[t] = std::numeric_limits<std::int64_t>::max();
  if (padded <= 32) {
    const __m512i pad = _mm512_set1_epi64(std::numeric_limits<std::int64_t>::max());
    __m512i k[4];
    for (std::size_t c = 0; c < 4; ++c) k[c] = 8 * c < padded ? _mm512_loadu_si512(keys + 8 * c) : pad;
    const __m512i k0 = k[0], k1 = k[1], k2 = k[2], k3 = k[3];
    for (std::size_t i = 0; i < h; ++i) {
      const __m512i key = _mm512_set1_epi64(static_cast<long long>(keys[i]));
      const std::size_t rank = static_cast<std::size_t>(
          __builtin_popcount(_mm512_cmpgt_epi64_mask(key, k0)) + __builtin_popcount(_mm512_cmpgt_epi64_mask(key, k1)) +
          __builtin_popcount(_mm512_cmpgt_epi64_mask(key, k2)) + __builtin_popcount(_mm512_cmpgt_epi64_mask(key, k3)));
      best[std::min(rank, K)] = keys[i];
    }
    return;
  }
  for (std::size_t i = 0; i < h; ++i) {
    const __m512i key = _mm512_set1_epi64(static_cast<long long>(keys[i]));
    unsigned rank = 0;
    for (std::size_t j = 0; j < padded; j += 8) {
      rank += static_cast<unsigned>(
          __builtin_popcount(_mm512_cmpgt_epi64_mask(key, _mm512_loadu_si512(static_cast<const void*>(keys + j)))));
    }
    if (rank < K) best[rank] = keys[i];
  }
}

// blockHitsAvx2's hits and squared distances, sixteen candidates at a time (AVX-512; the same operations)
SWARMSIM_AVX512 std::size_t blockHitsAvx512(const CellBlock& block, float qx, float qy, float qz, float limit,
                                            float* d2s, std::uint32_t* hits) {
  const std::size_t size = block.size;
  const __m512 vx = _mm512_set1_ps(qx), vy = _mm512_set1_ps(qy), vz = _mm512_set1_ps(qz), vl = _mm512_set1_ps(limit);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  std::size_t found = 0;
  for (std::size_t j = 0; j < size; j += 16) {
    const __mmask16 in = size - j >= 16 ? __mmask16(0xffff) : static_cast<__mmask16>((1u << (size - j)) - 1u);
    const __m512 dx = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, block.x.data() + j), vx);
    const __m512 dy = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, block.y.data() + j), vy);
    const __m512 dz = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, block.z.data() + j), vz);
    const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
    _mm512_mask_storeu_ps(d2s + j, in, d2);
    const __mmask16 hit = _mm512_mask_cmp_ps_mask(in, d2, vl, _CMP_LE_OQ);
    _mm512_mask_compressstoreu_epi32(hits + found, hit, _mm512_add_epi32(lane, _mm512_set1_epi32(static_cast<int>(j))));
    found += static_cast<std::size_t>(__builtin_popcount(hit));
  }
  return found;
}
// rehitAvx2's hits, sixteen at a time
SWARMSIM_AVX512 std::size_t rehitAvx512(const float* d2s, std::size_t size, float limit, std::uint32_t* hits) {
  const __m512 vl = _mm512_set1_ps(limit);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  std::size_t found = 0;
  for (std::size_t j = 0; j < size; j += 16) {
    const __mmask16 in = size - j >= 16 ? __mmask16(0xffff) : static_cast<__mmask16>((1u << (size - j)) - 1u);
    const __mmask16 hit = _mm512_mask_cmp_ps_mask(in, _mm512_maskz_loadu_ps(in, d2s + j), vl, _CMP_LE_OQ);
    _mm512_mask_compressstoreu_epi32(hits + found, hit, _mm512_add_epi32(lane, _mm512_set1_epi32(static_cast<int>(j))));
    found += static_cast<std::size_t>(__builtin_popcount(hit));
  }
  return found;
}

// The keys neighborKey(d2, order[k]) of the sorted points k of the runs [runs[2 i], runs[2 i + 1]) (i < nRuns)
// with d2 <= limit, d2 < nd2 and k != self, sixteen points at a time, read in place from the sorted positions
// (order == nullptr: the identity), in the runs' order. keys[] holds at least the runs' points plus 16.
SWARMSIM_AVX512 std::size_t runKeysAvx512(const float* sx, const float* sy, const float* sz, const std::uint32_t* runs,
                                          std::size_t nRuns, float qx, float qy, float qz, float limit, float nd2,
                                          std::uint32_t self, const std::uint32_t* order, std::uint64_t* keys) {
  const __m512 vx = _mm512_set1_ps(qx), vy = _mm512_set1_ps(qy), vz = _mm512_set1_ps(qz);
  const __m512 vl = _mm512_set1_ps(limit), vn = _mm512_set1_ps(nd2);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i me = _mm512_set1_epi32(static_cast<int>(self));
  std::size_t found = 0;
  for (std::size_t i = 0; i < nRuns; ++i) {
    const std::uint32_t b = runs[2 * i], e = runs[2 * i + 1];
    for (std::uint32_t j = b; j < e; j += 16) {
      const __mmask16 in = e - j >= 16 ? __mmask16(0xffff) : static_cast<__mmask16>((1u << (e - j)) - 1u);
      const __m512 dx = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, sx + j), vx);
      const __m512 dy = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, sy + j), vy);
      const __m512 dz = _mm512_sub_ps(_mm512_maskz_loadu_ps(in, sz + j), vz);
      const __m512 d2 =
          _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
      const __m512i k = _mm512_add_epi32(lane, _mm512_set1_epi32(static_cast<int>(j)));
      const __mmask16 hit = _mm512_mask_cmpneq_epi32_mask(
          _mm512_mask_cmp_ps_mask(_mm512_mask_cmp_ps_mask(in, d2, vl, _CMP_LE_OQ), d2, vn, _CMP_LT_OQ), k, me);
      if (hit == 0) continue;
      const __m512i id = order ? _mm512_mask_i32gather_epi32(k, hit, k, order, 4) : k;
      const __m512i bits = _mm512_castps_si512(d2);
      // (the zero-masked forms where GCC 12 warns about the undefined vector the unmasked ones start from)
      const auto widen = [](__m256i x) SWARMSIM_AVX512 { return _mm512_maskz_cvtepu32_epi64(0xff, x); };
      const auto lower = [](__m512i x) SWARMSIM_AVX512 { return _mm512_maskz_extracti64x4_epi64(0xff, x, 0); };
      const auto upper = [](__m512i x) SWARMSIM_AVX512 { return _mm512_maskz_extracti64x4_epi64(0xff, x, 1); };
      const __m512i lo = _mm512_or_si512(_mm512_maskz_slli_epi64(0xff, widen(lower(bits)), 32), widen(lower(id)));
      const __m512i hi = _mm512_or_si512(_mm512_maskz_slli_epi64(0xff, widen(upper(bits)), 32), widen(upper(id)));
      const auto hitLo = static_cast<__mmask8>(hit & 0xff), hitHi = static_cast<__mmask8>(hit >> 8);
      // compressed in registers, stored whole (a compress straight to memory is slow on some CPUs)
      _mm512_storeu_si512(keys + found, _mm512_maskz_compress_epi64(hitLo, lo));
      found += static_cast<std::size_t>(__builtin_popcount(hitLo));
      _mm512_storeu_si512(keys + found, _mm512_maskz_compress_epi64(hitHi, hi));
      found += static_cast<std::size_t>(__builtin_popcount(hitHi));
    }
  }
  return found;
}

// The block entries within `limit` of q (squared), in block order, to hits[0, returned); their squared distances
// to d2s[0, size) (the same operations as the scalar loop: dx dx + dy dy + dz dz). The block's arrays hold whole
// lanes past size (CellBlock::kSlack); lanes from size on are left out.
SWARMSIM_AVX2 std::size_t blockHitsAvx2(const CellBlock& block, float qx, float qy, float qz, float limit, float* d2s,
                                        std::uint32_t* hits) {
  const std::size_t size = block.size;
  const __m256 vx = _mm256_set1_ps(qx), vy = _mm256_set1_ps(qy), vz = _mm256_set1_ps(qz), vl = _mm256_set1_ps(limit);
  std::size_t found = 0;
  for (std::size_t j = 0; j < size; j += 8) {
    const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(block.x.data() + j), vx);
    const __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(block.y.data() + j), vy);
    const __m256 dz = _mm256_sub_ps(_mm256_loadu_ps(block.z.data() + j), vz);
    const __m256 d2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
    _mm256_storeu_ps(d2s + j, d2);
    unsigned mask = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(d2, vl, _CMP_LE_OQ)));
    if (size - j < 8) mask &= (1u << (size - j)) - 1u;
    found += packLaneIndices(static_cast<std::uint32_t>(j), mask, hits + found);
  }
  return found;
}
// the same from d2s, for a second limit
SWARMSIM_AVX2 std::size_t rehitAvx2(const float* d2s, std::size_t size, float limit, std::uint32_t* hits) {
  const __m256 vl = _mm256_set1_ps(limit);
  std::size_t found = 0;
  for (std::size_t j = 0; j < size; j += 8) {
    unsigned mask = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(_mm256_loadu_ps(d2s + j), vl, _CMP_LE_OQ)));
    if (size - j < 8) mask &= (1u << (size - j)) - 1u;
    found += packLaneIndices(static_cast<std::uint32_t>(j), mask, hits + found);
  }
  return found;
}
#endif

// few points: not worth waking the team
constexpr std::size_t kSerialBelow = 256;
template <typename F>
void forEach(std::size_t n, std::size_t chunk, F&& body) {
  if (n < kSerialBelow) {
    for (std::size_t i = 0; i < n; ++i) body(i);
  } else {
    parallelForDynamic(n, chunk, body);
  }
}

// histogram of the radius each agent's k-nearest search needed, in units of neighborDistance
constexpr std::size_t kBins = 256;
// the next search cell covers this fraction of the agents without widening
constexpr double kCoveredFraction = 0.97;

using Clock = std::chrono::steady_clock;

void checkParams(const Params& p, float dt) {
  const auto bad = [](float v) { return !std::isfinite(v); };
  if (bad(p.radius) || p.radius < 0.0f) throw std::invalid_argument("orca: radius must be >= 0");
  if (bad(p.neighborDistance) || p.neighborDistance < 0.0f) {
    throw std::invalid_argument("orca: neighborDistance must be >= 0");
  }
  if (p.maxNeighbors < 0) throw std::invalid_argument("orca: maxNeighbors must be >= 0");
  if (bad(p.timeHorizon) || !(p.timeHorizon > 0.0f)) throw std::invalid_argument("orca: timeHorizon must be > 0");
  if (bad(p.timeHorizonObstacle) || !(p.timeHorizonObstacle > 0.0f)) {
    throw std::invalid_argument("orca: timeHorizonObstacle must be > 0");
  }
  if (bad(p.maxSpeed) || !(p.maxSpeed > 0.0f)) throw std::invalid_argument("orca: maxSpeed must be > 0");
  if (bad(dt) || !(dt > 0.0f)) throw std::invalid_argument("orca: dt must be > 0");
}

}  // namespace

namespace {

// solveVelocity after its first ball program, which gave v and fail
bool finishVelocity(Plane* planes, std::size_t count, std::size_t hard, F3 want, float R, Plane* scratch,
                    std::size_t fail, F3 v, Vec3& out) {
  const bool infeasible = fail < count;
  if (fail < hard) {
    // the obstacles alone conflict (e.g. deep inside one): their least worst
    // violation first; then those planes, relaxed by it, are kept hard for the agents
    leastViolation(planes, fail, hard, 0, R, scratch, v);
    float worst = 0.0f;
    for (std::size_t h = 0; h < hard; ++h) worst = std::max(worst, planes[h].b - dot(normalOf(planes[h]), v));
    for (std::size_t h = 0; h < hard; ++h) planes[h].b -= worst + 10.0f * kTolerance;
    F3 w;
    fail = ballProgram(planes, count, R, want, false, w);
    if (fail >= hard) {  // else: rounding on the relaxed obstacles; keep their optimum
      v = w;
      if (fail < count) leastViolation(planes, fail, count, hard, R, scratch, v);
    }
  } else if (fail < count) {
    leastViolation(planes, fail, count, hard, R, scratch, v);
  }
  // the programs stay in the ball up to rounding; clamp that, and never return NaN
  const float v2 = dot(v, v);
  if (v2 > R * R) v = v * (R / std::sqrt(v2));
  if (!(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z))) v = F3{0.0f, 0.0f, 0.0f};
  out = Vec3(v.x, v.y, v.z);
  return infeasible;
}

// plane i of lane l in the lanes' layout (lp_lanes.hpp: nx of the eight lanes, then ny, nz and b), and back
inline void putLanePlane(float* soa, std::size_t i, std::size_t l, const Plane& p) {
  float* row = soa + i * kLpPlaneFloats + l;
  row[0] = p.nx;
  row[kLpLanes] = p.ny;
  row[2 * kLpLanes] = p.nz;
  row[3 * kLpLanes] = p.b;
}
inline Plane lanePlane(const float* soa, std::size_t i, std::size_t l) {
  const float* row = soa + i * kLpPlaneFloats + l;
  return Plane{row[0], row[kLpLanes], row[2 * kLpLanes], row[3 * kLpLanes]};
}
// the padding of a lane with fewer planes: no velocity violates it
constexpr Plane kNoPlane{0.0f, 0.0f, 0.0f, -std::numeric_limits<float>::infinity()};

}  // namespace

bool solveVelocity(Plane* planes, std::size_t count, std::size_t hard, const Vec3& pref, float maxSpeed, Plane* scratch,
                   Vec3& out) {
  const F3 want{pref.x(), pref.y(), pref.z()};
  F3 v;
  const std::size_t fail = ballProgram(planes, count, maxSpeed, want, false, v);
  return finishVelocity(planes, count, hard, want, maxSpeed, scratch, fail, v, out);
}

std::size_t solveVelocities(Plane* planes, std::size_t stride, const std::size_t* count, const std::size_t* hard,
                            const Vec3* pref, std::size_t agents, float maxSpeed, Plane* scratch,
                            std::vector<float>& lanesScratch, Vec3* out, bool* infeasible, LaneSet lanes) {
  std::size_t infeasibleCount = 0;
#if SWARMSIM_X86_LANES
  if ((lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512) && agents > 1) {
    for (std::size_t start = 0; start < agents; start += kLpLanes) {
      const std::size_t group = std::min(kLpLanes, agents - start);
      std::size_t most = 0;
      for (std::size_t l = 0; l < group; ++l) most = std::max(most, count[start + l]);
      if (lanesScratch.size() < most * kLpPlaneFloats + 6 * kLpLanes) {
        lanesScratch.resize(most * kLpPlaneFloats + 6 * kLpLanes);
      }
      float* soa = lanesScratch.data();
      float* want = soa + most * kLpPlaneFloats;
      float* got = want + 3 * kLpLanes;
      for (std::size_t l = 0; l < kLpLanes; ++l) {
        const std::size_t a = start + l;
        const std::size_t own = l < group ? count[a] : 0;
        const Plane* mine = planes + a * stride;
        for (std::size_t i = 0; i < most; ++i) putLanePlane(soa, i, l, i < own ? mine[i] : kNoPlane);
        const Vec3 p = l < group ? pref[a] : Vec3::Zero();
        want[l] = p.x();
        want[kLpLanes + l] = p.y();
        want[2 * kLpLanes + l] = p.z();
      }
      std::uint32_t fail[kLpLanes];
      ballProgramLanes(soa, most, maxSpeed, want, got, fail);
      for (std::size_t l = 0; l < group; ++l) {
        const std::size_t a = start + l;
        const F3 v{got[l], got[kLpLanes + l], got[2 * kLpLanes + l]};
        infeasible[a] = finishVelocity(planes + a * stride, count[a], hard[a],
                                       F3{want[l], want[kLpLanes + l], want[2 * kLpLanes + l]}, maxSpeed, scratch,
                                       std::min<std::size_t>(fail[l], count[a]), v, out[a]);
        infeasibleCount += infeasible[a] ? 1 : 0;
      }
    }
    return infeasibleCount;
  }
#else
  (void)lanes;
  (void)lanesScratch;
#endif
  for (std::size_t a = 0; a < agents; ++a) {
    infeasible[a] = solveVelocity(planes + a * stride, count[a], hard[a], pref[a], maxSpeed, scratch, out[a]);
    infeasibleCount += infeasible[a] ? 1 : 0;
  }
  return infeasibleCount;
}

Plane agentHalfSpace(const Vec3& p, const Vec3& vi, const Vec3& vj, float radius, float timeHorizon, float dt) {
  const float R = 2.0f * radius;
  const AgentConstants ac{R, R * R, 1.0f / timeHorizon, 1.0f / dt};
  const F3 v{vi.x(), vi.y(), vi.z()};
  // the batch path of solve(), with one neighbour and three fillers
  float in[6][4] = {
      {p.x(), 1.0f + R, 1.0f + R, 1.0f + R}, {p.y()}, {p.z()}, {vi.x() - vj.x()}, {vi.y() - vj.y()}, {vi.z() - vj.z()}};
  float out[5][4];
  agentPlanes(4, in[0], in[1], in[2], in[3], in[4], in[5], v, ac, out[0], out[1], out[2], out[3], out[4]);
  if (out[4][0] == 0.0f) return Plane{out[0][0], out[1][0], out[2][0], out[3][0]};
  return agentPlane(F3{in[0][0], in[1][0], in[2][0]}, v, F3{in[3][0], in[4][0], in[5][0]}, 0, 1, ac);
}

void Solver::saveState(StateOut& out) const {
  out.put(nextCell_);
  out.put<std::uint64_t>(lastSize_);
}

void Solver::loadState(StateIn& in) {
  nextCell_ = in.get<float>();
  lastSize_ = static_cast<std::size_t>(in.get<std::uint64_t>());
}

float Solver::suggestedCell(const Params& params) const {
  const float nd = params.neighborDistance;
  if (!(nextCell_ > 0.0f) || !(nd > 0.0f)) return nd;
  return std::clamp(nextCell_, nd / 16.0f, nd);
}

void Solver::findNeighbors(const UniformGrid& grid, const Params& params) {
  const std::size_t n = grid.size();
  const auto K = static_cast<std::size_t>(params.maxNeighbors);
  const float nd = params.neighborDistance;
  std::fill(count_.begin(), count_.end(), 0u);
  widened_ = 0;
  if (K == 0 || !(nd > 0.0f) || n < 2) {
    cell_ = 0.0f;
    return;
  }
  const float* gx = grid.sortedX().data();
  const float* gy = grid.sortedY().data();
  const float* gz = grid.sortedZ().data();

  // Cell edge h of the search grid: each cell gathers its 3x3x3 block, which holds
  // every agent within h of any agent of the cell, so an agent's k nearest are final
  // when the k-th is within h. Large h: big blocks; small h: many agents widen their
  // search. h is the radius that covered kCoveredFraction of the agents in the last
  // solve, or at first a guess from the mean density (1.3 times the mean k-th distance
  // of a uniform swarm in the bounding box). It only affects speed, never the result.
  float h = nextCell_;
  if (!(h > 0.0f) || n > 2 * lastSize_ || 2 * n < lastSize_) {
    float lo[3] = {gx[0], gy[0], gz[0]}, hi[3] = {gx[0], gy[0], gz[0]};
    for (std::size_t k = 1; k < n; ++k) {
      const float v[3] = {gx[k], gy[k], gz[k]};
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], v[a]);
        hi[a] = std::max(hi[a], v[a]);
      }
    }
    double volume = 1.0;
    for (int a = 0; a < 3; ++a) volume *= std::max(static_cast<double>(hi[a]) - lo[a], 0.25 * nd);
    const double kth =
        std::cbrt(3.0 * static_cast<double>(K) * volume / (4.0 * 3.14159265358979 * static_cast<double>(n)));
    h = static_cast<float>(1.3 * kth);
  }
  h = std::clamp(h, nd / 16.0f, nd);
  cell_ = h;
  // the caller's grid serves when its cells are at least h (blocks of 3x3x3 cells then
  // cover h) and not much larger (bigger blocks only cost time); otherwise our own
  reused_ = true;
  for (int a = 0; a < 3; ++a) reused_ = reused_ && grid.cellSize(a) >= h && grid.cellSize(a) <= 1.5f * h;
  if (!reused_) search_.build(gx, gy, gz, n, h);
  const UniformGrid& sg = reused_ ? grid : search_;
  if (reused_ && identity_.size() != n) {
    identity_.resize(n);
    for (std::size_t k = 0; k < n; ++k) identity_[k] = static_cast<std::uint32_t>(k);
  }

  const float* sx = sg.sortedX().data();
  const float* sy = sg.sortedY().data();
  const float* sz = sg.sortedZ().data();
  const std::uint32_t* order = reused_ ? identity_.data() : search_.order().data();
  const float nd2 = nd * nd;
  const float rc = h;  // gatherCell(c, h) spans one cell each way (cells are >= h wide)
  const bool blockIsAll = rc >= nd;
  const float finalBelow = rc * rc * (1.0f - 1e-5f);  // margin for float rounding of distances
  // candidates beyond this cannot be among the k nearest unless the search widens
  const float blockLimit = blockIsAll ? nd2 : finalBelow;
  for (auto& t : threads_) {
    std::fill(t.histogram.begin(), t.histogram.end(), 0u);
    t.widened = 0;
  }
  const float binScale = static_cast<float>(kBins) / nd;

  const LaneSet lanes = laneSet();
  const bool wide = lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512;  // the selection on AVX2 (same result)
  const bool wide512 = lanes == LaneSet::kAvx512;                          // and on AVX-512
  const auto cellWork = [&](std::size_t c) {
    const std::uint32_t a0 = sg.cellBegin(c), a1 = sg.cellEnd(c);
    if (a0 == a1) return;
    ThreadScratch& ts = threads_[static_cast<std::size_t>(threadIndex())];
    CellBlock& block = ts.block;
    sg.gatherCell(c, rc, block);
    std::uint64_t* best = ts.best.data();
    float guess = blockLimit;
    for (std::uint32_t m = a0; m < a1; ++m) {
      const float qx = sx[m], qy = sy[m], qz = sz[m];
      // distances to the whole block, then a first cut at a guess of the k-th distance
      // (the previous agent's: the cell's agents are close together) so that few
      // candidates go through the selection; if that leaves fewer than k, the block radius
      const std::size_t size = block.size;
#if SWARMSIM_X86_LANES
      if (wide) {
        // the same hits and keys as below, eight candidates at a time, and the k nearest by rank counts
        float* d2w = block.d2.data();
        std::uint32_t* hitw = block.hits.data();
        const auto blockHits = [&](float limit) {
          return wide512 ? blockHitsAvx512(block, qx, qy, qz, limit, d2w, hitw)
                         : blockHitsAvx2(block, qx, qy, qz, limit, d2w, hitw);
        };
        std::size_t hits = guess < blockLimit ? blockHits(guess) : 0;
        if (guess >= blockLimit) {
          hits = blockHits(blockLimit);
        } else if (hits <= K) {
          hits = wide512 ? rehitAvx512(d2w, size, blockLimit, hitw) : rehitAvx2(d2w, size, blockLimit, hitw);
        }
        if (ts.keys.size() < size + 8) ts.keys.resize(size + 8);  // grows to the largest block, then stays
        std::uint64_t* keys = ts.keys.data();
        std::size_t nk = 0;
        for (std::size_t t = 0; t < hits; ++t) {
          const std::uint32_t b = hitw[t];
          const std::uint32_t other = block.index[b];
          const float d2 = d2w[b];
          keys[nk] = neighborKey(d2, order[other]);
          nk += static_cast<std::size_t>(other != m && d2 < nd2);
        }
        if (nk <= kRankMax && wide512) {
          selectNearestAvx512(keys, nk, best, K);
        } else if (nk <= kRankMax) {
          selectNearestAvx2(keys, nk, best, K);
        } else {
          selectNearestScalar(keys, nk, best, K);
        }
      } else
#endif
      {
        {
          const float* __restrict bx = block.x.data();
          const float* __restrict by = block.y.data();
          const float* __restrict bz = block.z.data();
          float* __restrict dd = block.d2.data();
          for (std::size_t j = 0; j < size; ++j) {  // vectorises
            const float dx = bx[j] - qx, dy = by[j] - qy, dz = bz[j] - qz;
            dd[j] = dx * dx + dy * dy + dz * dz;
          }
        }
        const float* d2s = block.d2.data();
        std::uint32_t* hit = block.hits.data();
        const auto compact = [&](float limit) {
          std::size_t found = 0;
          for (std::size_t j = 0; j < size; ++j) {  // branch-free
            hit[found] = static_cast<std::uint32_t>(j);
            found += d2s[j] <= limit ? 1u : 0u;
          }
          return found;
        };
        std::size_t hits = guess < blockLimit ? compact(guess) : 0;
        if (hits <= K) hits = compact(blockLimit);  // (the agent itself is one of the hits)
        std::fill(best, best + K, kEmpty);
        for (std::size_t t = 0; t < hits; ++t) {
          const std::uint32_t b = hit[t];
          const std::uint32_t other = block.index[b];
          const float d2 = d2s[b];
          if (other == m || !(d2 < nd2)) continue;
          insertBest(best, K, neighborKey(d2, order[other]));
        }
      }
      if (!blockIsAll && !(best[K - 1] != kEmpty && keyDistance2(best[K - 1]) <= finalBelow)) {
        // the k-th may lie outside the block. Once k candidates are known, the k-th
        // of them bounds the true k-th distance, so one search of that radius is final;
        // with fewer, search in growing cubes up to neighborDistance.
        ++ts.widened;
        const auto search = [&](float r, float limit) {
#if SWARMSIM_X86_LANES
          if (wide512) {  // the same keys sixteen at a time, and their k smallest by rank counts
            std::size_t runCount = 0, points = 0;
            sg.forEachRun(qx, qy, qz, r, [&](std::uint32_t b, std::uint32_t e) {
              if (b == e) return;
              if (ts.runs.size() < 2 * runCount + 2) ts.runs.resize(2 * runCount + 64);
              ts.runs[2 * runCount] = b;
              ts.runs[2 * runCount + 1] = e;
              ++runCount;
              points += e - b;
            });
            if (ts.wideKeys.size() < points + 16) ts.wideKeys.resize(points + 16);  // grows, then stays
            std::uint64_t* keys = ts.wideKeys.data();
            const std::size_t nk = runKeysAvx512(sx, sy, sz, ts.runs.data(), runCount, qx, qy, qz, limit, nd2, m,
                                                 reused_ ? nullptr : order, keys);
            if (nk <= kRankMax) {
              selectNearestAvx512(keys, nk, best, K);
            } else {
              selectNearestScalar(keys, nk, best, K);
            }
            return;
          }
#endif
          std::fill(best, best + K, kEmpty);
          sg.forEachRun(qx, qy, qz, r, [&](std::uint32_t b, std::uint32_t e) {
            for (std::uint32_t o = b; o < e; ++o) {
              const float dx = sx[o] - qx, dy = sy[o] - qy, dz = sz[o] - qz;
              const float d2 = dx * dx + dy * dy + dz * dz;
              if (o == m || !(d2 <= limit && d2 < nd2)) continue;
              insertBest(best, K, neighborKey(d2, order[o]));
            }
          });
        };
        float r = rc;
        while (best[K - 1] == kEmpty && r < nd) {
          r = std::min(nd, 1.5f * r);
          search(r, r * r);
        }
        if (best[K - 1] != kEmpty && !(r >= nd || keyDistance2(best[K - 1]) <= r * r * (1.0f - 1e-5f))) {
          const float kth2 = keyDistance2(best[K - 1]);
          search(std::sqrt(kth2), kth2);
        }
      }
      const std::size_t cnt = static_cast<std::size_t>(std::lower_bound(best, best + K, kEmpty) - best);
      const std::uint32_t k = order[m];
      std::uint32_t* out = nbr_.data() + static_cast<std::size_t>(k) * K;
      for (std::size_t t = 0; t < cnt; ++t) out[t] = static_cast<std::uint32_t>(best[t]);
      count_[k] = static_cast<std::uint32_t>(cnt);
      guess = cnt == K ? 1.3f * keyDistance2(best[K - 1]) : blockLimit;
      const float needed = cnt == K ? std::sqrt(keyDistance2(best[K - 1])) : nd;
      ++ts.histogram[std::min(kBins - 1, static_cast<std::size_t>(needed * binScale))];
    }
  };
  const std::size_t cells = sg.cellCount();
  if (n < kSerialBelow) {
    for (std::size_t c = 0; c < cells; ++c) cellWork(c);
  } else {
    const auto team = static_cast<std::size_t>(std::max(1, threadCount()));
    const std::size_t chunk = std::clamp<std::size_t>(cells / (16 * team), 1, 64);
    parallelForDynamic(cells, chunk, cellWork);
  }

  // next cell edge: the radius that covered kCoveredFraction of the agents
  std::fill(histogram_.begin(), histogram_.end(), 0u);
  for (const auto& t : threads_) {
    for (std::size_t b = 0; b < kBins; ++b) histogram_[b] += t.histogram[b];
    widened_ += t.widened;
  }
  const auto target = static_cast<std::size_t>(kCoveredFraction * static_cast<double>(n));
  std::size_t seen = 0, bin = 0;
  while (bin + 1 < kBins && (seen += histogram_[bin]) < target) ++bin;
  nextCell_ = nd * static_cast<float>(bin + 1) / static_cast<float>(kBins);
  lastSize_ = n;
}

void Solver::solve(const UniformGrid& grid, const float* vx, const float* vy, const float* vz, const float* prefX,
                   const float* prefY, const float* prefZ, const Params& params, const Obstacles& obstacles, float dt,
                   float* outX, float* outY, float* outZ) {
  checkParams(params, dt);
  const auto t0 = Clock::now();
  const std::size_t n = grid.size();
  const auto K = static_cast<std::size_t>(params.maxNeighbors);
  // scratch: grows only when the problem or the team grows
  stride_ = params.maxNeighbors;
  if (nbr_.size() < n * K) nbr_.resize(n * K);
  count_.resize(n);
  histogram_.resize(kBins);
  const auto team = static_cast<std::size_t>(std::max(1, threadCount()));
  if (threads_.size() < team) threads_.resize(team);
  const std::size_t maxPlanes = K + obstacles.spheres.size() + 1;
  for (auto& t : threads_) {
    if (t.best.size() < K + 1) t.best.resize(K + 1);  // a slot past the K nearest (selectNearestAvx512)
    if (t.planes.size() < kLpLanes * maxPlanes) {
      t.planes.resize(kLpLanes * maxPlanes);
      t.projected.resize(maxPlanes);
    }
    if (t.batch.size() < 11 * (K + 3)) t.batch.resize(11 * (K + 3));
    // the lanes' planes, the neighbours' rows, the agents' own rows and the neighbours' planes apart
    const std::size_t lanesFloats = maxPlanes * kLpPlaneFloats + K * 6 * kLpLanes + 9 * kLpLanes + K * kLpPlaneFloats;
    if (t.lanes.size() < lanesFloats) t.lanes.resize(lanesFloats);
    if (t.degenerate.size() < K) t.degenerate.resize(K);
    t.histogram.resize(kBins);
    t.infeasible = 0;
  }

  findNeighbors(grid, params);
  const auto t1 = Clock::now();

  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  const float r = params.radius;
  const float R = 2.0f * r;
  const AgentConstants ac{R, R * R, 1.0f / params.timeHorizon, 1.0f / dt};
  const float tauO = params.timeHorizonObstacle;
  const float reach = params.maxSpeed * tauO;  // obstacles farther than r + reach cannot be hit in time
  const Grid3<float>* sdf = obstacles.sdf;
  const LaneSet lanes = laneSet();
  const bool onLanes = SWARMSIM_X86_LANES && (lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512);
  // the obstacles' half-spaces of agent k to planes[0, returned); they come first and stay hard in the fallback
  const auto obstaclePlanes = [&](std::size_t k, Plane* planes) {
    std::size_t m = 0;
    const F3 xi{sx[k], sy[k], sz[k]};
    for (const Sphere& s : obstacles.spheres) {
      const F3 d = xi - F3{s.center.x(), s.center.y(), s.center.z()};
      const float dist2 = dot(d, d), far = s.radius + r + reach;
      if (dist2 >= far * far) continue;
      const float dist = std::sqrt(dist2);
      const F3 nrm = dist > 0.0f ? d * (1.0f / dist) : F3{1.0f, 0.0f, 0.0f};
      Plane pl = obstaclePlane(nrm, dist - s.radius, r, tauO, dt);
      pl.b += nrm.x * s.velocity.x() + nrm.y * s.velocity.y() + nrm.z * s.velocity.z();  // n.(v - v_s) >= b
      planes[m++] = pl;
    }
    if (sdf) {
      const Vec3 x(xi.x, xi.y, xi.z);
      const float phi = sdf->sample(x);
      if (phi - r < reach) {
        const Vec3 gr = normalAt(*sdf, x);
        if (gr.squaredNorm() > 0.0f) planes[m++] = obstaclePlane(F3{gr.x(), gr.y(), gr.z()}, phi, r, tauO, dt);
      }
    }
    return m;
  };
  // agents in groups of kLpLanes: each agent's half-spaces, then the group's programs at once
  const std::size_t groups = (n + kLpLanes - 1) / kLpLanes;
  forEach(groups, 32, [&](std::size_t g) {
    ThreadScratch& ts = threads_[static_cast<std::size_t>(threadIndex())];
    const std::size_t first = g * kLpLanes, agents = std::min(kLpLanes, n - first);
    std::size_t counts[kLpLanes] = {}, hards[kLpLanes] = {};
#if SWARMSIM_X86_LANES
    if (onLanes) {
      // one agent per lane: the neighbours' half-spaces and the programs on the lanes, straight in their layout
      std::size_t neighbours[kLpLanes] = {};
      const std::uint32_t* nbs[kLpLanes] = {};
      std::size_t T = 0, most = 0;
      bool sameHard = true;
      for (std::size_t a = 0; a < agents; ++a) {
        hards[a] = obstaclePlanes(first + a, ts.planes.data() + a * maxPlanes);
        nbs[a] = neighbors(first + a, neighbours[a]);
        T = std::max(T, neighbours[a]);
        most = std::max(most, hards[a] + neighbours[a]);
        sameHard = sameHard && hards[a] == hards[0];
      }
      float* soa = ts.lanes.data();
      float* rel = soa + maxPlanes * kLpPlaneFloats;
      float* own = rel + K * 6 * kLpLanes;  // the agents' velocities, then their preferred ones, then the results
      float* tmp = own + 9 * kLpLanes;      // the neighbours' half-spaces when the obstacles' counts differ
      std::uint8_t* degenerate = ts.degenerate.data();
      for (std::size_t a = 0; a < kLpLanes; ++a) {
        const bool real = a < agents;
        const std::size_t k = first + a;
        const float xs = real ? sx[k] : 0.0f, ys = real ? sy[k] : 0.0f, zs = real ? sz[k] : 0.0f;
        const float us = real ? vx[k] : 0.0f, vs = real ? vy[k] : 0.0f, ws = real ? vz[k] : 0.0f;
        own[a] = us;
        own[kLpLanes + a] = vs;
        own[2 * kLpLanes + a] = ws;
        own[3 * kLpLanes + a] = real ? prefX[k] : 0.0f;
        own[4 * kLpLanes + a] = real ? prefY[k] : 0.0f;
        own[5 * kLpLanes + a] = real ? prefZ[k] : 0.0f;
        for (std::size_t t = 0; t < T; ++t) {
          float* row = rel + t * 6 * kLpLanes + a;
          if (t < neighbours[a]) {
            const std::uint32_t j = nbs[a][t];
            row[0] = sx[j] - xs;
            row[kLpLanes] = sy[j] - ys;
            row[2 * kLpLanes] = sz[j] - zs;
            row[3 * kLpLanes] = us - vx[j];
            row[4 * kLpLanes] = vs - vy[j];
            row[5 * kLpLanes] = ws - vz[j];
          } else {  // harmless filler, replaced by padding below
            row[0] = 1.0f + R;
            row[kLpLanes] = row[2 * kLpLanes] = row[3 * kLpLanes] = row[4 * kLpLanes] = row[5 * kLpLanes] = 0.0f;
          }
        }
      }
      const std::size_t base = sameHard ? hards[0] : 0;
      float* agentRows = sameHard ? soa + base * kLpPlaneFloats : tmp;
      agentPlanesLanes(rel, T, own, ac.R, ac.invTau, ac.invDt, agentRows, degenerate);
      for (std::size_t a = 0; a < kLpLanes; ++a) {
        const Plane* hardPlanes = ts.planes.data() + a * maxPlanes;
        for (std::size_t i = 0; i < hards[a]; ++i) putLanePlane(soa, i, a, hardPlanes[i]);
        if (!sameHard) {
          for (std::size_t t = 0; t < neighbours[a]; ++t) putLanePlane(soa, hards[a] + t, a, lanePlane(tmp, t, a));
        }
        for (std::size_t i = hards[a] + neighbours[a]; i < std::max(most, base + T); ++i) {
          putLanePlane(soa, i, a, kNoPlane);
        }
        counts[a] = hards[a] + neighbours[a];
      }
      for (std::size_t t = 0; t < T; ++t) {
        for (unsigned bits = degenerate[t]; bits != 0; bits &= bits - 1) {
          const auto a = static_cast<std::size_t>(__builtin_ctz(bits));
          if (t >= neighbours[a]) continue;
          const float* in = rel + t * 6 * kLpLanes + a;
          const F3 vi{own[a], own[kLpLanes + a], own[2 * kLpLanes + a]};
          putLanePlane(soa, hards[a] + t, a,
                       agentPlane(F3{in[0], in[kLpLanes], in[2 * kLpLanes]}, vi,
                                  F3{in[3 * kLpLanes], in[4 * kLpLanes], in[5 * kLpLanes]},
                                  static_cast<std::uint32_t>(first + a), nbs[a][t], ac));
        }
      }
      std::uint32_t fail[kLpLanes];
      float* got = own + 6 * kLpLanes;
      ballProgramLanes(soa, most, params.maxSpeed, own + 3 * kLpLanes, got, fail);
      for (std::size_t a = 0; a < agents; ++a) {
        const std::size_t failed = std::min<std::size_t>(fail[a], counts[a]);
        Plane* planes = ts.planes.data() + a * maxPlanes;
        if (failed < counts[a]) {  // the fallback works on the agent's own planes
          for (std::size_t i = 0; i < counts[a]; ++i) planes[i] = lanePlane(soa, i, a);
        }
        Vec3 v;
        const F3 want{own[3 * kLpLanes + a], own[4 * kLpLanes + a], own[5 * kLpLanes + a]};
        const F3 at{got[a], got[kLpLanes + a], got[2 * kLpLanes + a]};
        if (finishVelocity(planes, counts[a], hards[a], want, params.maxSpeed, ts.projected.data(), failed, at, v)) {
          ++ts.infeasible;
        }
        outX[first + a] = v.x();
        outY[first + a] = v.y();
        outZ[first + a] = v.z();
      }
      return;
    }
#endif
    Vec3 prefs[kLpLanes], outs[kLpLanes];
    for (std::size_t a = 0; a < kLpLanes; ++a) prefs[a] = outs[a] = Vec3::Zero();
    bool infeasible[kLpLanes];
    for (std::size_t a = 0; a < agents; ++a) {
      const std::size_t k = first + a;
      Plane* planes = ts.planes.data() + a * maxPlanes;
      std::size_t m = obstaclePlanes(k, planes);
      const F3 xi{sx[k], sy[k], sz[k]};
      const F3 vi{vx[k], vy[k], vz[k]};
      hards[a] = m;
      std::size_t cnt;
      const std::uint32_t* nb = neighbors(k, cnt);
      {
        const std::size_t padded = (cnt + 3) & ~std::size_t{3};
        float* f = ts.batch.data();
        float *px = f, *py = px + padded, *pz = py + padded, *rx = pz + padded, *ry = rx + padded, *rz = ry + padded;
        for (std::size_t t = 0; t < cnt; ++t) {
          const std::uint32_t j = nb[t];
          px[t] = sx[j] - xi.x;
          py[t] = sy[j] - xi.y;
          pz[t] = sz[j] - xi.z;
          rx[t] = vi.x - vx[j];
          ry[t] = vi.y - vy[j];
          rz[t] = vi.z - vz[j];
        }
        for (std::size_t t = cnt; t < padded; ++t) {  // harmless filler, dropped below
          px[t] = 1.0f + R;
          py[t] = pz[t] = rx[t] = ry[t] = rz[t] = 0.0f;
        }
        float *nx = rz + padded, *ny = nx + padded, *nz = ny + padded, *b = nz + padded, *degenerate = b + padded;
        agentPlanes(padded, px, py, pz, rx, ry, rz, vi, ac, nx, ny, nz, b, degenerate);
        for (std::size_t t = 0; t < cnt; ++t) {
          planes[m++] = degenerate[t] == 0.0f ? Plane{nx[t], ny[t], nz[t], b[t]}
                                              : agentPlane(F3{px[t], py[t], pz[t]}, vi, F3{rx[t], ry[t], rz[t]},
                                                           static_cast<std::uint32_t>(k), nb[t], ac);
        }
      }
      counts[a] = m;
      prefs[a] = Vec3(prefX[k], prefY[k], prefZ[k]);
    }
    ts.infeasible += solveVelocities(ts.planes.data(), maxPlanes, counts, hards, prefs, agents, params.maxSpeed,
                                     ts.projected.data(), ts.lanes, outs, infeasible, lanes);
    for (std::size_t a = 0; a < agents; ++a) {
      outX[first + a] = outs[a].x();
      outY[first + a] = outs[a].y();
      outZ[first + a] = outs[a].z();
    }
  });
  infeasible_ = 0;
  for (const auto& t : threads_) infeasible_ += t.infeasible;
  const auto t2 = Clock::now();
  neighbourSeconds_ = std::chrono::duration<double>(t1 - t0).count();
  lpSeconds_ = std::chrono::duration<double>(t2 - t1).count();
}

}  // namespace swarmsim::orca
