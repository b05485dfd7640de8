#pragma once
// The boids model's neighbour sums, eight candidates at a time (core/lanes.hpp:
// AVX2, AVX or SSE chosen at run time, the same bits with each). The model
// walks the grid's cells; each cell's neighbourhood rows, read in place from
// the state (which the model keeps in cell order), are cut into chunks of up to eight. Each agent of
// the cell tests every chunk for neighbours within R3 (squared distances only),
// packs their positions in scan order, and sums them eight at a time: hit e in
// lane e % 8, the lanes added in a fixed tree at the end. The result depends on
// the positions and velocities only, never on threads or the instruction set.
#include <array>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/vec.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

// the agents in the grid's sorted order: positions (n of them, read in place: chunks near the end are loaded
// shifted back so no load reads past n; fewer than eight agents are copied into padded arrays here) and unit
// velocities (padded here with kPad zeros: the hits' gathers only read entries below n)
struct BoidsLanesInput {
  static constexpr std::size_t kPad = UniformGrid::kSortedPad;
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  std::size_t n = 0;
  std::vector<float> ux, uy, uz;
  // positions x, y, z (n each), and room for n unit velocities plus the padding (zeros)
  void prepare(const float* px, const float* py, const float* pz, std::size_t count);

 private:
  std::vector<float> tx_, ty_, tz_;  // padded copies of fewer than eight positions
};

// the zones: squared radii R1², R2², R3² and the cosine of half the attraction field of view
struct BoidsZones {
  float r1sq, r2sq, r3sq, cosHalfFov;
};

// per-thread scratch: the hits of one agent, packed (a full buffer is summed and emptied), a row's runs, a
// cell's chunks, and the model's sums of one cell
struct BoidsScratch {
  static constexpr std::size_t kRoom = 256;
  std::vector<std::uint32_t> hits;         // sorted positions of one agent's hits, packed
  std::vector<std::uint32_t> runs;         // a row's cells' runs (UniformGrid::forEachCellOfRow)
  std::vector<std::uint32_t> chunkStart;   // a cell's rows in chunks of up to eight: first sorted position loaded
  std::vector<std::uint32_t> chunkLive;    // and the lanes in the run: a lane mask's offset (boids_kernel.cpp)
  std::vector<std::array<float, 9>> sums;  // the model's: boidsCellSums' output for one cell
  BoidsScratch();
};

// for each agent k of a grid cell (sorted positions a0..a1-1) whose neighbourhood rows are the runs
// [runs[2 i], runs[2 i + 1]) (i < nRuns: UniformGrid::forEachCellOfRow), sums over the agents j != k within R3
// (d = p_j − p_k, d̂ = d / |d|, coincident agents skipped), into out[k − a0][0..8]: Σ d̂ over |d| <= R1
// (repulsion: the caller negates it), Σ û_j over R1 < |d| <= R2, Σ d̂ over R2 < |d| <= R3 with û_k · d̂ >=
// cos(fov / 2), axis by axis. `lanes`: which instruction set (laneSet(); every one gives the same bits; kAvx512 runs the AVX2 kernel).
void boidsCellSums(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, const std::uint32_t* runs,
                   std::size_t nRuns, const BoidsZones& zones, LaneSet lanes, BoidsScratch& scratch,
                   std::array<float, 9>* out);

}  // namespace swarmsim
