#include "fields/fast_marching.hpp"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/parallel.hpp"

namespace swarmsim {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::int32_t kFar = -1;    // not reached yet
constexpr std::int32_t kKnown = -2;  // accepted, impassable or padding: never updated
// the waves (marchWaves) run from at most kFewSources source cells, and hand over to the heap after a wave of
// at least kHandOverWave lowered cells more than kRelowered of which had a value before (once kHandOverAfter
// cells have been lowered)
constexpr std::size_t kFewSources = 64;
constexpr double kRelowered = 0.6;
constexpr std::size_t kHandOverAfter = 4096;
constexpr std::size_t kHandOverWave = 1024;

// solver state of one cell of the padded grid (interleaved: a cell's neighbours' values and
// its heap slot share cache lines)
struct CellState {
  float val;          // accepted C, +inf until accepted
  float cost;         // f
  std::int32_t slot;  // heap position while in the heap, else kFar / kKnown
};

// Binary min-heap of cells keyed by tentative C, with decrease-key through CellState::slot.
// An item packs the key's IEEE bits (keys are ≥ +0, whose bit patterns order like their
// values) above the cell index, so one integer comparison orders by C and then by cell:
// the acceptance order is fully determined by the input.
class CellHeap {
 public:
  explicit CellHeap(std::vector<CellState>& cells) : cells_(cells) {}
  void reserve(std::size_t n) { items_.reserve(n); }
  bool empty() const { return items_.empty(); }

  static std::uint64_t pack(std::uint32_t cell, float key) {
    std::uint32_t bits;
    std::memcpy(&bits, &key, sizeof bits);
    return static_cast<std::uint64_t>(bits) << 32 | cell;
  }
  static std::uint32_t cellOf(std::uint64_t item) { return static_cast<std::uint32_t>(item); }
  static float keyOf(std::uint64_t item) {
    const auto bits = static_cast<std::uint32_t>(item >> 32);
    float key;
    std::memcpy(&key, &bits, sizeof key);
    return key;
  }
  float keyAt(std::int32_t pos) const { return keyOf(items_[static_cast<std::size_t>(pos)]); }

  void push(std::uint32_t cell, float key) {
    items_.push_back(0);
    siftUp(items_.size() - 1, pack(cell, key));
  }
  // lowers the key of the item at pos (the caller checked key < its current key)
  void decrease(std::int32_t pos, std::uint32_t cell, float key) {
    siftUp(static_cast<std::size_t>(pos), pack(cell, key));
  }
  // removes and returns the smallest item; the caller sets its slot. Bottom-up: the hole
  // at the root follows the smaller child down to a leaf (one comparison per level), then
  // the last item is sifted up from there.
  std::uint64_t pop() {
    const std::uint64_t top = items_.front();
    const std::uint64_t last = items_.back();
    items_.pop_back();
    const std::size_t n = items_.size();
    if (n == 0) return top;
    std::size_t pos = 0;
    for (std::size_t child = 1; child < n; child = 2 * pos + 1) {
      if (child + 1 < n) child += items_[child + 1] < items_[child] ? 1 : 0;
      place(pos, items_[child]);
      pos = child;
    }
    siftUp(pos, last);
    return top;
  }

 private:
  void place(std::size_t pos, std::uint64_t item) {
    items_[pos] = item;
    cells_[cellOf(item)].slot = static_cast<std::int32_t>(pos);
  }
  // puts item into the hole at pos or above it
  void siftUp(std::size_t pos, std::uint64_t item) {
    while (pos > 0) {
      const std::size_t parent = (pos - 1) / 2;
      if (!(item < items_[parent])) break;
      place(pos, items_[parent]);
      pos = parent;
    }
    place(pos, item);
  }

  std::vector<CellState>& cells_;
  std::vector<std::uint64_t> items_;
};

void validate(const FastMarchingInput& in) {
  const GridSpec& s = in.spec;
  for (int a = 0; a < 3; ++a) {
    if (s.n[a] < 1) throw std::invalid_argument("fastMarching: the grid needs at least one cell per axis");
    if (!(s.cell[a] > 0.0) || !std::isfinite(s.cell[a]))
      throw std::invalid_argument("fastMarching: cell sizes must be positive and finite");
  }
  const double padded = (s.n[0] + 4.0) * (s.n[1] + 4.0) * (s.n[2] + 4.0);  // two padding layers a side
  if (padded > static_cast<double>(std::numeric_limits<std::int32_t>::max()))
    throw std::invalid_argument("fastMarching: grid too large");
  if (in.order != 1 && in.order != 2) throw std::invalid_argument("fastMarching: order must be 1 or 2");
  if (!in.start.empty() && in.start.size() != s.size())
    throw std::invalid_argument("fastMarching: start needs " + std::to_string(s.size()) + " values or none");
  for (const float v : in.start)
    if (v < 0.0f) throw std::invalid_argument("fastMarching: a start value is negative");
  if (in.cost.size() != s.size() || in.goal.size() != s.size())
    throw std::invalid_argument("fastMarching: cost and goal need " + std::to_string(s.size()) + " values (got " +
                                std::to_string(in.cost.size()) + " and " + std::to_string(in.goal.size()) + ")");
  for (std::size_t i = 0; i < in.cost.size(); ++i)
    if (!(in.cost[i] >= 0.0f))
      throw std::invalid_argument("fastMarching: cost of cell " + std::to_string(i) + " is negative or NaN");
}

// the waves' upwind update of a cell of cost f from, per axis, the value m[a] its difference is taken from, the
// term's weight wt[a] and its square root rw[a] (m[a] = +inf: no known neighbour along a): the heap's arithmetic
// (marchHeap's solve, first order) without branches on the values, which would be mispredicted about as often as
// not: the axes sorted by selects, every candidate root computed and the valid one selected.
inline double pick(bool c, double a, double b) {  // c ? a : b, by bit masks (no branch)
  std::uint64_t ua, ub;
  std::memcpy(&ua, &a, sizeof a);
  std::memcpy(&ub, &b, sizeof b);
  const std::uint64_t mask = std::uint64_t{0} - static_cast<std::uint64_t>(c);
  const std::uint64_t r = (ua & mask) | (ub & ~mask);
  double out;
  std::memcpy(&out, &r, sizeof out);
  return out;
}
inline float solveSelect(const double mIn[3], const double wt[3], const double rw[3], double f) {
  // sorted by value (a stable sort: equal values keep their axis order), the axes' indices alongside
  double m[3] = {mIn[0], mIn[1], mIn[2]};
  int axis[3] = {0, 1, 2};
  auto order = [&](int a, int b) {
    const bool swap = m[b] < m[a];
    const double lo = std::min(m[a], m[b]), hi = std::max(m[b], m[a]);
    const int ia = swap ? axis[b] : axis[a], ib = swap ? axis[a] : axis[b];
    m[a] = lo;
    m[b] = hi;
    axis[a] = ia;
    axis[b] = ib;
  };
  order(0, 1);
  order(1, 2);
  order(0, 1);
  const double w0 = wt[axis[0]], w1 = wt[axis[1]], w2 = wt[axis[2]];
  // one axis: C = m0 + f / sqrt(w0). The next axis is taken in while C exceeds its value; in τ = C − m0,
  // δ_a = m_a − m0 the equation Σ_a w_a (τ − δ_a)^2 = f^2 has the root
  // τ = (Σ w δ + sqrt((Σ w δ)^2 − Σw (Σ w δ^2 − f^2))) / Σw. A negative discriminant or a root not above δ
  // (rounding only) keeps the solution with fewer axes. (With m_a = +inf the root is NaN or +inf and is not
  // taken.)
  const double base = m[0];
  const double tau1 = f / rw[axis[0]];
  const double d1 = m[1] - base, d2 = m[2] - base;
  const double sw2 = w0 + w1, swd2 = 0.0 + w1 * d1, swdd2 = 0.0 + w1 * d1 * d1;
  const double disc2 = swd2 * swd2 - sw2 * (swdd2 - f * f);
  const double tau2 = (swd2 + std::sqrt(std::max(disc2, 0.0))) / sw2;
  const double sw3 = sw2 + w2, swd3 = swd2 + w2 * d2, swdd3 = swdd2 + w2 * d2 * d2;
  const double disc3 = swd3 * swd3 - sw3 * (swdd3 - f * f);
  const double tau3 = (swd3 + std::sqrt(std::max(disc3, 0.0))) / sw3;
  const bool two = (tau1 > d1) & !(disc2 < 0.0) & (tau2 > d1);
  const bool three = two & (tau2 > d2) & !(disc3 < 0.0) & (tau3 > d2);
  return static_cast<float>(base + pick(three, tau3, pick(two, tau2, tau1)));
}

// the heap's march (any order)
Grid3<float> marchHeap(const FastMarchingInput& input) {
  const GridSpec& spec = input.spec;
  const int nx = spec.n[0], ny = spec.n[1], nz = spec.n[2];

  // padded grid: two layers of impassable, accepted cells around the grid remove all bounds
  // checks (second order reads two cells away); impassable cells are accepted at +inf from the start
  const std::size_t px = static_cast<std::size_t>(nx) + 4, py = static_cast<std::size_t>(ny) + 4,
                    pz = static_cast<std::size_t>(nz) + 4;
  std::vector<CellState> cells(px * py * pz, CellState{kInf, kInf, kKnown});
  auto paddedIndex = [&](int i, int j, int k) {
    return (static_cast<std::size_t>(k + 2) * py + static_cast<std::size_t>(j + 2)) * px +
           static_cast<std::size_t>(i + 2);
  };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        CellState& c = cells[paddedIndex(i, j, k)];
        c.cost = input.cost[spec.index(i, j, k)];
        if (std::isfinite(c.cost)) c.slot = kFar;
      }

  // neighbour offsets, spacings h and weights w = 1/h^2
  const std::size_t stride[3] = {1, px, px * py};
  double h[3], w[3];
  for (int a = 0; a < 3; ++a) {
    h[a] = spec.cell[a];
    w[a] = 1.0 / (h[a] * h[a]);
  }
  const bool second = input.order == 2;

  // the upwind update of cell p from its accepted neighbours (solveSelect above is its first order without
  // branches: along the heap's chain of dependent solves the branches cost less than computing every root)
  auto solve = [&](std::size_t p) -> float {
    // per axis: the value the difference is taken from (m_a, or (4 m_a − m'_a)/3 at second order) and the
    // term's weight (w_a, or 9/4 w_a); then sorted by value
    double m[3], wt[3];
    for (int a = 0; a < 3; ++a) {
      const float lo = cells[p - stride[a]].val, hi = cells[p + stride[a]].val;
      const bool low = lo <= hi;
      const float m1 = low ? lo : hi;
      m[a] = static_cast<double>(m1);
      wt[a] = w[a];
      if (second && m1 < kInf) {
        const float m2 = low ? cells[p - 2 * stride[a]].val : cells[p + 2 * stride[a]].val;
        if (m2 <= m1) {  // accepted (finite) and decreasing toward the front
          m[a] = (4.0 * static_cast<double>(m1) - static_cast<double>(m2)) / 3.0;
          wt[a] = 2.25 * w[a];
        }
      }
    }
    auto order = [&](int a, int b) {
      if (m[b] < m[a]) {
        std::swap(m[a], m[b]);
        std::swap(wt[a], wt[b]);
      }
    };
    order(0, 1);
    order(1, 2);
    order(0, 1);
    // one axis: C = m0 + f / sqrt(w0). Take in the next axis while C exceeds its value; in
    // τ = C − m0, δ_a = m_a − m0 the equation Σ_a w_a (τ − δ_a)^2 = f^2 has the root
    // τ = (Σ w δ + sqrt((Σ w δ)^2 − Σw (Σ w δ^2 − f^2))) / Σw. A negative discriminant or a
    // root not above δ (rounding only) keeps the solution with fewer axes.
    const double f = static_cast<double>(cells[p].cost);
    const double base = m[0];
    double tau = f / std::sqrt(wt[0]);
    double sw = wt[0], swd = 0.0, swdd = 0.0;
    for (int a = 1; a < 3; ++a) {
      const double d = m[a] - base;
      if (!(tau > d)) break;  // also when m_a = +inf
      const double nsw = sw + wt[a], nswd = swd + wt[a] * d, nswdd = swdd + wt[a] * d * d;
      const double disc = nswd * nswd - nsw * (nswdd - f * f);
      if (disc < 0.0) break;
      const double t = (nswd + std::sqrt(disc)) / nsw;
      if (!(t > d)) break;
      tau = t;
      sw = nsw;
      swd = nswd;
      swdd = nswdd;
    }
    return static_cast<float>(base + tau);
  };

  // the heap holds the front: room for a few layers of cells, grown if needed
  CellHeap heap(cells);
  heap.reserve(4 * (px * py + py * pz + px * pz));

  // a cell known from the start (a goal at 0, or a start value) enters the heap with its value, even an
  // impassable one (it wins), or lowers its entry
  const auto enter = [&](std::size_t p, float v) {
    if (cells[p].slot == kKnown) cells[p].slot = kFar;
    if (cells[p].slot == kFar) {
      heap.push(static_cast<std::uint32_t>(p), v);
    } else if (v < heap.keyAt(cells[p].slot)) {
      heap.decrease(cells[p].slot, static_cast<std::uint32_t>(p), v);
    }
  };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!input.goal[spec.index(i, j, k)]) continue;
        const std::size_t p = paddedIndex(i, j, k);
        cells[p].cost = 0.0f;
        enter(p, 0.0f);
      }

  // cells with a start value (a goal cell keeps 0) keep it: no update lowers it
  std::vector<std::uint8_t> fixedCell;
  if (!input.start.empty()) {
    fixedCell.assign(cells.size(), 0);
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
          const float v = input.start[spec.index(i, j, k)];
          if (!(v < kInf) || input.goal[spec.index(i, j, k)]) continue;
          const std::size_t p = paddedIndex(i, j, k);
          fixedCell[p] = 1;
          enter(p, v);
        }
  }

  // accept the smallest tentative value, then update its unaccepted neighbours
  while (!heap.empty()) {
    const std::uint64_t top = heap.pop();
    const std::size_t c = CellHeap::cellOf(top);
    cells[c].slot = kKnown;
    cells[c].val = CellHeap::keyOf(top);
    for (int a = 0; a < 3; ++a) {
      for (const std::size_t q : {c - stride[a], c + stride[a]}) {
        const std::int32_t s = cells[q].slot;
        if (s == kKnown || (!fixedCell.empty() && fixedCell[q])) continue;
        const float t = solve(q);
        if (s == kFar) {
          heap.push(static_cast<std::uint32_t>(q), t);
        } else if (t < heap.keyAt(s)) {
          heap.decrease(s, static_cast<std::uint32_t>(q), t);
        }
      }
    }
  }

  // unpad
  Grid3<float> out(spec, kInf);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) out.at(i, j, k) = cells[paddedIndex(i, j, k)].val;
  return out;
}

// First order by waves (the header). The cells are stored in bricks of 4 × 4 × 4 (x fastest inside a brick,
// then y, then z; the bricks in x, y, z order), so that one 64-bit word holds a brick's bits of a set and the
// cells a wave touches share cache lines; one layer of bricks of padding (never lowered, at +inf) all round
// means every cell of the grid has its six neighbours. A wave takes the bricks with a trigger (a cell lowered
// by the last wave) and their six neighbours; each brick (one thread) solves its cells next to a trigger lower
// than themselves from the values before the wave, then each brick puts its lowered values in. No value
// depends on the threads or on the order of the bricks. After a wave most of whose lowered cells had a value
// before (the step count orders the cells badly: extended or uneven sources, obstacles), the heap solves the
// field afresh.
Grid3<float> marchWaves(const FastMarchingInput& input, FastMarchingReport& report) {
  const GridSpec& spec = input.spec;
  const int nx = spec.n[0], ny = spec.n[1], nz = spec.n[2];
  std::size_t nb[3];
  for (int a = 0; a < 3; ++a) nb[a] = (static_cast<std::size_t>(spec.n[a]) + 8 + 3) / 4;
  const std::size_t bricks = nb[0] * nb[1] * nb[2], cells = 64 * bricks;
  const std::size_t brickStride[3] = {1, nb[0], nb[0] * nb[1]};
  // cell (i, j, k) of the grid at (i, j, k) + 4 in the padded bricks
  const auto cellIndex = [&](int i, int j, int k) {
    const auto x = static_cast<std::size_t>(i) + 4, y = static_cast<std::size_t>(j) + 4,
               z = static_cast<std::size_t>(k) + 4;
    return (((z >> 2) * nb[1] + (y >> 2)) * nb[0] + (x >> 2)) * 64 + (z & 3) * 16 + (y & 3) * 4 + (x & 3);
  };
  // the offsets of each brick cell's neighbours below (side 0) and above (side 1) along x, y, z: inside the
  // brick, or across to the next one
  static constexpr unsigned kShift[3] = {0, 2, 4};
  std::ptrdiff_t offset[3][2][64];
  for (int a = 0; a < 3; ++a)
    for (std::size_t l = 0; l < 64; ++l) {
      const auto one = static_cast<std::ptrdiff_t>(std::size_t{1} << kShift[a]);
      const auto jump = static_cast<std::ptrdiff_t>(64 * brickStride[a]) - 4 * one;
      const std::size_t local = (l >> kShift[a]) & 3;
      offset[a][0][l] = -one - (local == 0 ? jump : 0);
      offset[a][1][l] = one + (local == 3 ? jump : 0);
    }
  // masks of the cells whose neighbour below / above along x, y, z is in the same brick's first / last layer
  constexpr std::uint64_t kLow[3] = {0x1111111111111111ull, 0x000f000f000f000full, 0x000000000000ffffull};
  constexpr std::uint64_t kHigh[3] = {0x8888888888888888ull, 0xf000f000f000f000ull, 0xffff000000000000ull};
  std::vector<float> val(cells, kInf), cost(cells, kInf), next(cells, kInf);
  std::vector<std::uint64_t> open(bricks, 0);     // may be lowered: in the grid, passable, no start value or goal
  std::vector<std::uint64_t> trigger(bricks, 0);  // lowered by the last wave (at first: goals and start values)
  std::vector<std::uint64_t> lowered(bricks, 0);  // by this wave
  std::vector<std::uint32_t> listed(bricks, 0);   // the last wave that listed the brick
  float lowest = kInf;                            // the smallest trigger value
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::size_t p = cellIndex(i, j, k), c = spec.index(i, j, k);
        const std::uint64_t bit = std::uint64_t{1} << (p & 63);
        cost[p] = input.cost[c];
        const bool goal = input.goal[c] != 0;
        const float start = input.start.empty() || goal ? kInf : input.start[c];
        if (goal || start < kInf) {
          val[p] = goal ? 0.0f : start;
          trigger[p >> 6] |= bit;
          lowest = std::min(lowest, val[p]);
        } else if (std::isfinite(cost[p])) {
          open[p >> 6] |= bit;
        }
      }
  double w[3], rootW[3];
  for (int a = 0; a < 3; ++a) {
    w[a] = 1.0 / (spec.cell[a] * spec.cell[a]);
    rootW[a] = std::sqrt(w[a]);
  }
  // the bricks of a wave: those with a trigger and their six neighbours, each listed once (stamped)
  std::uint32_t wave = 1;
  const auto list = [&](std::size_t b, std::vector<std::uint32_t>& out) {
    for (const std::size_t q :
         {b, b - 1, b + 1, b - brickStride[1], b + brickStride[1], b - brickStride[2], b + brickStride[2]}) {
      if (__atomic_exchange_n(&listed[q], wave, __ATOMIC_RELAXED) != wave) out.push_back(static_cast<std::uint32_t>(q));
    }
  };
  std::vector<std::uint32_t> active;
  for (std::size_t b = 0; b < bricks; ++b)
    if (trigger[b] != 0) list(b, active);
  ++wave;
  const auto threads = static_cast<std::size_t>(threadCount());
  struct alignas(64) PerThread {  // (a cache line each)
    std::vector<std::uint32_t> listed;
    float lowest = kInf;
    std::size_t lowered = 0, relowered = 0;
  };
  std::vector<PerThread> part(threads);
  // room for every brick in each list: nothing is allocated inside the team (an exception could not leave it)
  active.reserve(bricks);
  for (PerThread& t : part) t.listed.reserve(bricks);
  std::size_t loweredSum = 0;
  bool toHeap = false;
  // one team of threads for all the waves (each is two short loops): the shared state changes in `serial` only,
  // between barriers, so every thread takes the same branches
  parallelTeam([&](const Team& team) {
    const auto forEach = [&](auto&& body) {
      if (active.size() < 8) {
        team.serial([&] {
          for (const std::uint32_t b : active) body(b);
        });
      } else {
        team.forDynamic(active.size(), 16, [&](std::size_t e) { body(active[e]); });
      }
    };
    while (!active.empty()) {
      const float lowTrigger = lowest;
      // the solves of the cells next to a trigger lower than themselves, from the values before the wave
      forEach([&](std::size_t b) {
        if (open[b] == 0) return;
        PerThread& mine = part[static_cast<std::size_t>(threadIndex())];
        // per axis and side: the cells whose neighbour there is a trigger
        std::uint64_t from[3][2];
        const std::uint64_t own = trigger[b];
        for (int a = 0; a < 3; ++a) {
          const unsigned s = 1u << kShift[a], across = 3 * s;
          from[a][0] = ((own << s) & ~kLow[a]) | ((trigger[b - brickStride[a]] >> across) & kLow[a]);
          from[a][1] = ((own >> s) & ~kHigh[a]) | ((trigger[b + brickStride[a]] << across) & kHigh[a]);
        }
        const std::uint64_t cand =
            open[b] & (from[0][0] | from[0][1] | from[1][0] | from[1][1] | from[2][0] | from[2][1]);
        // only through a lower trigger can a solve give less than before: a cell without a value yet is solved, a
        // cell at or below every trigger is not, the others look at their triggers
        std::uint64_t solve = 0, look = 0;
        for (std::uint64_t bits = cand; bits != 0; bits &= bits - 1) {
          const unsigned l = static_cast<unsigned>(__builtin_ctzll(bits));
          const float vq = val[b * 64 + l];
          solve |= static_cast<std::uint64_t>(vq == kInf) << l;
          look |= static_cast<std::uint64_t>((vq > lowTrigger) & (vq < kInf)) << l;
        }
        for (std::uint64_t bits = look; bits != 0; bits &= bits - 1) {
          const unsigned l = static_cast<unsigned>(__builtin_ctzll(bits));
          const std::size_t q = b * 64 + l;
          const float vq = val[q];
          bool lower = false;
          for (int a = 0; a < 3; ++a) {
            lower |= (((from[a][0] >> l) & 1) != 0) & (vq > val[q + offset[a][0][l]]);
            lower |= (((from[a][1] >> l) & 1) != 0) & (vq > val[q + offset[a][1][l]]);
          }
          solve |= static_cast<std::uint64_t>(lower) << l;
        }
        std::uint64_t low = 0, known = 0;  // lowered; had a value before
        for (std::uint64_t bits = solve; bits != 0; bits &= bits - 1) {
          const unsigned l = static_cast<unsigned>(__builtin_ctzll(bits));
          const std::size_t q = b * 64 + l;
          known |= static_cast<std::uint64_t>(val[q] < kInf) << l;
          double m[3];
          for (int a = 0; a < 3; ++a)
            m[a] = static_cast<double>(std::min(val[q + offset[a][0][l]], val[q + offset[a][1][l]]));
          const float t = solveSelect(m, w, rootW, static_cast<double>(cost[q]));
          next[q] = t;  // (read only where lowered)
          low |= static_cast<std::uint64_t>(t < val[q]) << l;
        }
        lowered[b] = low;
        mine.lowered += static_cast<std::size_t>(std::bitset<64>(low).count());
        mine.relowered += static_cast<std::size_t>(std::bitset<64>(low & known).count());
      });
      // put the lowered values in: they are the next wave's triggers
      forEach([&](std::size_t b) {
        PerThread& mine = part[static_cast<std::size_t>(threadIndex())];
        const std::uint64_t low = lowered[b];
        lowered[b] = 0;
        trigger[b] = low;
        float least = kInf;
        for (std::uint64_t bits = low; bits != 0; bits &= bits - 1) {
          const std::size_t q = b * 64 + static_cast<std::size_t>(__builtin_ctzll(bits));
          val[q] = next[q];
          least = std::min(least, next[q]);
        }
        mine.lowest = std::min(mine.lowest, least);
        if (low != 0) list(b, mine.listed);
      });
      team.serial([&] {
        std::size_t waveLowered = 0, waveRelowered = 0;
        for (PerThread& t : part) {
          waveLowered += t.lowered;
          waveRelowered += t.relowered;
          t.lowered = t.relowered = 0;
        }
        loweredSum += waveLowered;
        toHeap = loweredSum >= kHandOverAfter && waveLowered >= kHandOverWave &&
                 static_cast<double>(waveRelowered) > kRelowered * static_cast<double>(waveLowered);
        ++wave;
        active.clear();
        lowest = kInf;
        for (PerThread& t : part) {
          active.insert(active.end(), t.listed.begin(), t.listed.end());
          t.listed.clear();
          lowest = std::min(lowest, t.lowest);
          t.lowest = kInf;
        }
        ++report.waves;
      });
      if (toHeap) break;
    }
  });
  report.handedOver = toHeap;
  // (the heap from the start: with the waves' values as tentative ones its heap would hold every cell they
  // reached, not just the front, and run slower than from the sources)
  if (toHeap) return marchHeap(input);
  Grid3<float> out(spec, kInf);
  parallelFor(static_cast<std::size_t>(nz), [&](std::size_t k) {
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) out.at(i, j, static_cast<int>(k)) = val[cellIndex(i, j, static_cast<int>(k))];
  });
  return out;
}

}  // namespace

Grid3<float> fastMarching(const FastMarchingInput& input, FastMarchingReport* report) {
  validate(input);
  FastMarchingReport own;
  FastMarchingReport& r = report ? *report : own;
  r = FastMarchingReport{};
  if (input.order != 1 || input.heap) return marchHeap(input);
  // the waves only from a few source cells (a point goal), where they lower each cell about once; from more
  // they lower cells again and again, and the heap is faster
  std::size_t sources = 0;
  for (std::size_t c = 0; c < input.goal.size() && sources <= kFewSources; ++c)
    sources += input.goal[c] != 0 || (!input.start.empty() && input.start[c] < kInf) ? 1 : 0;
  if (sources > kFewSources) return marchHeap(input);
  r.waved = true;
  return marchWaves(input, r);
}

Grid3<Vec3> descentDirection(const Grid3<float>& C, float speed) {
  const GridSpec& spec = C.spec;
  Grid3<Vec3> out(spec, Vec3::Zero());
  const std::size_t nx = static_cast<std::size_t>(spec.n[0]), ny = static_cast<std::size_t>(spec.n[1]);
  const std::size_t stride[3] = {1, nx, nx * ny};
  parallelFor(spec.size(), [&](std::size_t idx) {
    const float c = C.data[idx];
    if (!std::isfinite(c) || !(c > 0.0f)) return;  // unreachable, impassable or goal
    const int q[3] = {static_cast<int>(idx % nx), static_cast<int>((idx / nx) % ny), static_cast<int>(idx / (nx * ny))};
    // upwind one-sided derivative per axis, toward the smaller neighbour if it is lower
    Vec3 g = Vec3::Zero();
    for (int a = 0; a < 3; ++a) {
      const float lo = q[a] > 0 ? C.data[idx - stride[a]] : kInf;
      const float hi = q[a] < spec.n[a] - 1 ? C.data[idx + stride[a]] : kInf;
      const auto h = static_cast<float>(spec.cell[a]);
      if (lo <= hi) {
        if (lo < c) g[a] = (c - lo) / h;
      } else if (hi < c) {
        g[a] = (hi - c) / h;
      }
    }
    out.data[idx] = normalizedOrZero(g) * -speed;
  });
  return out;
}

}  // namespace swarmsim
