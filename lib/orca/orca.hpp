#pragma once
// 3-D ORCA (optimal reciprocal collision avoidance; van den Berg, Guy, Lin and
// Manocha 2011, "Reciprocal n-body collision avoidance"), written for this
// project, with sphere and signed-distance obstacles. See docs/orca.md.
//
// Per agent: its maxNeighbors nearest neighbours within neighborDistance
// (k-nearest search on a uniform grid), one velocity half-space per neighbour
// (each agent takes half of the avoidance) and per nearby obstacle (the agent
// takes all of it), then the velocity closest to the preferred one inside all
// half-spaces and the max-speed ball (an incremental 3-D linear program). When
// the half-spaces have no common point inside the ball, the velocity of
// smallest worst violation is used, obstacle half-spaces first.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/state_buffer.hpp"
#include "core/vec.hpp"
#include "fields/grid3.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim::orca {

struct Params {
  float radius = 0.5f;               // agent radius, m (all agents of a solve share it)
  float neighborDistance = 5.0f;     // only neighbours closer than this are considered, m
  int maxNeighbors = 10;             // the nearest maxNeighbors within neighborDistance
  float timeHorizon = 2.0f;          // s, for other agents
  float timeHorizonObstacle = 1.0f;  // s, for obstacles
  float maxSpeed = 2.0f;             // m/s
};

struct Sphere {
  Vec3 center;
  float radius;
  Vec3 velocity = Vec3::Zero();  // m/s: a moving sphere is avoided in relative velocity
};

struct Obstacles {  // static, read-only
  std::vector<Sphere> spheres;
  const Grid3<float>* sdf = nullptr;  // signed distance to mesh (and other) obstacles, negative inside; may be null
};

// One velocity half-space {v : n . v >= b}, |n| = 1 (m/s for b).
struct Plane {
  float nx, ny, nz, b;
};

// The linear program of one agent, exposed for tests. planes[0, hard) are
// obstacle half-spaces, the rest agent half-spaces. Writes the velocity closest
// to pref inside all planes and the ball |v| <= maxSpeed; when there is none,
// the fallback (docs/orca.md): the obstacle planes' smallest worst violation,
// then among those velocities the agent planes' smallest worst violation.
// `scratch` must hold count planes. Returns true if the fallback was needed.
bool solveVelocity(Plane* planes, std::size_t count, std::size_t hard, const Vec3& pref, float maxSpeed, Plane* scratch,
                   Vec3& out);

// solveVelocity of `agents` agents at once: agent a's planes at planes + a * stride (count[a] of them, the
// first hard[a] obstacle half-spaces), its preferred velocity pref[a]; writes out[a] and infeasible[a] (solveVelocity's
// result), and returns how many were infeasible. With the AVX2 or AVX-512 lane set the ball programs run eight
// agents at a time, with the same bits as solveVelocity one agent at a time. `scratch` holds the most planes of one
// agent; lanesScratch grows to what the lanes need.
std::size_t solveVelocities(Plane* planes, std::size_t stride, const std::size_t* count, const std::size_t* hard,
                            const Vec3* pref, std::size_t agents, float maxSpeed, Plane* scratch,
                            std::vector<float>& lanesScratch, Vec3* out, bool* infeasible, LaneSet lanes);

// The ORCA half-space of an agent moving at vi for a neighbour at relative position
// p = x_j - x_i moving at vj, as the solver builds it (docs/orca.md); for tests.
Plane agentHalfSpace(const Vec3& p, const Vec3& vi, const Vec3& vj, float radius, float timeHorizon, float dt);

class Solver {
 public:
  // Everything is indexed by the grid's sorted order k = 0..grid.size()-1: positions are
  // grid.sortedX()/sortedY()/sortedZ(); current velocities vx/vy/vz[k]; preferred velocities
  // prefX/Y/Z[k]. The grid was built over those positions by the caller (any minCell; the caller
  // uses minCell >= neighborDistance when it can). Writes the new (collision-avoiding)
  // velocities to outX/Y/Z[k] (may not alias the inputs). dt is the simulation time step, s.
  // Deterministic: bit-identical results for any number of threads. No heap allocation in
  // steady state (scratch kept in the Solver, per thread), except the small one inside
  // UniformGrid::build for the solver's own search grid.
  // Throws std::invalid_argument for parameters out of range (radius < 0, maxNeighbors < 0,
  // a time horizon, maxSpeed or dt <= 0, neighborDistance < 0, or any of them not finite).
  void solve(const UniformGrid& grid, const float* vx, const float* vy, const float* vz, const float* prefX,
             const float* prefY, const float* prefZ, const Params& params, const Obstacles& obstacles, float dt,
             float* outX, float* outY, float* outZ);

  // What carries over from one solve to the next (the search cell size, which a
  // caller's grid follows through suggestedCell and so decides its agent order),
  // for checkpoints: a solver restored from saveState continues bit-identically.
  void saveState(StateOut& out) const;
  void loadState(StateIn& in);

  // the cell edge the k-nearest search will want next (m): a caller that builds its
  // grid with this minCell lets the solver search that grid instead of building its own
  float suggestedCell(const Params& params) const;

  // agents whose LP was infeasible in the last solve (the fallback of minimal worst violation was used)
  std::size_t infeasibleCount() const { return infeasible_; }
  // seconds spent in the last solve: neighbour search, and constraints + LPs
  double neighbourSeconds() const { return neighbourSeconds_; }
  double lpSeconds() const { return lpSeconds_; }

  // For tests and statistics (after a solve): the neighbours of agent k found by the last solve, as sorted
  // indices, nearest first (ties by index); count is their number.
  const std::uint32_t* neighbors(std::size_t k, std::size_t& count) const {
    count = count_[k];
    return nbr_.data() + k * static_cast<std::size_t>(stride_);
  }
  // the cell edge the k-nearest search used in the last solve, m
  float searchCell() const { return cell_; }
  // agents whose k-nearest search had to widen beyond their cell's block in the last solve
  std::size_t widenedSearches() const { return widened_; }
  // whether the last solve searched the caller's grid (no grid of its own)
  bool reusedCallerGrid() const { return reused_; }

 private:
  // per-thread buffers (own cache lines), kept between solves
  struct alignas(64) ThreadScratch {
    CellBlock block;                  // candidates of one cell's neighbourhood
    std::vector<std::uint64_t> best;  // k nearest so far: (squared distance bits << 32) | index, ascending
    std::vector<std::uint64_t> keys;  // the block hits' keys (the AVX2 selection)
    std::vector<std::uint64_t> wideKeys;   // the keys of a search beyond the block (AVX-512)
    std::vector<std::uint32_t> runs;       // its runs of sorted positions
    std::vector<Plane> planes, projected;  // planes: kLpLanes agents' half-spaces
    std::vector<float> lanes;              // their programs on lanes
    std::vector<std::uint8_t> degenerate;  // lanes whose neighbour half-space agentPlane redoes
    std::vector<float> batch;  // the neighbours' relative positions and velocities, then their planes (SoA)
    std::vector<std::uint32_t> histogram;
    std::size_t infeasible = 0, widened = 0;
  };
  void findNeighbors(const UniformGrid& grid, const Params& params);

  UniformGrid search_;                // the solver's own grid, cells sized for the k-nearest search
  std::vector<std::uint32_t> nbr_;    // neighbours of agent k at [k * stride_, k * stride_ + count_[k])
  std::vector<std::uint32_t> count_;  // neighbours found per agent
  int stride_ = 0;                    // maxNeighbors of the last solve
  std::vector<ThreadScratch> threads_;
  std::vector<std::uint32_t> histogram_;  // required search radius / neighborDistance, for the next cell size
  float cell_ = 0.0f;                     // cell edge of the last k-nearest search, m
  float nextCell_ = 0.0f;                 // from the last solve's histogram; 0: estimate from the density
  std::size_t lastSize_ = 0;              // agents of the last solve
  std::size_t infeasible_ = 0, widened_ = 0;
  bool reused_ = false;
  std::vector<std::uint32_t> identity_;  // order of the caller's grid when it is searched directly
  double neighbourSeconds_ = 0.0, lpSeconds_ = 0.0;
};

}  // namespace swarmsim::orca
