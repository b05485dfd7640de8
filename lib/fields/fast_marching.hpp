#pragma once
// Minimum cost field and global velocity of wang2014, section 5.2 (after Treuille et al.
// 2006, "Continuum crowds", and Sethian 1996, the fast marching method).
//
//   |∇C(x)| = f(x),  C = 0 on the goal cells                                       (eq. 7)
//   V_g = −∇C / |∇C| · s0                                                            (eq. 8)
//
// C is solved on a cell-centred grid with spacing (hx, hy, hz) by upwind differences: for
// a cell with smallest accepted neighbour value m_a along each axis a (on the side of the
// smaller one),
//   first order:  Σ_a (max(C − m_a, 0) / h_a)^2 = f^2;
//   second order (order 2, along axes whose second cell on that side, m'_a, is accepted and
//   m'_a <= m_a): the one-sided difference (3C − 4m_a + m'_a) / (2 h_a), that is the term
//   (9/4) (max(C − (4m_a − m'_a)/3, 0) / h_a)^2;
// solved with the axes taken in increasing value, adding an axis only while the current
// solution exceeds its value.
//
// Two solvers; on every input we compared (tests/fields_test.cpp, the field scenarios) they give
// the same values bit for bit:
// - the heap: cells accepted in increasing C through a binary min-heap with decrease-key, as
//   in Dijkstra's algorithm; serial. Order 2 always uses it.
// - the waves (order 1): label correcting in parallel. Each wave solves, from the values
//   before it, every passable cell next to a cell lowered by the last wave (a "trigger") that
//   is lower than itself, and lowers the cells whose solve came out lower; until a wave lowers
//   none. Both end at each cell's solve from its final upwind neighbours (a solve changes only
//   through a neighbour below the cell, so no other cell needs solving). The waves follow the
//   number of steps from the sources, which orders the cells by value from a point goal: there
//   each cell is lowered once. After a wave most of whose lowered cells had a value before
//   (uneven costs, obstacles), the heap solves the field afresh. The cells are kept in
//   4 × 4 × 4 bricks so that a wave's cells share cache lines.
// The waves run only from at most 64 source cells (goal or start cells: a point goal), else the
// heap: from extended sources the waves lower cells again and again (docs/performance.md). Which
// solver runs depends on the input; the tests check that the values do not (at 1, 2 and 3
// threads).
#include <cstdint>
#include <vector>

#include "core/vec.hpp"
#include "fields/grid3.hpp"

namespace swarmsim {

struct FastMarchingInput {
  GridSpec spec;
  std::vector<float> cost;         // f per cell (spec.size(), ≥ 0); +inf = impassable (obstacle)
  std::vector<std::uint8_t> goal;  // per cell (spec.size()): 1 = goal cell, C = 0
  // optional (empty, or spec.size()): cells with a finite value start with that C, like goal cells (for
  // example exact distances next to a smooth goal surface); NaN or +inf: none
  std::vector<float> start;
  // 1: first-order upwind differences; 2: second order where the two cells upwind along an axis are
  // accepted and decrease toward the front (Sethian 1999), first order elsewhere
  int order = 1;
  // order 1 by the heap (serial) instead of the waves: the same values (a reference for tests and timings)
  bool heap = false;
};

// how fastMarching went (for tests and timings)
struct FastMarchingReport {
  bool waved = false;       // by waves (else by the heap alone)
  int waves = 0;            // how many
  bool handedOver = false;  // the waves handed over to the heap
};

// C per cell; cells that cannot be reached from a goal (sealed off, or impassable) are +inf.
// A goal cell gets C = 0 even if its cost is +inf (a goal may be an obstacle, e.g. a target
// building, which is then approached but not entered). Throws std::invalid_argument on
// mismatched sizes, a negative or NaN cost, or a non-positive cell size.
Grid3<float> fastMarching(const FastMarchingInput& input, FastMarchingReport* report = nullptr);

// eq. 8 per cell: −∇C/|∇C| · speed. Along each axis the derivative is the one-sided
// difference toward the smaller finite neighbour, if it is smaller than the cell (upwind),
// and 0 otherwise, so the direction always points downhill and never uses an impassable
// (+inf) neighbour. Zero where C is +inf, where C = 0 (the goal), and where no neighbour is
// lower. Parallel.
Grid3<Vec3> descentDirection(const Grid3<float>& C, float speed);

}  // namespace swarmsim
