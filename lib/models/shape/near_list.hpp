#pragma once
// Per-insect neighbour lists kept across steps (Verlet lists) for the shape
// model's near-field sums (F_con, F_int over the K nearest, MDE).
//
// Insect i's list holds every other insect that was within its radius R_i
// when the list was built, in ascending order of their ids, each as its
// sorted position in this step's grid: a kept list is translated every step
// from last step's positions (the state's order) to this step's, which lie
// near the insect's own, where an id would need a look-up anywhere in an
// array indexed by id. A step asks for every insect within some radius ρ_i
// now. Moves are measured against a translation common to the insects near
// insect i, a different one each step (advance()): an offset x_j - x_i changes
// in a step by d_j - d_i = (d_j - c) - (d_i - c), at most |d_i - c| +
// |d_j - c| for any c. Two bounds of that are kept for each insect:
//   - global: c is the middle of every insect's move, and |d_j - c| is
//     bounded by the largest of all (so a swarm that travels together keeps
//     its lists);
//   - local: the insects are binned by where they start the step into cubic
//     blocks of edge b, c is the middle of the moves in the 3 x 3 x 3 blocks
//     about insect i's, and |d_j - c| is bounded by the largest of those
//     (half their bounding box's diagonal). Every insect j that ends the step
//     within r of insect i started it within r + 2 max_j |d_j| of it, so in
//     one of those blocks when r + 2 max_j |d_j| <= b: the local bound holds
//     for a list of radius R_i <= b - 2 max_j |d_j| (it follows the swarm's
//     turns and deformations, where the global one takes the whole swarm's).
// Each step adds the smaller of the two that holds to the list's moves since
// its build, M_i: any insect within ρ_i now was within ρ_i + M_i when the
// list was built (backwards, step by step, it stays within R_i), so the list
// still covers ρ_i while ρ_i + M_i <= R_i. Otherwise the list is built again
// from the grid, at R_i = ρ_i (1 + skin); one too long for its slot
// (capacity) is not kept, and the grid's candidates serve that step only.
//
// The lists are a cache: the callers use only the candidates within the radius
// they need, in id order, so what they compute depends on the positions alone,
// never on when a list was built (a resumed run, which starts without lists,
// equals an uninterrupted one; any thread count gives the same bits).
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/lanes.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

// sorted positions `pos` put in ascending order of their ids (idOf: sorted position -> id, distinct ids);
// keys: scratch of the long lists' sort; `lanes`: with AVX2, short lists are ordered by rank counts (the
// same order)
void sortById(std::vector<std::uint32_t>& pos, const std::uint32_t* idOf, std::vector<std::uint64_t>& keys,
              LaneSet lanes);
// the same of pos[0, m)
void sortById(std::uint32_t* pos, std::size_t m, const std::uint32_t* idOf, std::vector<std::uint64_t>& keys,
              LaneSet lanes);

class NearLists {
 public:
  static constexpr std::uint32_t kNone = 0xffffffffu;

  // n insects, room for `capacity` neighbours each; lists are built at ρ (1 + skin). Changing n or
  // capacity drops every list.
  void reset(std::size_t n, std::size_t capacity, float skin);
  // drop every list (the next step builds them again)
  void clear();
  // A step in which every insect's sorted position is its state index (the grid kept its cells, so the state
  // is where last step wrote it): each list stays in its slot, a kept list as it is (no copy), a new one
  // written over it. Otherwise (the default for each step) this step's lists go to the other slots.
  void beginStep(bool inPlace) { inPlace_ = inPlace; }

  // Lists live in slots: the state's order, which each step rewrites in its grid order, so a step reads
  // the slots of last step (`from`, the insect's state index, or kNone when it has no list there) and
  // writes this step's (`k`, its sorted position in the grid), nearly in sequence.
  //
  // The radius about insect k within which the list in slot `from` still holds every insect now (less a
  // float slack), or a negative number when there is none.
  float coverage(std::uint32_t from) const {
    if (from == kNone || last_.len[from] == kNone) return -1.0f;
    const double r = static_cast<double>(last_.radius[from]);
    return static_cast<float>((r - last_.moved[from] - lastMoveBound(from, r) - 1e-6) / (1.0 + 1e-5));
  }
  // how much the offset of the insect of state index `from` to any insect within r of it at the end of last step
  // changed in that step at most (m): the smaller of the global and the local bound, where the local one holds
  double lastMoveBound(std::uint32_t from, double r) const {
    const double global = lastMove_ + static_cast<double>(lastOwn_[from]);
    return r <= localReach_ ? std::min(global, static_cast<double>(lastLocal_[from])) : global;
  }
  // keep the list of slot `from` for sorted insect k: its sorted positions now (newPos maps last step's
  // sorted position, the state index, to this step's), by ascending id, the insect itself left out
  const std::uint32_t* keep(std::uint32_t from, std::uint32_t k, const std::uint32_t* newPos, std::size_t& m);
  // a new list for sorted insect k: every other grid point within r (its coverage now), by ascending id;
  // kept when it fits (`scratch` holds it otherwise, in its first m entries: scratch keeps its size, so that
  // no build zero-fills it; `keys` is scratch for the sort). `idOf` maps a sorted
  // position to its id; `lanes`: the instruction set to scan with (laneSet(), core/lanes.hpp; every one
  // gives the same list)
  const std::uint32_t* build(std::uint32_t k, float r, const UniformGrid& grid, const std::uint32_t* idOf,
                             std::vector<std::uint32_t>& scratch, std::vector<std::uint64_t>& keys, std::size_t& m,
                             LaneSet lanes);
  // the largest move of last step (m, relative to its common translation)
  double lastMove() const { return lastMove_; }
  float skin() const { return skin_; }

  // after a step in which sorted insect k moved own[k] (m) relative to a translation common to every insect,
  // each no more than maxMove, and, where local is given, the offset of insect k to any insect within
  // localReach of it at the end of the step changed by at most (*local)[k] (upper bounds of the exact values,
  // float rounding included): this step's lists become last step's. own and *local (n each) are taken over:
  // they come back holding last step's values, to be written over.
  void advance(double maxMove, std::vector<float>& own, std::vector<float>* local, double localReach);

 private:
  struct Slots {
    std::vector<std::uint32_t> pos;   // n × capacity: sorted positions
    std::vector<std::uint32_t> len;   // per slot: list length, or kNone
    std::vector<float> radius;        // per slot: R_i
    std::vector<double> moved;        // per slot: M_i, the bounds of the steps since the build, but the last
    void assign(std::size_t n, std::size_t capacity);
  };
  std::size_t n_ = 0, capacity_ = 0;
  float skin_ = 0.3f;
  std::vector<float> lastOwn_;    // by state index: each insect's relative move last step (global bound)
  std::vector<float> lastLocal_;  // by state index: the local bound of last step
  double lastMove_ = 0.0;         // last step's largest relative move (global bound)
  double localReach_ = -1.0;      // the radius up to which last step's local bound holds
  bool inPlace_ = false;  // beginStep
  Slots last_, next_;
};

}  // namespace swarmsim
