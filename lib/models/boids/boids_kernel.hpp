#pragma once
// The boids model's neighbour sums, sixteen candidates at a time (core/lanes.hpp:
// AVX-512, AVX or SSE chosen at run time, the same bits with each). The model
// walks the grid's cells; each cell's neighbourhood rows, read in place from
// the state (which the model keeps in cell order), are copied once per cell
// into six contiguous arrays (positions and unit velocities), padded to whole
// sixteens with far points. Each agent of the cell tests them sixteen at a
// time for neighbours within R3 and adds every neighbour's terms to nine sums
// of sixteen lanes, candidate e in lane e % 16 (eight-lane sets keep lanes 0-7
// and 8-15 as two sums). At the end lanes l and l + 8 are added and the eight
// lanes summed in a fixed tree. The result depends on the positions and velocities only, never on
// threads or the instruction set.
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"

namespace swarmsim {

// the agents in the grid's sorted order: positions (n of them, read in place) and unit velocities (n); no load
// reads past n
struct BoidsLanesInput {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  std::size_t n = 0;
  std::vector<float> ux, uy, uz;
  // positions x, y, z (n each), and room for n unit velocities
  void prepare(const float* px, const float* py, const float* pz, std::size_t count);
};

// the zones: squared radii R1², R2², R3² and the cosine of half the attraction field of view
struct BoidsZones {
  float r1sq, r2sq, r3sq, cosHalfFov;
};

// per-thread scratch: a row's runs, a cell's candidates (six arrays of `stride` floats: x, y, z, ux, uy, uz; it
// only grows), and the model's sums and random draws of one row of cells
struct BoidsScratch {
  std::vector<std::uint32_t> runs;         // a row's cells' runs (UniformGrid::forEachCellOfRow)
  std::vector<float> candidates;           // the cell's candidates, copied from its runs
  std::vector<float> sums;                 // the model's: boidsCellSums' output for one row of cells (9 arrays)
  std::vector<float> jitter;               // the model's: four uniforms per agent of the row
};

// for each agent k of a grid cell (sorted positions a0..a1-1) whose neighbourhood rows are the runs
// [runs[2 i], runs[2 i + 1]) (i < nRuns: UniformGrid::forEachCellOfRow), sums over the agents j != k within R3
// (d = p_j − p_k, d̂ = d / |d|, coincident agents skipped), into out[0..8][k − a0]: Σ d̂ over |d| <= R1
// (repulsion: the caller negates it), Σ û_j over R1 < |d| <= R2, Σ d̂ over R2 < |d| <= R3 with û_k · d̂ >=
// cos(fov / 2), axis by axis. `lanes`: which instruction set (laneSet(); every one gives the same bits; kAvx2 runs the
// AVX kernel: it needs no AVX2 instruction).
void boidsCellSums(const BoidsLanesInput& in, std::uint32_t a0, std::uint32_t a1, const std::uint32_t* runs,
                   std::size_t nRuns, const BoidsZones& zones, LaneSet lanes, BoidsScratch& scratch,
                   float* const out[9]);

}  // namespace swarmsim
