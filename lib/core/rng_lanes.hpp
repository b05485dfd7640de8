#pragma once
// AgentRng's first four uniforms (core/rng.hpp: one Philox4x32-10 block) of many agents at once, on SIMD lanes
// where the CPU has them (AVX-512: sixteen agents, AVX2: eight; integer arithmetic, so the same bits as AgentRng
// on every lane set).
#include <cstddef>
#include <cstdint>

#include "core/lanes.hpp"
#include "core/rng.hpp"

namespace swarmsim {

// out[w][i] (w < 4, i < m) = the w-th uniform() of AgentRng(seed, step, ids[i], purpose, stream)
void firstUniforms(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids, std::size_t m, RngPurpose purpose,
                   std::uint32_t stream, float* const out[4], LaneSet lanes);

}  // namespace swarmsim
