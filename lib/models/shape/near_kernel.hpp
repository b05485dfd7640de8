#pragma once
// The shape model's per-insect sums over its near neighbours, eight lanes at a
// time (core/lanes.hpp: AVX or SSE chosen at run time, the same bits either
// way). Every sum runs over its entries in the order given (the shape model
// gives only the entries that count, in id order: near_list.hpp) with entry e
// in lane e % 8, and the lanes are added in a fixed order (0..7 for F_con, a
// fixed tree for F_int): so the result depends on the data only, never on
// threads or the instruction set.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/vec.hpp"

namespace swarmsim {

// `avx`: use the AVX lanes (useAvx(), asked once per step: it reads the environment)

// per-thread scratch of the kernels (grows rarely, never shrinks)
struct alignas(64) NearScratch {
  std::vector<float> dx, dy, dz, d2, ux, uy, uz;
  std::vector<std::uint64_t> keys;   // F_int's candidates (classifyCandidates' output; room as the candidates')
  std::vector<std::uint64_t> found;  // an insect's K nearest from the grid (spatial/nearest.hpp), when it has no list
  // one insect's candidates (the shape model's near lists): offsets, squared distances, sorted positions,
  // and the ids of a list built from the grid
  std::vector<float> cx, cy, cz, cd2;
  std::vector<std::uint32_t> cj, ids;
  std::vector<std::uint32_t> conIdx, mdeIdx;           // classifyCandidates' output (with keys)
  std::vector<std::uint32_t> chosen;                   // F_int's neighbours (sorted positions), for zonalForceRows
  std::vector<std::uint64_t> sortKeys;                 // sortById's (near_list.hpp)
  // the MDE candidates of the insects this thread took in this step's near pass, one insect's after another
  // (the shape model's: it clears them at each step's start; they keep their room)
  std::vector<std::uint32_t> mde;
  std::size_t rebuilds = 0;  // near lists this thread built from the grid (a statistic: one count per thread,
                             // so that no cache line is shared between the cores)
  void reserve(std::size_t n);
  // room for n candidates (padded to whole lanes) in every array
  void reserveCandidates(std::size_t n) {
    if (n + 16 <= room_) return;
    growCandidates(n);
  }

 private:
  std::size_t room_ = 0;
  void growCandidates(std::size_t n);
};

// One insect's candidates, eight at a time: on entry scratch.cx/cy/cz[0, m) hold their positions, on
// return their offsets from q and scratch.cd2 their squared distances; the indices e (ascending) of those
// with Manhattan length < threshold and d2 > 0 (F_con's) go to conIdx, with their offsets and squared
// distances packed in that order in scratch.dx/dy/dz/d2; those with d2 <= near2 (F_int's) go to scratch.keys
// as neighbourKey(d2, e) (spatial/nearest.hpp), ascending e; those with d2 <= reach2 to mdeIdx; counts[0..2]
// say how many of each. The lanes past m are padded here. `lanes`: which instruction set (laneSet(); every
// one gives the same result).
void classifyCandidates(std::size_t m, const Vec3& q, float threshold, float near2, float reach2, NearScratch& scratch,
                        LaneSet lanes, std::size_t counts[3]);

// Keeps the K smallest of the distinct keys[0, m) in their given order at the front; returns how many are kept
// (min(m, K)). With at most 8 too many (the usual case) one pass finds the (m − K)-th largest key, then one
// pass keeps the keys below it; with more, nth_element and a sort by the keys' low halves (their order given).
std::size_t keepSmallest(std::uint64_t* keys, std::size_t m, std::size_t K);

// The rows gatherClassify reads: kRowFloats floats per sorted position, x, y, z, 0, then the velocity
// vx, vy, vz, 0 (a neighbour's velocity comes in the cache line its position came in)
constexpr std::size_t kRowFloats = 8;

// floats whose first is at a cache line's start (rows of kRowFloats never straddle two lines); the storage
// is kept between steps and grows only
class AlignedFloats {
 public:
  float* resize(std::size_t n) {
    if (store_.size() < n + 16) store_.resize(n + 16);
    const auto at = reinterpret_cast<std::uintptr_t>(store_.data());
    data_ = store_.data() + ((64 - at % 64) % 64) / sizeof(float);
    return data_;
  }
  float* data() { return data_; }
  const float* data() const { return data_; }

 private:
  std::vector<float> store_;
  float* data_ = nullptr;
};

// rows[kRowFloats k + ·] = (x, y, z, 0, vx, vy, vz, 0)[k] for k in [first, first + count): eight rows at a time with
// whole-row stores on AVX (the stores of a row miss the cache together), one float at a time otherwise
void fillRows(const float* x, const float* y, const float* z, const float* vx, const float* vy, const float* vz,
              std::size_t first, std::size_t count, float* rows, LaneSet lanes);

// classifyCandidates of the candidates at sorted positions cand[0, m), which go to scratch.cj: candidate
// e's position is the first three floats of row cand[e] of `rows` (kRowFloats per sorted position), and row
// `far` holds a point far from everything (the padding of the last lanes)
void gatherClassify(std::size_t m, const std::uint32_t* cand, const float* rows, std::uint32_t far, const Vec3& q,
                    float threshold, float near2, float reach2, NearScratch& s, LaneSet lanes, std::size_t counts[3]);

// F_con's sum (eq. 5) over scratch.dx/dy/dz/d2[0, m): Σ d̂ exp(−M² inv2s2) over the entries with 0 < |d| and
// Manhattan length M < threshold, d = p_j − q (the caller negates and scales it), and how many there were.
// The other entries count for nothing, but the lane of entry e is e % 8, so a caller that wants a sum
// independent of which other entries are present passes only those that count.
void constraintSumScratch(std::size_t m, float threshold, float inv2s2, NearScratch& scratch, bool avx, Vec3& sum,
                          int& count);

// the zones of F_int (eq. 2-3): squared radii and weights
struct ZoneLanes {
  float rep2, ali2, att2;
  float w[3];
};

// F_int (eq. 2-3) from m neighbours given in scratch.dx/dy/dz/d2 (d = p_j − q) and scratch.ux/uy/uz
// (v_j − v_q): Σ_k ω_k / N_k Σ_{j in zone k} (S_k d̂ + (1 − S_k²) û), zones rep [0, r_rep) S = −1,
// ali [r_rep, r_ali) S = 0, att [r_ali, r_att] S = +1, nothing beyond r_att; a zero d or u adds a zero
// vector but counts
Vec3 zonalForce(std::size_t m, const ZoneLanes& zones, NearScratch& scratch, bool avx);

// zonalForce of the m neighbours at sorted positions js[0, m), taken from their rows (gatherClassify's, with
// the velocity in floats 4-6) less the insect's position q and velocity v: the same result as zonalForce of
// the same entries, without gathering them first. js is padded here with the far row to whole lanes (room
// for it needed). Only where zonalFromRows(lanes) (AVX2).
bool zonalFromRows(LaneSet lanes);
Vec3 zonalForceRows(std::size_t m, std::uint32_t* js, const float* rows, std::uint32_t far, const Vec3& q,
                    const Vec3& v, const ZoneLanes& zones);

// What nearSums gives of one insect's candidates
struct NearSums {
  Vec3 fInt = Vec3::Zero();           // F_int (zonalForceRows) over the K chosen
  float far2 = 0.0f;                  // the largest squared distance among them
  std::size_t counts[3] = {0, 0, 0};  // as gatherClassify's: F_con's entries, F_int's (within near2), MDE's
  // F_con's sum and count as constraintSumScratch gives them, where conSummed (else its entries are packed)
  bool conSummed = false;
  Vec3 conSum = Vec3::Zero();
  int conCount = 0;
};
// whether nearSums runs on this lane set (AVX-512, with BMI2)
bool nearSumsLanes(LaneSet lanes);
// gatherClassify of the m candidates cand[0, m), then keepSmallest of F_int's K and zonalForceRows of them, in one
// pass on sixteen AVX-512 lanes, with the same results: F_con's sum (constraintSumScratch with inv2s2) where
// it has at most sixteen entries, else its entries packed in scratch.dx/dy/dz/d2 (out.conSummed says which), MDE's
// indices in scratch.mdeIdx, the counts, and F_int's K nearest within near2 (ties to the lower index) as sorted
// positions in their given order in scratch.chosen, with their F_int (v: the insect's velocity) and farthest
// squared distance. Returns false where it does not apply, having left nothing the caller may use: none or more
// than 48 candidates, K = 0 or more than 16, fewer than K or more than 32 within near2, more than 32 in F_con's or
// MDE's class, or a tie of distances at the K-th place (the general path takes those). Only where nearSumsLanes(lanes).
bool nearSums(std::size_t m, const std::uint32_t* cand, const float* rows, std::uint32_t far, const Vec3& q,
              const Vec3& v, float threshold, float inv2s2, float near2, float reach2, std::size_t K,
              const ZoneLanes& zones, NearScratch& scratch, NearSums& out);

// the largest squared distance from q of the rows at sorted positions pos[prev[0, m)], of `count` rows (rows
// as gatherClassify reads them; the squared distance as it computes it, so the same bits on every lane set:
// the AVX2 lane set gathers eight at a time, below 2^28 rows; the others, AVX-512 too, take one row at a time,
// which was faster than the gathers on an AMD Zen 4, shape.md)
float farthestRow2(std::size_t m, const std::uint32_t* prev, const std::uint32_t* pos, const float* rows,
                   std::size_t count, const Vec3& q, LaneSet lanes);

}  // namespace swarmsim
