#pragma once
// Trilinear samples of a grid of vectors at many points: the same bits as Grid3<Vec3>::Sampler point by point,
// with the points' base cells and fractions (Sampler::base: a subtraction, a division and the clamps) computed
// eight points at a time.
#include <cstddef>

#include "core/lanes.hpp"
#include "core/vec.hpp"
#include "fields/grid3.hpp"

namespace swarmsim {

// a sample in 16 bytes: x, y, z and 0
struct alignas(16) PaddedVec3 {
  float v[4];
};

// out[i] = s(Vec3(x[i], y[i], z[i])) for i < n, each padded with a 0.
// `lanes`: laneSet() (AVX or wider: eight points at a time)
void sampleBatch(const Grid3<Vec3>::Sampler& s, const float* x, const float* y, const float* z, std::size_t n,
                 PaddedVec3* out, LaneSet lanes);

}  // namespace swarmsim
