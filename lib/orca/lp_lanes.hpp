#pragma once
// The ORCA solver's 3-D linear program for eight agents at once, one agent per
// SIMD lane (AVX2), internal to lib/orca. Each lane computes exactly the
// operations of orca.cpp's ballProgram (and its planeProgram and lineProgram)
// for its own agent, so every lane's result has the scalar program's bits; a
// lane only waits for the others where they have more to do.
#include <cstddef>
#include <cstdint>

namespace swarmsim::orca {

// A plane counts as satisfied when violated by at most this much (m/s): keeps
// rounding (a point computed on plane j read back as 1e-7 outside it) from
// triggering sub-problems or a spurious infeasibility. Over a 1 s step it is 10 µm.
constexpr float kTolerance = 1e-5f;

constexpr std::size_t kLpLanes = 8;
// floats one plane takes in the lanes' layout: nx of the eight lanes, then ny, nz and b
constexpr std::size_t kLpPlaneFloats = 4 * kLpLanes;

// ballProgram (closest to pref, no direction objective) of eight agents. planes: `count` planes in the lanes'
// layout (plane i at planes + i * kLpPlaneFloats); a lane with fewer planes is padded with n = 0,
// b = -infinity, which no velocity violates. pref and v: x of the eight lanes, then y, then z. fail[l]: the
// first plane lane l cannot satisfy (v then the optimum of the planes before it), or count. AVX2 only
// (laneSet() >= kAvx2); needs SWARMSIM_X86_LANES.
void ballProgramLanes(const float* planes, std::size_t count, float R, const float* pref, float* v,
                      std::uint32_t* fail);

// The half-spaces of eight agents' neighbours, the t-th neighbour of each agent at once, one agent per lane:
// orca.cpp's agentPlanes, operation by operation. rel: for t in [0, T), six rows of eight floats (p = x_j - x_i
// in x, y, z, then rv = v_i - v_j in x, y, z); vi: the agents' velocities (x of the eight lanes, then y, z).
// Writes plane t to planes + t * kLpPlaneFloats (the lanes' layout) and, in degenerate[t], a bit for each lane
// whose normal is undefined there (agentPlane redoes those). AVX2 only.
void agentPlanesLanes(const float* rel, std::size_t T, const float* vi, float R, float invTau, float invDt,
                      float* planes, std::uint8_t* degenerate);

}  // namespace swarmsim::orca
