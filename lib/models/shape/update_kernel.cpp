#include "models/shape/update_kernel.hpp"

#include <algorithm>
#include <array>

namespace swarmsim {

namespace {

// the eight-lane view of an InsectUpdate's arrays, from a given index on, and the block's forces
struct UpdateArrays {
  const float* in[12];    // x, y, z, vx, vy, vz, cnx, cny, cnz, sx, sy, sz
  const float* force[6];  // F_int x, y, z, F_con x, y, z
  float* out[6];          // nvx, nvy, nvz, tx, ty, tz
};

template <typename L>
inline typename L::V select(typename L::V m, typename L::V a, typename L::V b) {
  return L::bor(L::band(m, a), L::andnot(m, b));
}

// |(x, y, z)| as Eigen's norm() of a 3-vector computes it: sqrt(x² + (y² + z²))
template <typename L>
inline typename L::V norm3(typename L::V x, typename L::V y, typename L::V z) {
  return L::sqrt(L::add(L::mul(x, x), L::add(L::mul(y, y), L::mul(z, z))));
}

// The last m (< kLanes) insects of a block through padded lane buffers: each in[c] (null: not read) copied to
// its buffer, zeros past m (and in a buffer of a null input); body(ins, outs) run once on the buffers; the
// first width[c] m floats of each output buffer copied to out[c] (null: not written). Output buffers hold up to
// three floats an insect.
template <std::size_t NIn, std::size_t NOut, typename Body>
void throughPadded(std::size_t m, const std::array<const float*, NIn>& in, const std::array<float*, NOut>& out,
                   const std::array<std::size_t, NOut>& width, Body&& body) {
  alignas(32) float tin[NIn][kLanes] = {};
  alignas(32) float tout[NOut][3 * kLanes] = {};
  std::array<const float*, NIn> ins;
  std::array<float*, NOut> outs;
  for (std::size_t c = 0; c < NIn; ++c) {
    if (in[c]) std::copy(in[c], in[c] + m, tin[c]);
    ins[c] = tin[c];
  }
  for (std::size_t c = 0; c < NOut; ++c) outs[c] = tout[c];
  body(ins, outs);
  for (std::size_t c = 0; c < NOut; ++c) {
    if (out[c]) std::copy(tout[c], tout[c] + width[c] * m, out[c]);
  }
}

// eight insects: a.in[·][0..7], a.force[·][0..7] to a.out[·][0..7]
template <typename L>
inline void updateLanes(const InsectUpdate& u, const UpdateArrays& a) {
  using V = typename L::V;
  const V zero = L::set1(0.0f), one = L::set1(1.0f), half = L::set1(0.5f), four = L::set1(4.0f);
  const V dt = L::set1(u.dt), alpha = L::set1(u.alpha), beta = L::set1(1.0f - u.alpha);
  const V x[3] = {L::load(a.in[0]), L::load(a.in[1]), L::load(a.in[2])};
  V v[3] = {L::load(a.in[3]), L::load(a.in[4]), L::load(a.in[5])};
  V internal[3], external[3];
  for (int c = 0; c < 3; ++c) {
    internal[c] = L::add(L::load(a.force[c]), L::load(a.in[6 + c]));
    external[c] = zero;
  }
  if (u.shaped) {
    for (int c = 0; c < 3; ++c) external[c] = L::add(external[c], L::load(a.force[3 + c]));
    // F_dis (shape.hpp's distanceForce and distanceProfile)
    V to[3];
    for (int c = 0; c < 3; ++c) to[c] = L::sub(L::load(a.in[9 + c]), x[c]);
    const V e = norm3<L>(to[0], to[1], to[2]);
    const V d = L::mul(e, L::set1(u.invRange));
    const V ed = L::sub(d, half);
    const V profile =
        L::band(L::band(L::gt(d, zero), L::le(d, one)), L::add(L::mul(L::mul(L::mul(four, ed), ed), ed), half));
    const V scale = L::div(L::mul(L::set1(u.wDis), profile), e);
    const V some = L::gt(e, zero);
    for (int c = 0; c < 3; ++c) external[c] = L::add(external[c], L::band(some, L::mul(to[c], scale)));
  }
  for (int c = 0; c < 3; ++c) {
    const V force = L::add(L::mul(alpha, internal[c]), L::mul(beta, external[c]));
    v[c] = L::add(v[c], L::mul(force, dt));
  }
  const V vmax = L::set1(u.maxSpeed);
  const V sp = norm3<L>(v[0], v[1], v[2]);
  const V fast = L::gt(sp, vmax), scale = L::div(vmax, sp);
  for (int c = 0; c < 3; ++c) {
    v[c] = select<L>(fast, L::mul(v[c], scale), v[c]);
    L::store(a.out[c], v[c]);
    L::store(a.out[3 + c], L::add(x[c], L::mul(v[c], dt)));
  }
}

template <typename L>
void updateBlock(const InsectUpdate& u, std::size_t first, std::size_t count, const float* const fInt[3],
                 const float* const fCon[3]) {
  const float* in[12];
  float* out[6];
  for (int c = 0; c < 3; ++c) {
    in[c] = u.x[c];
    in[3 + c] = u.v[c];
    in[6 + c] = u.noise[c];
    in[9 + c] = u.sample[c];
    out[c] = u.nv[c];
    out[3 + c] = u.t[c];
  }
  std::size_t i = 0;
  for (; i + kLanes <= count; i += kLanes) {
    UpdateArrays a;
    for (int c = 0; c < 12; ++c) a.in[c] = in[c] ? in[c] + first + i : nullptr;
    for (int c = 0; c < 3; ++c) {
      a.force[c] = fInt[c] + i;
      a.force[3 + c] = fCon[c] + i;
    }
    for (int c = 0; c < 6; ++c) a.out[c] = out[c] + first + i;
    if (!u.shaped) a.in[9] = a.in[10] = a.in[11] = a.force[3] = a.force[4] = a.force[5] = a.in[0];  // (unread)
    updateLanes<L>(u, a);
  }
  if (i == count) return;
  // the last few: the arrays, then the forces, through padded copies
  std::array<const float*, 18> tin;
  std::array<float*, 6> tout;
  for (std::size_t c = 0; c < 12; ++c) tin[c] = in[c] && (u.shaped || c < 9) ? in[c] + first + i : nullptr;
  for (std::size_t c = 0; c < 3; ++c) {
    tin[12 + c] = fInt[c] + i;
    tin[15 + c] = u.shaped ? fCon[c] + i : nullptr;
  }
  for (std::size_t c = 0; c < 6; ++c) tout[c] = out[c] + first + i;
  std::array<std::size_t, 6> width;
  width.fill(1);
  throughPadded(count - i, tin, tout, width,
                [&](const std::array<const float*, 18>& ins, const std::array<float*, 6>& outs) {
                  UpdateArrays a;
                  std::copy(ins.begin(), ins.begin() + 12, a.in);
                  std::copy(ins.begin() + 12, ins.end(), a.force);
                  std::copy(outs.begin(), outs.end(), a.out);
                  updateLanes<L>(u, a);
                });
}

// writeInsects of eight insects from k on
template <typename L>
inline void writeLanes(const InsectWrite& w, std::size_t k) {
  using V = typename L::V;
  V x[3], v[3];
  for (int c = 0; c < 3; ++c) {
    x[c] = L::load(w.t[c] + k);
    if (w.addZero) x[c] = L::add(x[c], L::set1(0.0f));
    // std::max(x, lo) is lo where lo > x, else x; std::min(·, hi) is hi where hi < it
    x[c] = L::min(L::set1(w.hi[c]), L::max(L::set1(w.lo[c]), x[c]));
    v[c] = L::load(w.nv[c] + k);
    L::store(w.p[c] + k, x[c]);
    L::store(w.v[c] + k, v[c]);
  }
  L::store(w.speed + k, norm3<L>(v[0], v[1], v[2]));
  if (w.shaped) {
    V d[3];
    for (int c = 0; c < 3; ++c) d[c] = L::sub(L::load(w.target[c] + k), x[c]);
    L::store(w.err + k, norm3<L>(d[0], d[1], d[2]));
  }
  if (w.move) {
    alignas(32) float m[3][kLanes];
    for (int c = 0; c < 3; ++c) L::store(m[c], L::sub(x[c], L::load(w.start[c] + k)));
    float* out = w.move + 3 * k;
    for (std::size_t l = 0; l < kLanes; ++l) {
      for (int c = 0; c < 3; ++c) out[3 * l + static_cast<std::size_t>(c)] = m[c][l];
    }
  }
}

template <typename L>
void writeBlock(const InsectWrite& w, std::size_t first, std::size_t count) {
  std::copy(w.ids + first, w.ids + first + count, w.id + first);
  std::fill(w.moved + first, w.moved + first + count, std::uint8_t{0});
  std::size_t k = first;
  const std::size_t end = first + count;
  for (; k + kLanes <= end; k += kLanes) writeLanes<L>(w, k);
  if (k == end) return;
  // the last few: t, start, nv and target to p, v, speed, err and move, through padded copies
  std::array<const float*, 12> in;
  for (std::size_t c = 0; c < 3; ++c) {
    in[c] = w.t[c] + k;
    in[3 + c] = w.move ? w.start[c] + k : nullptr;
    in[6 + c] = w.nv[c] + k;
    in[9 + c] = w.shaped ? w.target[c] + k : nullptr;
  }
  const std::array<float*, 9> out = {w.p[0] + k,
                                     w.p[1] + k,
                                     w.p[2] + k,
                                     w.v[0] + k,
                                     w.v[1] + k,
                                     w.v[2] + k,
                                     w.speed + k,
                                     w.shaped ? w.err + k : nullptr,
                                     w.move ? w.move + 3 * k : nullptr};
  const std::array<std::size_t, 9> width = {1, 1, 1, 1, 1, 1, 1, 1, 3};
  throughPadded(end - k, in, out, width,
                [&](const std::array<const float*, 12>& ins, const std::array<float*, 9>& outs) {
                  InsectWrite t = w;
                  for (std::size_t c = 0; c < 3; ++c) {
                    t.t[c] = ins[c];
                    t.start[c] = ins[3 + c];
                    t.nv[c] = ins[6 + c];
                    t.target[c] = ins[9 + c];
                    t.p[c] = outs[c];
                    t.v[c] = outs[3 + c];
                  }
                  t.speed = outs[6];
                  t.err = outs[7];
                  t.move = w.move ? outs[8] : nullptr;
                  writeLanes<L>(t, 0);
                });
}

// placeTargets one sample at a time
inline void placeOne(const TargetPlacement& t, std::uint32_t i, float out[3]) {
  const float* a = t.keyA + 3 * std::size_t{i};
  const float* b = t.keyB + 3 * std::size_t{i};
  float q[3];
  for (int c = 0; c < 3; ++c) q[c] = a[c] + t.f * (b[c] - a[c]);
  if (!t.placed) {
    for (int c = 0; c < 3; ++c) out[c] = q[c];
    return;
  }
  for (int c = 0; c < 3; ++c) q[c] -= t.pivot[c];
  for (int r = 0; r < 3; ++r) {
    out[r] = t.shift[r] + (t.rot[3 * r] * q[0] + (t.rot[3 * r + 1] * q[1] + t.rot[3 * r + 2] * q[2]));
  }
}

#if SWARMSIM_X86_LANES
// placeTargets on eight AVX2 lanes (gathers of the samples' coordinates), the rest one at a time
SWARMSIM_AVX2 void placeAvx2(const TargetPlacement& t, const std::uint32_t* sample, std::size_t first,
                             std::size_t count, float* tx, float* ty, float* tz) {
  std::size_t k = first;
  const std::size_t end = first + count;
  const __m256 f = _mm256_set1_ps(t.f);
  float* out[3] = {tx, ty, tz};
  for (; k + kLanes <= end; k += kLanes) {
    const __m256i i = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(sample + k));
    const __m256i at = _mm256_add_epi32(i, _mm256_add_epi32(i, i));  // 3 i
    __m256 q[3];
    for (int c = 0; c < 3; ++c) {
      const __m256 a = _mm256_i32gather_ps(t.keyA + c, at, 4), b = _mm256_i32gather_ps(t.keyB + c, at, 4);
      q[c] = _mm256_add_ps(a, _mm256_mul_ps(f, _mm256_sub_ps(b, a)));
    }
    if (t.placed) {
      for (int c = 0; c < 3; ++c) q[c] = _mm256_sub_ps(q[c], _mm256_set1_ps(t.pivot[c]));
      __m256 r[3];
      for (int row = 0; row < 3; ++row) {
        const __m256 p0 = _mm256_mul_ps(_mm256_set1_ps(t.rot[3 * row]), q[0]);
        const __m256 p1 = _mm256_mul_ps(_mm256_set1_ps(t.rot[3 * row + 1]), q[1]);
        const __m256 p2 = _mm256_mul_ps(_mm256_set1_ps(t.rot[3 * row + 2]), q[2]);
        r[row] = _mm256_add_ps(_mm256_set1_ps(t.shift[row]), _mm256_add_ps(p0, _mm256_add_ps(p1, p2)));
      }
      for (int c = 0; c < 3; ++c) q[c] = r[c];
    }
    for (int c = 0; c < 3; ++c) _mm256_storeu_ps(out[c] + k, q[c]);
  }
  for (; k < end; ++k) {
    float o[3];
    placeOne(t, sample[k], o);
    tx[k] = o[0];
    ty[k] = o[1];
    tz[k] = o[2];
  }
}

#define SWARMSIM_UPDATE_ARGS \
  const InsectUpdate &u, std::size_t first, std::size_t count, const float *const fInt[3], const float *const fCon[3]
__attribute__((flatten)) void updateSse(SWARMSIM_UPDATE_ARGS) { updateBlock<SseLanes>(u, first, count, fInt, fCon); }
SWARMSIM_AVX __attribute__((flatten)) void updateAvx(SWARMSIM_UPDATE_ARGS) {
  updateBlock<AvxLanes>(u, first, count, fInt, fCon);
}
__attribute__((flatten)) void writeSse(const InsectWrite& w, std::size_t first, std::size_t count) {
  writeBlock<SseLanes>(w, first, count);
}
SWARMSIM_AVX __attribute__((flatten)) void writeAvx(const InsectWrite& w, std::size_t first, std::size_t count) {
  writeBlock<AvxLanes>(w, first, count);
}
#undef SWARMSIM_UPDATE_ARGS
#endif

}  // namespace

void updateInsects(const InsectUpdate& u, std::size_t first, std::size_t count, const float* const fInt[3],
                   const float* const fCon[3], LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kSse) {
    updateSse(u, first, count, fInt, fCon);
  } else {
    updateAvx(u, first, count, fInt, fCon);
  }
#else
  (void)lanes;
  updateBlock<ScalarLanes>(u, first, count, fInt, fCon);
#endif
}

void placeTargets(const TargetPlacement& t, const std::uint32_t* sample, std::size_t first, std::size_t count,
                  float* tx, float* ty, float* tz, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  const bool gathers = 3 * t.samples < (std::size_t{1} << 31);  // (the gathers' offsets 3 i in 32 bits)
  if (gathers && (lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512)) {
    placeAvx2(t, sample, first, count, tx, ty, tz);
    return;
  }
#else
  (void)lanes;
#endif
  for (std::size_t k = first; k < first + count; ++k) {
    float o[3];
    placeOne(t, sample[k], o);
    tx[k] = o[0];
    ty[k] = o[1];
    tz[k] = o[2];
  }
}

void writeInsects(const InsectWrite& w, std::size_t first, std::size_t count, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kSse) {
    writeSse(w, first, count);
  } else {
    writeAvx(w, first, count);
  }
#else
  (void)lanes;
  writeBlock<ScalarLanes>(w, first, count);
#endif
}

}  // namespace swarmsim
