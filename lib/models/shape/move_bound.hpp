#pragma once
// The local bound of the near lists (near_list.hpp) for one step: how much
// the offset of insect i to any insect near it changed in the step, measured
// against the moves of the insects about it only.
//
// The insects are binned into cubic blocks of edge b by where they started
// the step. For the 3 x 3 x 3 blocks about insect i's, let B be the bounding
// box of their insects' moves and c its middle. Any insect j that ends the
// step within r of insect i started it within r + 2 max_k |d_k| of it, so,
// when that is at most b, in one of those blocks: its move d_j lies in B, and
// the offset x_j - x_i changed by |d_j - d_i| <= |d_j - c| + |d_i - c| <=
// half B's diagonal + |d_i - c|, which is local[i]. The bound holds for every
// r <= reach() = b - 2 max_k |d_k| (less a float slack).
//
// A swarm that turns or deforms moves unevenly as a whole, but its insects'
// moves vary little across a few blocks: this bound is then far tighter than
// one over the whole swarm. It is a cache's bound only (when a near list is
// built again), so no result depends on it.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace swarmsim {

class LocalMoveBound {
 public:
  // n insects that started the step at (x[k], y[k], z[k]), all within the box [lo, hi], and moved by
  // (move[3k], move[3k + 1], move[3k + 2]), none by more than maxMove (an upper bound); move holds 3 n + 1
  // floats (the last is read, not used). Blocks of edge `edge` (> 2 maxMove to be of use). Writes local[k]
  // for every k and returns true, or returns false (no bound this step) when the box spans more than
  // maxBlocks blocks or is not finite. With `other` (another bound, other[k] + otherAdd), gain() compares
  // the two.
  bool compute(std::size_t n, const float* x, const float* y, const float* z, const float lo[3], const float hi[3],
               const float* move, double edge, double maxMove, std::size_t maxBlocks, float* local,
               const float* other = nullptr, float otherAdd = 0.0f);
  // of the last compute with `other`: the sum over the insects of the other bound, divided by the sum of the
  // smaller of the two (1 when the local bound is nowhere smaller; how much longer the lists last with it)
  double gain() const { return spentLocal_ > 0 ? static_cast<double>(spent_) / static_cast<double>(spentLocal_) : 1.0; }
  // the radius up to which the last compute's local bounds hold (negative when none)
  double reach() const { return reach_; }
  // the last compute's blocks (a statistic)
  std::size_t blocks() const { return blocks_; }

 private:
  struct alignas(16) Box {  // a bounding box of moves (four lanes, for vector min and max; the fourth unused)
    float lo[4], hi[4];
  };
  static const Box kEmpty;
  double reach_ = -1.0;
  std::size_t blocks_ = 0;
  std::uint64_t spent_ = 0, spentLocal_ = 0;  // (gain(): in micrometres)
  std::vector<std::uint64_t> sums_;           // per chunk, the two
  std::vector<std::uint32_t> blockOf_;  // by insect
  std::vector<Box> perChunk_;           // chunk c's boxes at [c * blocks, (c + 1) * blocks)
  std::vector<Box> box_, tmp_;          // merged, then over the 3 x 3 x 3 blocks about each
};

}  // namespace swarmsim
