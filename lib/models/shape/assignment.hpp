#pragma once
// Agent-to-target assignment for the shape model (Chen et al. 2019, section 5.3:
// "we compute the direct correspondences between the insects and the target
// positions"): a one-to-one assignment that keeps the total travel distance
// sum_i |a_i - t_perm[i]| (Euclidean, not squared) close to its minimum.
//
// The exact minimum (Hungarian, O(n^3)) is far too slow for a million agents,
// so this is a heuristic in two stages:
//  1. a starting assignment by recursive bisection: split both point sets at
//     their own median along the widest axis of their union, recursively, so
//     that each half of the agents goes to the half of the targets on the same
//     side (equal counts by construction), down to single pairs. From 2,000
//     points on this is done at several levels: each set is cut into groups of
//     8 by a bisection of its own, the group centroids are assigned to each
//     other (recursively, by this same procedure), and matched groups are
//     bisected against each other.
//  2. local improvement: passes of 2-opt swaps, exchanging the targets of two
//     agents i, j when |a_i - t_j| + |a_j - t_i| < |a_i - t_i| + |a_j - t_j|,
//     over all pairs of agents in neighbouring cells of a uniform grid, then,
//     with the roles exchanged, over all pairs of targets in neighbouring
//     cells; until a pass shortens the total by less than 0.2%.
// Quality and timings are measured in tests/shape_sampling_test.cpp (against
// an exact Hungarian solver on 500 points, and against a lower bound on up to a
// million).
//
// Deterministic: the passes visit the grid in tiles of 4^3 cells coloured
// 2 x 2 x 2; tiles of one colour touch disjoint points and run in parallel,
// each in a fixed order. The result is bit-identical for any number of threads.
#include <cstdint>
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

// One target per agent: returns perm with agent i -> target perm[i] (a
// permutation of 0..n-1), close to the minimum of sum_i |agent_i -
// target_perm[i]|, deterministic and bit-identical for any thread count.
// Throws std::invalid_argument when the sizes differ, when there are 2^32 or
// more points, or when a coordinate is not finite.
std::vector<std::uint32_t> assignTargets(const std::vector<Vec3>& agents, const std::vector<Vec3>& targets);

}  // namespace swarmsim
