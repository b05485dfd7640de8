#pragma once
// FASTSWARM's objective (Xiang et al., eq. 2-13) for one agent and one candidate sample d_v = [v, a] of the
// reference, and the exact argmin over a range of candidates. docs/models/fastswarm.md has the equations as
// implemented and our readings.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/vec.hpp"

namespace swarmsim::fastswarm {

struct Weights {
  float rep = 1.0f, oa = 1.0f, cos = 0.05f, dir = 1.0f, acc = 1.0f, n = 0.2f;  // Table 1, aggregation
  float user = 0.0f;
  float env = 0.0f;
};

struct EnergyParams {
  Weights w;
  float rho = 2.5f;     // ρ
  float dRep = 0.1f;    // d_rep, m
  float dAtt1 = 0.3f;   // d_att,1, m
  float dt = 0.02f;     // Δt, s
  float dDanger = 1.0f; // d_danger, m
  // how far ahead the startled term predicts the agent's position: p' = p + v T (0: T = Δt, the paper's eq. 12)
  float dangerHorizon = 0.0f;  // T, s
  float dangerAhead() const { return dangerHorizon > 0.0f ? dangerHorizon : dt; }
};

// the reference's samples as the minimiser reads them (structure of arrays, float)
struct Candidates {
  std::vector<float> vx, vy, vz;  // v, m/s
  std::vector<float> ux, uy, uz;  // v̂ (zero for v = 0)
  std::vector<float> bx, by, bz;  // â (zero for a = 0)
  std::vector<float> amag;        // |a|, m/s^2
  std::size_t size() const { return vx.size(); }
  void add(const Vec3& v, const Vec3& a);
};

// what one agent's energies depend on besides the candidate
struct AgentInput {
  Vec3 p = Vec3::Zero();       // p_{i,t}
  Vec3 v = Vec3::Zero();       // v_{i,t}
  Vec3 vhat = Vec3::Zero();    // v̂_{i,t} (zero when v is)
  Vec3 center = Vec3::Zero();  // v̂_{i,center}: unit vector toward the swarm centre (zero when at it)
  Vec3 noise = Vec3::Zero();   // v̂^n_{i,t}: the curl noise's direction (zero where it vanishes)
  Vec3 control = Vec3::Zero(); // v̂^cd_{i,t}: the user's control direction (eq. 15; zero: none)
  // repulsion neighbours: predicted positions p'_j = p_j + v_j Δt; attraction neighbours: p_j
  const float* repX = nullptr;
  const float* repY = nullptr;
  const float* repZ = nullptr;
  std::size_t rep = 0;
  const float* attX = nullptr;
  const float* attY = nullptr;
  const float* attZ = nullptr;
  std::size_t att = 0;
  // stimuli (eq. 11-12): attractors as unit vectors toward them (v̂_{i,sti}); the predators that startle
  // the agent (within d_danger) as centres and radii (distance to a sphere's surface)
  const float* lureX = nullptr;
  const float* lureY = nullptr;
  const float* lureZ = nullptr;
  std::size_t lures = 0;
  const float* dangerX = nullptr;
  const float* dangerY = nullptr;
  const float* dangerZ = nullptr;
  const float* dangerR = nullptr;
  std::size_t dangers = 0;
};

// the terms of E for candidate c, each with its weight (E is their sum)
struct EnergyTerms {
  float rep = 0, oa = 0, cos = 0, dir = 0, adir = 0, amag = 0, n = 0, user = 0, lure = 0, danger = 0;
  float total() const { return rep + oa + cos + dir + adir + amag + n + user + lure + danger; }
};

inline Vec3 unitOrZero(const Vec3& x) {
  const float n = x.norm();
  return n > 0.0f ? Vec3(x / n) : Vec3::Zero();
}

// E(i, v, a) term by term (eq. 4, 6, 7, 9, 10, 11-12, 13, 14); E_env is split into its attracted
// (lure) and startled (danger) parts
EnergyTerms energyTerms(const AgentInput& in, const Candidates& c, std::size_t k, const EnergyParams& p);
// the same with the lane type chosen by the caller (avx: useAvx(), core/lanes.hpp); both give the same bits
EnergyTerms energyTermsWith(bool avx, const AgentInput& in, const Candidates& c, std::size_t k, const EnergyParams& p);

// the candidate of [first, last) with the least E (ties: the lowest index), and its E
std::size_t argminEnergy(const AgentInput& in, const Candidates& c, std::size_t first, std::size_t last,
                         const EnergyParams& p, float* best = nullptr);

// per candidate, e^{-ρ |v| Δt / d} for d = d_rep, d_att,1 and d_danger (a little less): moving by |v| Δt changes a
// neighbour's distance by at most that much, so E_rep and E_oa are at least these factors times their value
// for no move
struct BoundFactors {
  std::vector<float> rep, oa, danger;
  void build(const Candidates& c, const EnergyParams& p);
};

// the lanes of argminEnergyBounded: its exact terms on SSE or AVX lanes (the same bits either way), its lower
// bounds too, or those on AVX2 with FMA or on AVX-512 (different bits, the same candidate chosen). The widest
// this CPU has, narrowed by core/lanes.hpp's SWARMSIM_NO_AVX and SWARMSIM_NO_AVX2 and by SWARMSIM_NO_AVX512
enum class SearchLanes { kSse, kAvx, kAvx2Fma, kAvx512 };
SearchLanes searchLanes();
SearchLanes searchLanes(LaneSet set);  // for laneSet() == set (AVX2 or AVX-512 without FMA: AVX)

// argminEnergy's result (the same candidate: the lowest index of the least E), found by branch and bound:
// E's own terms exactly and the interaction bounded below for every candidate, then the exact E only where
// that bound is not above the best E found. `lower` is scratch.
std::size_t argminEnergyBounded(const AgentInput& in, const Candidates& c, const BoundFactors& f, std::size_t first,
                                std::size_t last, const EnergyParams& p, std::vector<float>& lower,
                                float* best = nullptr, SearchLanes lanes = searchLanes());

}  // namespace swarmsim::fastswarm
