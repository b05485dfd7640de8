#include "fields/fast_marching.hpp"

#include <algorithm>
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

}  // namespace

Grid3<float> fastMarching(const FastMarchingInput& input) {
  validate(input);
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

  // the upwind update of cell p from its accepted neighbours
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
