#include "fields/fast_marching.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/parallel.hpp"

namespace swarmsim {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::int32_t kFar = -1;    // not reached yet
constexpr std::int32_t kKnown = -2;  // accepted (or impassable, or padding)

// Binary min-heap of (key, cell) with decrease-key: slot[cell] is the cell's position in
// the heap while it is in it. Ties are broken by the cell index, so the order of
// acceptance (and the result) is fully determined by the input.
class CellHeap {
 public:
  explicit CellHeap(std::vector<std::int32_t>& slot) : slot_(slot) {}
  void reserve(std::size_t n) { items_.reserve(n); }
  bool empty() const { return items_.empty(); }
  float keyAt(std::int32_t pos) const { return items_[static_cast<std::size_t>(pos)].key; }

  void push(std::int32_t cell, float key) {
    items_.push_back({key, cell});
    siftUp(items_.size() - 1);
  }
  void decrease(std::int32_t pos, float key) {
    items_[static_cast<std::size_t>(pos)].key = key;
    siftUp(static_cast<std::size_t>(pos));
  }
  // removes the smallest item; its slot is left for the caller to set
  std::pair<std::int32_t, float> pop() {
    const Item top = items_.front();
    const Item last = items_.back();
    items_.pop_back();
    if (!items_.empty()) {
      items_.front() = last;
      siftDown(0);
    }
    return {top.cell, top.key};
  }

 private:
  struct Item {
    float key;
    std::int32_t cell;
  };
  static bool less(const Item& a, const Item& b) { return a.key < b.key || (a.key == b.key && a.cell < b.cell); }
  void place(std::size_t pos, const Item& it) {
    items_[pos] = it;
    slot_[static_cast<std::size_t>(it.cell)] = static_cast<std::int32_t>(pos);
  }
  void siftUp(std::size_t pos) {
    const Item it = items_[pos];
    while (pos > 0) {
      const std::size_t parent = (pos - 1) / 2;
      if (!less(it, items_[parent])) break;
      place(pos, items_[parent]);
      pos = parent;
    }
    place(pos, it);
  }
  void siftDown(std::size_t pos) {
    const Item it = items_[pos];
    const std::size_t n = items_.size();
    for (;;) {
      std::size_t child = 2 * pos + 1;
      if (child >= n) break;
      if (child + 1 < n && less(items_[child + 1], items_[child])) ++child;
      if (!less(items_[child], it)) break;
      place(pos, items_[child]);
      pos = child;
    }
    place(pos, it);
  }

  std::vector<Item> items_;
  std::vector<std::int32_t>& slot_;
};

void validate(const FastMarchingInput& in) {
  const GridSpec& s = in.spec;
  for (int a = 0; a < 3; ++a) {
    if (s.n[a] < 1) throw std::invalid_argument("fastMarching: the grid needs at least one cell per axis");
    if (!(s.cell[a] > 0.0) || !std::isfinite(s.cell[a]))
      throw std::invalid_argument("fastMarching: cell sizes must be positive and finite");
  }
  const double padded = (s.n[0] + 2.0) * (s.n[1] + 2.0) * (s.n[2] + 2.0);
  if (padded > static_cast<double>(std::numeric_limits<std::int32_t>::max()))
    throw std::invalid_argument("fastMarching: grid too large");
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

  // padded copies: one layer of impassable, accepted cells around the grid removes all
  // bounds checks; val holds accepted values only (+inf for the rest)
  const std::size_t px = static_cast<std::size_t>(nx) + 2, py = static_cast<std::size_t>(ny) + 2;
  const std::size_t padded = px * py * (static_cast<std::size_t>(nz) + 2);
  std::vector<float> val(padded, kInf), cost(padded, kInf);
  std::vector<std::int32_t> slot(padded, kKnown);
  auto paddedIndex = [&](int i, int j, int k) {
    return (static_cast<std::size_t>(k + 1) * py + static_cast<std::size_t>(j + 1)) * px + static_cast<std::size_t>(i + 1);
  };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const std::size_t p = paddedIndex(i, j, k);
        cost[p] = input.cost[spec.index(i, j, k)];
        if (std::isfinite(cost[p])) slot[p] = kFar;
      }

  // neighbour offsets and squared inverse spacings per axis
  const std::int32_t stride[3] = {1, static_cast<std::int32_t>(px), static_cast<std::int32_t>(px * py)};
  const double h[3] = {spec.cell[0], spec.cell[1], spec.cell[2]};

  // the upwind update of cell p from its accepted neighbours
  auto solve = [&](std::size_t p) -> float {
    // smallest accepted value per axis, with that axis' spacing, sorted by value
    double m[3], hh[3];
    for (int a = 0; a < 3; ++a) {
      m[a] = static_cast<double>(std::min(val[p - stride[a]], val[p + stride[a]]));
      hh[a] = h[a];
    }
    auto order = [&](int a, int b) {
      if (m[b] < m[a]) {
        std::swap(m[a], m[b]);
        std::swap(hh[a], hh[b]);
      }
    };
    order(0, 1);
    order(1, 2);
    order(0, 1);
    // one axis, then add axes while the solution exceeds the next neighbour value;
    // in τ = C − m0 the equation is Σ_a (τ − δ_a)^2 / h_a^2 = f^2 with δ_a = m_a − m0
    const double f = static_cast<double>(cost[p]);
    double tau = hh[0] * f;
    double sw = 0.0, swd = 0.0, swdd = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double d = m[a] - m[0];
      if (a > 0 && !(tau > d)) break;  // also stops at +inf neighbours
      const double w = 1.0 / (hh[a] * hh[a]);
      sw += w;
      swd += w * d;
      swdd += w * d * d;
      if (a == 0) continue;
      const double disc = swd * swd - sw * (swdd - f * f);
      if (disc < 0.0) break;  // keep the solution with fewer axes
      const double t = (swd + std::sqrt(disc)) / sw;
      if (!(t > d)) break;
      tau = t;
    }
    return static_cast<float>(m[0] + tau);
  };

  CellHeap heap(slot);
  heap.reserve(4 * (px * py + py * (static_cast<std::size_t>(nz) + 2) + px * (static_cast<std::size_t>(nz) + 2)));

  // goal cells enter the heap at 0 (even impassable ones: a goal wins)
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (!input.goal[spec.index(i, j, k)]) continue;
        const std::size_t p = paddedIndex(i, j, k);
        cost[p] = 0.0f;
        heap.push(static_cast<std::int32_t>(p), 0.0f);
      }

  // accept the smallest tentative value, then update its unaccepted neighbours
  while (!heap.empty()) {
    const auto [cell, key] = heap.pop();
    const auto c = static_cast<std::size_t>(cell);
    slot[c] = kKnown;
    val[c] = key;
    for (int a = 0; a < 3; ++a) {
      for (const std::size_t q : {c - static_cast<std::size_t>(stride[a]), c + static_cast<std::size_t>(stride[a])}) {
        const std::int32_t s = slot[q];
        if (s == kKnown) continue;
        const float t = solve(q);
        if (s == kFar) {
          heap.push(static_cast<std::int32_t>(q), t);
        } else if (t < heap.keyAt(s)) {
          heap.decrease(s, t);
        }
      }
    }
  }

  // unpad
  Grid3<float> out(spec, kInf);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) out.at(i, j, k) = val[paddedIndex(i, j, k)];
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
