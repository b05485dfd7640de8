#include "models/shape/assignment.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/parallel.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {
namespace {

// Below this many points every loop runs on the calling thread: a pass is a
// few milliseconds there, and waking the team for each of its ~20 loops (and
// on a busy machine, waiting for a descheduled thread at each barrier) costs
// more than it saves.
constexpr std::size_t kSerialPointsBelow = 32768;

template <typename F>
void forPoints(std::size_t n, F&& body) {
  if (n < kSerialPointsBelow) {
    for (std::size_t i = 0; i < n; ++i) body(i);
  } else {
    parallelFor(n, body);
  }
}

template <typename F>
void forTasks(std::size_t points, std::size_t tasks, F&& body) {
  if (points < kSerialPointsBelow) {
    for (std::size_t i = 0; i < tasks; ++i) body(i);
  } else {
    parallelForDynamic(tasks, 4, body);
  }
}

inline float distance(float ax, float ay, float az, float bx, float by, float bz) {
  const float dx = ax - bx, dy = ay - by, dz = az - bz;
  return std::sqrt(dx * dx + dy * dy + dz * dz);
}

// ---- recursive bisection -------------------------------------------------------

// a point and its index in the caller's array; the partition moves these (a
// copy of the coordinates beside the index keeps the partition cache-friendly)
struct Item {
  float p[3];
  std::uint32_t index;
};

// levels split over the whole set before the segments become independent
// tasks: up to 2^kTaskLevels tasks, a constant, so the work never depends on
// the thread count
constexpr int kTaskLevels = 6;

// where a segment of n > leaf points is split: at half, rounded down to a
// multiple of leaf (so every leaf segment but the last holds exactly leaf points)
std::size_t splitPoint(std::size_t n, std::size_t leaf) {
  const std::size_t whole = n / leaf;
  return whole >= 2 ? leaf * (whole / 2) : leaf;
}

// Split a[0, n) (and t[0, n) when t is not null, at the same position) at
// `at` along the widest axis of the bounding box of the points: afterwards
// a[0, at) (and t[0, at)) hold the lower points. (nth_element is a fixed
// sequence of steps, so the result is a function of the input order alone.)
void splitSegment(Item* a, Item* t, std::size_t n, std::size_t at) {
  float lo[3], hi[3];
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = a[0].p[d];
  for (const Item* set : {a, t}) {
    if (set == nullptr) continue;
    for (std::size_t k = 0; k < n; ++k) {
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], set[k].p[d]);
        hi[d] = std::max(hi[d], set[k].p[d]);
      }
    }
  }
  int axis = 0;
  for (int d = 1; d < 3; ++d) {
    if (hi[d] - lo[d] > hi[axis] - lo[axis]) axis = d;
  }
  const auto less = [axis](const Item& x, const Item& y) { return x.p[axis] < y.p[axis]; };
  std::nth_element(a, a + at, a + n, less);
  if (t != nullptr) std::nth_element(t, t + at, t + n, less);
}

inline float itemDistance(const Item& a, const Item& t) {
  return distance(a.p[0], a.p[1], a.p[2], t.p[0], t.p[1], t.p[2]);
}

// the best order of t[0, n) against a[0, n) for n <= 3, by trying all (cheaper
// than the last two levels of splitting, and optimal)
void matchTiny(const Item* a, Item* t, std::size_t n) {
  if (n == 2) {
    if (itemDistance(a[0], t[1]) + itemDistance(a[1], t[0]) < itemDistance(a[0], t[0]) + itemDistance(a[1], t[1])) {
      std::swap(t[0], t[1]);
    }
  } else if (n == 3) {
    int order[3] = {0, 1, 2}, best[3] = {0, 1, 2};
    float bestCost = std::numeric_limits<float>::max();
    do {
      const float cost = itemDistance(a[0], t[order[0]]) + itemDistance(a[1], t[order[1]]) + itemDistance(a[2], t[order[2]]);
      if (cost < bestCost) {
        bestCost = cost;
        std::copy(order, order + 3, best);
      }
    } while (std::next_permutation(order, order + 3));
    const Item copy[3] = {t[0], t[1], t[2]};
    for (int i = 0; i < 3; ++i) t[i] = copy[best[i]];
  }
}

void partitionSerial(Item* a, Item* t, std::size_t n, std::size_t leaf) {
  for (;;) {  // recurse on the lower part, loop on the upper one
    if (t != nullptr && leaf == 1 && n <= 3) {
      matchTiny(a, t, n);
      return;
    }
    if (n <= leaf) return;
    const std::size_t at = splitPoint(n, leaf);
    splitSegment(a, t, n, at);
    partitionSerial(a, t, at, leaf);
    a += at;
    if (t != nullptr) t += at;
    n -= at;
  }
}

// Recursive bisection of a[0, n) (with t[0, n) alongside when not null) into
// segments of `leaf` points (the last one fewer), each split along the widest
// axis of the segment. With t and leaf 1, a[i] and t[i] end up in matching
// regions: equal numbers of agents and targets on either side of every cut.
void partition(Item* a, Item* t, std::size_t n, std::size_t leaf) {
  // the top levels: one parallel loop per level over its segments
  std::vector<std::size_t> bounds = {0, n}, next;
  for (int level = 0; level < kTaskLevels; ++level) {
    const std::size_t segments = bounds.size() - 1;
    forTasks(n, segments, [&](std::size_t s) {
      const std::size_t b = bounds[s], e = bounds[s + 1];
      if (e - b > leaf) splitSegment(a + b, t == nullptr ? nullptr : t + b, e - b, splitPoint(e - b, leaf));
    });
    next.clear();
    for (std::size_t s = 0; s < segments; ++s) {
      const std::size_t b = bounds[s], e = bounds[s + 1];
      next.push_back(b);
      if (e - b > leaf) next.push_back(b + splitPoint(e - b, leaf));
    }
    next.push_back(n);
    bounds.swap(next);
  }
  // then each segment independently
  forTasks(n, bounds.size() - 1, [&](std::size_t s) {
    partitionSerial(a + bounds[s], t == nullptr ? nullptr : t + bounds[s], bounds[s + 1] - bounds[s], leaf);
  });
}

std::vector<Item> items(const std::vector<Vec3>& points) {
  std::vector<Item> out(points.size());
  forPoints(points.size(), [&](std::size_t i) {
    out[i] = {{points[i].x(), points[i].y(), points[i].z()}, static_cast<std::uint32_t>(i)};
  });
  return out;
}

// ---- 2-opt passes ----------------------------------------------------------------

// The grid for the swap passes: cells sized so that a point's cell holds ~3
// points on average (so a point has ~40 swap candidates in a volume and ~20 on
// a surface, see improveCell). The first guess assumes a volume; the occupancy
// is measured and the edge corrected (as for a surface, the common other case)
// up to three times.
void buildSwapGrid(UniformGrid& grid, const std::vector<float>& x, const std::vector<float>& y,
                   const std::vector<float>& z) {
  constexpr double kTargetOccupancy = 3.0;
  constexpr double kCellsPerPoint = 16.0;  // surfaces in large boxes need many (mostly empty) cells
  const std::size_t n = x.size();
  const auto [x0, x1] = std::minmax_element(x.begin(), x.end());
  const auto [y0, y1] = std::minmax_element(y.begin(), y.end());
  const auto [z0, z1] = std::minmax_element(z.begin(), z.end());
  const double extent = std::max({double(*x1) - *x0, double(*y1) - *y0, double(*z1) - *z0});
  double edge = extent > 0.0 ? extent / std::cbrt(static_cast<double>(n)) : 1.0;
  for (int attempt = 0;; ++attempt) {
    edge = std::max(edge, static_cast<double>(std::numeric_limits<float>::min()));  // > 0 as a float too
    grid.build(x.data(), y.data(), z.data(), n, static_cast<float>(edge), kCellsPerPoint);
    // mean number of points in the cell of a point: sum of squared counts / n
    std::uint64_t sum = 0;
    for (std::size_t c = 0; c < grid.cellCount(); ++c) {
      const std::uint64_t m = grid.cellEnd(c) - grid.cellBegin(c);
      sum += m * m;
    }
    const double occupancy = static_cast<double>(sum) / static_cast<double>(n);
    if (attempt == 3 || (occupancy > 0.5 * kTargetOccupancy && occupancy < 2.0 * kTargetOccupancy)) return;
    // a surface's occupancy scales with edge^2, a volume's with edge^3
    edge *= std::pow(kTargetOccupancy / occupancy, occupancy > kTargetOccupancy ? 0.5 : 1.0 / 3.0);
  }
}

// One fixed point and its current partner, by sorted grid position (32 bytes:
// a row of a neighbourhood is one contiguous run of these, so a gather streams
// five runs, where one array per quantity streamed five per quantity and was
// three times slower at a million points)
struct Slot {
  float sx, sy, sz;        // the fixed point
  float dist;              // |s - q|
  float qx, qy, qz;        // its partner
  std::uint32_t partner;   // the partner's index in the other set
};

// Cells are grouped in tiles of kTile^3 for the passes. Tiles get 2 x 2 x 2
// colours: two tiles of one colour are at least kTile >= 2 cells apart, and a
// cell's work touches only cells within one of it, so the tiles of one colour
// can run in parallel without touching the same slots. Inside a tile the cells
// run in order, and the tile with its one-cell halo stays in cache while its
// cells reuse it (with 27 colours of single cells instead, a pass streamed
// every point from memory 27 times: 1.5x slower at a million points).
constexpr int kTile = 4;

// One point set held fixed while the points of the other set are exchanged
// between them: the fixed points binned in a grid, their slots, and the
// non-empty cells tile by tile, the tiles by colour.
struct FixedSide {
  UniformGrid grid;
  std::vector<Slot> slots;
  std::vector<std::uint32_t> cells;          // non-empty cells, increasing within a tile
  std::vector<std::size_t> tileStart;        // tile r: cells[tileStart[r], tileStart[r + 1])
  std::array<std::size_t, 9> colourStart{};  // colour c: tiles [colourStart[c], colourStart[c + 1])
};

void buildSide(FixedSide& side, const std::vector<Vec3>& points, std::vector<float>& x, std::vector<float>& y,
               std::vector<float>& z) {
  const std::size_t n = points.size();
  forPoints(n, [&](std::size_t i) {
    x[i] = points[i].x();
    y[i] = points[i].y();
    z[i] = points[i].z();
  });
  UniformGrid& g = side.grid;
  buildSwapGrid(g, x, y, z);
  side.slots.resize(n);
  forPoints(n, [&](std::size_t k) {
    Slot& s = side.slots[k];
    s.sx = g.sortedX()[k];
    s.sy = g.sortedY()[k];
    s.sz = g.sortedZ()[k];
  });
  // tiles: counting sort of the non-empty cells by tile (stable, so cells stay
  // increasing within a tile), tiles ordered by colour, then index
  const std::size_t d0 = g.dim(0), d1 = g.dim(1);
  std::size_t tdim[3];
  for (int a = 0; a < 3; ++a) tdim[a] = (static_cast<std::size_t>(g.dim(a)) + kTile - 1) / kTile;
  const auto tileOf = [&](std::size_t c) {
    return (c / (d0 * d1) / kTile * tdim[1] + (c / d0) % d1 / kTile) * tdim[0] + c % d0 / kTile;
  };
  const auto colourOf = [&](std::size_t t) {
    return t % tdim[0] % 2 + 2 * (t / tdim[0] % tdim[1] % 2) + 4 * (t / (tdim[0] * tdim[1]) % 2);
  };
  std::vector<std::size_t> next(tdim[0] * tdim[1] * tdim[2], 0);
  for (std::size_t c = 0; c < g.cellCount(); ++c) {
    if (g.cellEnd(c) > g.cellBegin(c)) ++next[tileOf(c)];
  }
  side.tileStart.clear();
  std::size_t offset = 0;
  for (std::size_t colour = 0; colour < 8; ++colour) {
    side.colourStart[colour] = side.tileStart.size();
    for (std::size_t t = 0; t < next.size(); ++t) {
      if (next[t] == 0 || colourOf(t) != colour) continue;
      side.tileStart.push_back(offset);
      const std::size_t count = next[t];
      next[t] = offset;
      offset += count;
    }
  }
  side.colourStart[8] = side.tileStart.size();
  side.tileStart.push_back(offset);
  side.cells.resize(offset);
  for (std::size_t c = 0; c < g.cellCount(); ++c) {
    if (g.cellEnd(c) > g.cellBegin(c)) side.cells[next[tileOf(c)]++] = static_cast<std::uint32_t>(c);
  }
}

// a cell's forward half-shell gathered contiguously, one array per quantity so
// the gain loop vectorises (per-thread scratch)
struct Block {
  std::vector<float> sx, sy, sz, qx, qy, qz, dist, gain;  // gain: scratch of the current point
  std::array<std::uint32_t, 5> runBegin{}, runSize{};     // the gathered runs of slots
  int runs = 0;
  std::size_t size = 0;

  void reserve(std::size_t m) {
    if (sx.size() >= m) return;
    m += m / 2 + 16;  // grows rarely
    for (auto* v : {&sx, &sy, &sz, &qx, &qy, &qz, &dist, &gain}) v->resize(m);
  }
  // the slot gathered at block position m
  std::uint32_t slotAt(std::size_t m) const {
    int r = 0;
    while (m >= runSize[r]) m -= runSize[r++];
    return runBegin[r] + static_cast<std::uint32_t>(m);
  }
};

// at most this many swap partners are tried per point (a window of its block),
// so that piles of coincident points cannot make a pass quadratic; a multiple
// of the vector width kLanes
constexpr std::size_t kLanes = 4;
constexpr std::size_t kMaxCandidates = 96;
// a swap must gain this fraction of the two distances: float rounding cannot
// then accept a swap that does not shorten the true total, so passes terminate
constexpr float kMinRelativeGain = 4e-6f;

// what one tile of a pass achieved
struct TaskResult {
  double gain = 0.0;
  std::size_t swaps = 0;
};

// For each point p of cell c in order, try swapping its partner with that of
// every other point of the cell and every point of the cell's forward
// half-shell (the 13 neighbour cells after it in x, then y, then z order, so
// each pair of neighbouring cells is tried once per pass), and take the best
// swap when it shortens the sum of the two distances. Reads and writes only
// slots within one cell of c.
void improveCell(FixedSide& side, std::size_t c, Block& b, TaskResult& result) {
  const UniformGrid& g = side.grid;
  const int d0 = g.dim(0), d1 = g.dim(1), d2 = g.dim(2);
  const int cx = static_cast<int>(c % d0), cy = static_cast<int>((c / d0) % d1);
  const int cz = static_cast<int>(c / (static_cast<std::size_t>(d0) * d1));
  const int xlo = std::max(cx - 1, 0), xhi = std::min(cx + 1, d0 - 1);
  // the half-shell as runs of slots: the cell and the next one in its row
  // first (so the cell's own points come first), then row y + 1, then the
  // three rows of plane z + 1
  b.runs = 0;
  std::size_t total = 0;
  const auto addRun = [&](int y, int z, int x0, int x1) {
    const std::size_t row = (static_cast<std::size_t>(z) * d1 + y) * d0;
    const std::uint32_t begin = g.cellBegin(row + x0), end = g.cellEnd(row + x1);
    b.runBegin[b.runs] = begin;
    b.runSize[b.runs++] = end - begin;
    total += end - begin;
  };
  addRun(cy, cz, cx, xhi);
  if (cy + 1 < d1) addRun(cy + 1, cz, xlo, xhi);
  if (cz + 1 < d2) {
    for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, d1 - 1); ++y) addRun(y, cz + 1, xlo, xhi);
  }
  b.reserve(total + kLanes);
  std::size_t m = 0;
  for (int r = 0; r < b.runs; ++r) {
    const Slot* run = side.slots.data() + b.runBegin[r];
    for (std::uint32_t i = 0; i < b.runSize[r]; ++i, ++m) {
      b.sx[m] = run[i].sx;
      b.sy[m] = run[i].sy;
      b.sz[m] = run[i].sz;
      b.dist[m] = run[i].dist;
      b.qx[m] = run[i].qx;
      b.qy[m] = run[i].qy;
      b.qz[m] = run[i].qz;
    }
  }
  b.size = m;
  // pad to whole vectors with entries whose gain is -infinity
  for (; m % kLanes != 0; ++m) {
    b.sx[m] = b.sy[m] = b.sz[m] = b.qx[m] = b.qy[m] = b.qz[m] = 0.0f;
    b.dist[m] = -std::numeric_limits<float>::infinity();
  }
  const std::size_t padded = m, window = std::min(padded, kMaxCandidates);
  float* __restrict gain = b.gain.data();
  const float* __restrict sx = b.sx.data();
  const float* __restrict sy = b.sy.data();
  const float* __restrict sz = b.sz.data();
  float* __restrict qx = b.qx.data();
  float* __restrict qy = b.qy.data();
  float* __restrict qz = b.qz.data();
  float* __restrict dist = b.dist.data();
  const std::size_t own = g.cellEnd(c) - g.cellBegin(c);
  for (std::size_t p = 0; p < own; ++p) {
    // candidates: a window of whole vectors around p (all of the block unless
    // it is larger than kMaxCandidates); p itself has gain 0
    const std::size_t lo = std::min(p / kLanes * kLanes, padded - window), hi = lo + window;
    const float px = sx[p], py = sy[p], pz = sz[p], pqx = qx[p], pqy = qy[p], pqz = qz[p], pd = dist[p];
    // the gains, and their maximum as integers (the order of non-negative
    // floats' bits; every negative gain maps below the zero start): both loops
    // vectorise, and most points have no gain, so the search below is rare
    for (std::size_t j = lo; j < hi; ++j) {
      gain[j] = pd + dist[j] - distance(px, py, pz, qx[j], qy[j], qz[j]) - distance(sx[j], sy[j], sz[j], pqx, pqy, pqz);
    }
    std::int32_t top = 0;
    for (std::size_t j = lo; j < hi; ++j) {
      std::int32_t bits;
      std::memcpy(&bits, &gain[j], sizeof bits);
      top = std::max(top, bits);
    }
    if (top == 0) continue;
    std::size_t best = lo;
    while (std::memcmp(&gain[best], &top, sizeof top) != 0) ++best;
    if (!(gain[best] > kMinRelativeGain * (pd + dist[best]))) continue;
    // swap partners: p takes best's, best takes p's, in the block and the slots
    const float dp = distance(px, py, pz, qx[best], qy[best], qz[best]);
    const float db = distance(sx[best], sy[best], sz[best], pqx, pqy, pqz);
    result.gain += (static_cast<double>(pd) + dist[best]) - (static_cast<double>(dp) + db);
    ++result.swaps;
    std::swap(qx[p], qx[best]);
    std::swap(qy[p], qy[best]);
    std::swap(qz[p], qz[best]);
    dist[p] = dp;
    dist[best] = db;
    Slot& sp = side.slots[b.slotAt(p)];
    Slot& sb = side.slots[b.slotAt(best)];
    std::swap(sp.partner, sb.partner);
    std::swap(sp.qx, sb.qx);
    std::swap(sp.qy, sb.qy);
    std::swap(sp.qz, sb.qz);
    sp.dist = dp;
    sb.dist = db;
  }
}

// One pass over every non-empty cell of the fixed side, in 8 colour phases of
// tiles. The tiles of one colour run in parallel; per-tile results are summed
// in tile order.
TaskResult improvePass(FixedSide& side, std::vector<Block>& blocks, std::vector<TaskResult>& tiles) {
  tiles.assign(side.tileStart.size() - 1, TaskResult());
  for (int colour = 0; colour < 8; ++colour) {
    const std::size_t first = side.colourStart[colour];
    forTasks(side.slots.size(), side.colourStart[colour + 1] - first, [&](std::size_t i) {
      const std::size_t t = first + i;
      Block& b = blocks[static_cast<std::size_t>(threadIndex())];
      for (std::size_t j = side.tileStart[t]; j < side.tileStart[t + 1]; ++j) improveCell(side, side.cells[j], b, tiles[t]);
    });
  }
  TaskResult pass;
  for (const TaskResult& r : tiles) {
    pass.gain += r.gain;
    pass.swaps += r.swaps;
  }
  return pass;
}

// Hand the links over from one side to the other: every slot of `from` names
// its partner's slot in `to`, which gets the reverse link (partners are one to
// one, so each slot of `to` is written once).
void transfer(const FixedSide& from, FixedSide& to) {
  forPoints(from.slots.size(), [&](std::size_t k) {
    const Slot& f = from.slots[k];
    Slot& t = to.slots[f.partner];
    t.partner = static_cast<std::uint32_t>(k);
    t.qx = f.sx;
    t.qy = f.sy;
    t.qz = f.sz;
    t.dist = f.dist;  // the same float: the squared differences do not depend on the sign
  });
}

// passes end when one gains less than this fraction of the total distance
constexpr double kStopGain = 2e-3;
constexpr int kMaxPasses = 30;

// 2-opt passes from perm (agent -> target) until a pass gains little: each pass
// lets neighbouring agents exchange targets, then neighbouring targets
// exchange agents (both are needed: agents close together may have targets
// far apart, and the other way round). The links live in the slots, by sorted
// grid position on both sides, so following a link mostly stays in cache
// (neighbouring agents have neighbouring targets).
void improve(const std::vector<Vec3>& agents, const std::vector<Vec3>& targets, std::vector<std::uint32_t>& perm) {
  const std::size_t n = agents.size();
  std::vector<float> x(n), y(n), z(n);  // build scratch
  FixedSide agentSide, targetSide;
  buildSide(agentSide, agents, x, y, z);
  buildSide(targetSide, targets, x, y, z);
  const std::vector<std::uint32_t>& agentAt = agentSide.grid.order();  // sorted position -> index
  const std::vector<std::uint32_t>& targetAt = targetSide.grid.order();
  {
    std::vector<std::uint32_t> slotOfTarget(n);
    forPoints(n, [&](std::size_t k) { slotOfTarget[targetAt[k]] = static_cast<std::uint32_t>(k); });
    forPoints(n, [&](std::size_t k) {
      Slot& s = agentSide.slots[k];
      s.partner = slotOfTarget[perm[agentAt[k]]];
      const Slot& t = targetSide.slots[s.partner];
      s.qx = t.sx;
      s.qy = t.sy;
      s.qz = t.sz;
      s.dist = distance(s.sx, s.sy, s.sz, s.qx, s.qy, s.qz);
    });
  }
  double total = 0.0;
  for (const Slot& s : agentSide.slots) total += s.dist;
  std::vector<Block> blocks(static_cast<std::size_t>(threadCount()));
  std::vector<TaskResult> tiles;
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    const TaskResult a = improvePass(agentSide, blocks, tiles);  // neighbouring agents exchange targets
    transfer(agentSide, targetSide);
    const TaskResult b = improvePass(targetSide, blocks, tiles);  // neighbouring targets exchange agents
    transfer(targetSide, agentSide);
    const double gain = a.gain + b.gain;
    total -= gain;
    if (gain < kStopGain * total) break;
  }
  forPoints(n, [&](std::size_t k) { perm[agentAt[k]] = targetAt[agentSide.slots[k].partner]; });
}

// From this many points on, the starting assignment is multilevel: each set is
// cut into groups of kGroup by a bisection of its own, the groups' centroids
// are assigned to each other recursively (this whole function), and each pair
// of matched groups is bisected jointly. The 2-opt passes only move targets
// between neighbours, so they undo a joint bisection's mistakes at scales much
// larger than a cell only slowly. A million agents from a ball to a sphere
// (radius 20 m), against the lower bound sum_i (20 m - |a_i|): a joint
// bisection starts 16.7% above it and is still 0.29% above after 30 passes
// (6.8 s on 2 cores); the multilevel start is 0.61% above, and two passes
// leave 0.15% (1.6 s in all).
constexpr std::size_t kCoarsenFrom = 2000;
constexpr std::size_t kGroup = 8;

std::vector<std::uint32_t> solve(const std::vector<Vec3>& agents, const std::vector<Vec3>& targets) {
  const std::size_t n = agents.size();
  std::vector<Item> a = items(agents), t = items(targets);
  std::vector<std::uint32_t> perm(n);
  if (n < kCoarsenFrom) {
    partition(a.data(), t.data(), n, 1);
    forPoints(n, [&](std::size_t i) { perm[a[i].index] = t[i].index; });
  } else {
    partition(a.data(), nullptr, n, kGroup);
    partition(t.data(), nullptr, n, kGroup);
    const std::size_t groups = n / kGroup;  // full ones; the rest forms a last, smaller group of each set
    std::vector<Vec3> ca(groups), ct(groups);
    forTasks(n, groups, [&](std::size_t g) {
      double sa[3] = {0, 0, 0}, st[3] = {0, 0, 0};
      for (std::size_t k = g * kGroup; k < (g + 1) * kGroup; ++k) {
        for (int d = 0; d < 3; ++d) {
          sa[d] += a[k].p[d];
          st[d] += t[k].p[d];
        }
      }
      for (int d = 0; d < 3; ++d) {
        ca[g][d] = static_cast<float>(sa[d] / kGroup);
        ct[g][d] = static_cast<float>(st[d] / kGroup);
      }
    });
    const std::vector<std::uint32_t> coarse = solve(ca, ct);
    forTasks(n, groups + 1, [&](std::size_t g) {
      const std::size_t h = g < groups ? coarse[g] : groups;
      const std::size_t size = g < groups ? kGroup : n - groups * kGroup;
      Item* ga = a.data() + g * kGroup;
      Item* gt = t.data() + h * kGroup;
      partitionSerial(ga, gt, size, 1);
      for (std::size_t k = 0; k < size; ++k) perm[ga[k].index] = gt[k].index;
    });
  }
  improve(agents, targets, perm);
  return perm;
}

}  // namespace

std::vector<std::uint32_t> assignTargets(const std::vector<Vec3>& agents, const std::vector<Vec3>& targets) {
  if (agents.size() != targets.size()) {
    throw std::invalid_argument("assignTargets: " + std::to_string(agents.size()) + " agents but " +
                                std::to_string(targets.size()) + " targets");
  }
  if (agents.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("assignTargets: more than 2^32 - 1 points");
  }
  for (const auto* set : {&agents, &targets}) {
    for (const Vec3& p : *set) {
      if (!p.allFinite()) throw std::invalid_argument("assignTargets: a coordinate is not finite");
    }
  }
  if (agents.size() < 2) return std::vector<std::uint32_t>(agents.size(), 0);
  return solve(agents, targets);
}

}  // namespace swarmsim
