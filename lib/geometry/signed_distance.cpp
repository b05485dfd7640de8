#include "geometry/signed_distance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/parallel.hpp"

namespace swarmsim {

namespace {

// One body per grid plane, slab or block of lines: few heavy indices, so
// dynamic scheduling (parallelFor runs loops of few indices serially).
template <typename F>
void forEachPlane(std::size_t n, F&& body) {
  parallelForDynamic(n, 1, std::forward<F>(body));
}

}  // namespace

double sphereSignedDistance(const SphereObstacle& s, const Vec3d& p) { return (p - s.center).norm() - s.radius; }

double boxSignedDistance(const BoxObstacle& b, const Vec3d& p) {
  const Vec3d q = (p - 0.5 * (b.min + b.max)).cwiseAbs() - 0.5 * (b.max - b.min);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

namespace {

// ---------------------------------------------------------------------------
// Exact point-triangle distance

struct Tri {
  Vec3d a, ab, ac;
  Vec3d n;  // unit normal (a, b, c counter-clockwise around it); zero if degenerate
  bool degenerate = false;
};

std::vector<Tri> makeTris(const TriangleMesh& mesh) {
  std::vector<Tri> tris(mesh.triangles.size());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const auto& idx = mesh.triangles[t];
    Tri& T = tris[t];
    T.a = mesh.vertices[idx[0]];
    T.ab = mesh.vertices[idx[1]] - T.a;
    T.ac = mesh.vertices[idx[2]] - T.a;
    const Vec3d cr = T.ab.cross(T.ac);
    const double longest2 = std::max({T.ab.squaredNorm(), T.ac.squaredNorm(), (T.ac - T.ab).squaredNorm()});
    // area below ~1e-12 of the longest edge squared: treat as its three edges
    T.degenerate = !(cr.norm() > 1e-12 * longest2);
    T.n = T.degenerate ? Vec3d::Zero() : Vec3d(cr.normalized());
  }
  return tris;
}

double segmentDist2(const Vec3d& ap, const Vec3d& ab) {
  const double len2 = ab.squaredNorm();
  const double s = len2 > 0.0 ? std::clamp(ap.dot(ab) / len2, 0.0, 1.0) : 0.0;
  return (ap - s * ab).squaredNorm();
}

// which part of a triangle is closest to a point
enum Feature : int { kFace = 0, kVertexA, kVertexB, kVertexC, kEdgeAB, kEdgeAC, kEdgeBC };

// squared distance from p to triangle T and the closest feature (Voronoi
// regions of the vertices, edges and face; degenerate triangles report kFace)
double triDist2(const Vec3d& p, const Tri& T, int& feature) {
  const Vec3d ap = p - T.a;
  feature = kFace;
  if (T.degenerate) {
    return std::min({segmentDist2(ap, T.ab), segmentDist2(ap, T.ac), segmentDist2(ap - T.ab, T.ac - T.ab)});
  }
  const double d1 = T.ab.dot(ap), d2 = T.ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) {
    feature = kVertexA;
    return ap.squaredNorm();
  }
  const Vec3d bp = ap - T.ab;
  const double d3 = T.ab.dot(bp), d4 = T.ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) {
    feature = kVertexB;
    return bp.squaredNorm();
  }
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    feature = kEdgeAB;
    return (ap - (d1 / (d1 - d3)) * T.ab).squaredNorm();
  }
  const Vec3d cp = ap - T.ac;
  const double d5 = T.ab.dot(cp), d6 = T.ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) {
    feature = kVertexC;
    return cp.squaredNorm();
  }
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    feature = kEdgeAC;
    return (ap - (d2 / (d2 - d6)) * T.ac).squaredNorm();
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 >= d3 && d5 >= d6) {
    feature = kEdgeBC;
    return (bp - ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (T.ac - T.ab)).squaredNorm();
  }
  const double h = ap.dot(T.n);
  return h * h;
}

// Triangles with their adjacency, on vertices welded by exact position (so
// meshes stored with duplicated vertices are connected too).
struct Surface {
  std::vector<Tri> tris;
  std::vector<std::array<std::uint32_t, 3>> corners;  // welded vertex ids per triangle
  std::vector<std::uint32_t> ringStart, ring;         // triangles around welded vertex v
  std::vector<std::uint32_t> nbrStart, nbr;           // welded vertices joined to v by an edge
  std::vector<Vec3d> nbrDir;                          // unit direction of that edge

  explicit Surface(const TriangleMesh& m) : tris(makeTris(m)), corners(m.triangles) {
    const std::size_t nv = m.vertices.size();
    // weld: the lowest index among vertices at the same position
    std::vector<std::uint32_t> order(nv), weld(nv);
    for (std::size_t v = 0; v < nv; ++v) order[v] = static_cast<std::uint32_t>(v);
    auto less = [&](std::uint32_t x, std::uint32_t y) {
      const Vec3d &a = m.vertices[x], &b = m.vertices[y];
      return std::tie(a.x(), a.y(), a.z(), x) < std::tie(b.x(), b.y(), b.z(), y);
    };
    std::sort(order.begin(), order.end(), less);
    for (std::size_t k = 0; k < nv; ++k) {
      const bool same = k > 0 && m.vertices[order[k]] == m.vertices[order[k - 1]];
      weld[order[k]] = same ? weld[order[k - 1]] : order[k];
    }
    for (auto& c : corners) {
      for (auto& v : c) v = weld[v];
    }
    // triangles around each vertex (CSR, ascending triangle index)
    ringStart.assign(nv + 1, 0);
    for (const auto& c : corners) {
      for (const std::uint32_t v : c) ++ringStart[v + 1];
    }
    for (std::size_t v = 0; v < nv; ++v) ringStart[v + 1] += ringStart[v];
    ring.resize(ringStart.back());
    std::vector<std::uint32_t> fill(ringStart.begin(), ringStart.end() - 1);
    for (std::size_t t = 0; t < corners.size(); ++t) {
      for (const std::uint32_t v : corners[t]) ring[fill[v]++] = static_cast<std::uint32_t>(t);
    }
    // edge neighbours of each vertex, with unit directions
    nbrStart.assign(nv + 1, 0);
    std::vector<std::uint32_t> scratch;
    for (std::size_t v = 0; v < nv; ++v) {
      scratch.clear();
      for (std::uint32_t r = ringStart[v]; r < ringStart[v + 1]; ++r) {
        for (const std::uint32_t u : corners[ring[r]]) {
          if (u != v) scratch.push_back(u);
        }
      }
      std::sort(scratch.begin(), scratch.end());
      scratch.erase(std::unique(scratch.begin(), scratch.end()), scratch.end());
      for (const std::uint32_t u : scratch) {
        const Vec3d e = m.vertices[u] - m.vertices[v];
        if (e.squaredNorm() == 0.0) continue;
        nbr.push_back(u);
        nbrDir.push_back(e.normalized());
      }
      nbrStart[v + 1] = static_cast<std::uint32_t>(nbr.size());
    }
  }
};

bool hasVertex(const std::array<std::uint32_t, 3>& t, std::uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

constexpr int kEdgeEnds[3][2] = {{0, 1}, {0, 2}, {1, 2}};  // kEdgeAB, kEdgeAC, kEdgeBC

// Local descent: while the closest point of triangle t is on an edge or vertex,
// move to a triangle across that edge (for a vertex: across the edge from it
// that points most towards p) if that is strictly closer. Keeps propagated
// candidates at a local minimum of the distance over the surface.
void descend(const Surface& S, const Vec3d& p, std::int32_t& t, double& d2, int& feature) {
  for (int step = 0; step < 64 && feature != kFace; ++step) {
    const auto& tv = S.corners[static_cast<std::size_t>(t)];
    std::uint32_t v = 0, u = 0;
    if (feature <= kVertexC) {
      // the edge from v along which the distance to p falls fastest
      const int corner = feature - kVertexA;
      v = tv[corner];
      const Tri& T = S.tris[static_cast<std::size_t>(t)];
      const Vec3d pv = p - (corner == 0 ? T.a : (corner == 1 ? Vec3d(T.a + T.ab) : Vec3d(T.a + T.ac)));
      double best = 0.0;
      for (std::uint32_t k = S.nbrStart[v]; k < S.nbrStart[v + 1]; ++k) {
        const double slope = pv.dot(S.nbrDir[k]);
        if (slope > best) {
          best = slope;
          u = S.nbr[k];
        }
      }
      if (best <= 0.0) return;  // v is a local minimum
    } else {
      v = tv[kEdgeEnds[feature - kEdgeAB][0]];
      u = tv[kEdgeEnds[feature - kEdgeAB][1]];
    }
    // the closest other triangle on edge (v, u)
    std::int32_t next = -1;
    int nextFeature = kFace;
    double nextD2 = d2;
    for (std::uint32_t r = S.ringStart[v]; r < S.ringStart[v + 1]; ++r) {
      const std::uint32_t cand = S.ring[r];
      if (static_cast<std::int32_t>(cand) == t || !hasVertex(S.corners[cand], u)) continue;
      int f = kFace;
      const double dd = triDist2(p, S.tris[cand], f);
      if (dd < nextD2) {
        nextD2 = dd;
        next = static_cast<std::int32_t>(cand);
        nextFeature = f;
      }
    }
    if (next < 0) return;
    t = next;
    d2 = nextD2;
    feature = nextFeature;
  }
}

// The lowest-numbered triangle with the same closest feature as t when that is
// a vertex or edge at a local minimum (all its triangles are then equally
// close), so that neighbouring cells share ids and skip re-evaluation.
std::int32_t canonical(const Surface& S, std::int32_t t, int feature) {
  if (feature == kFace) return t;
  const auto& tv = S.corners[static_cast<std::size_t>(t)];
  if (feature <= kVertexC) return static_cast<std::int32_t>(S.ring[S.ringStart[tv[feature - kVertexA]]]);
  const std::uint32_t v = tv[kEdgeEnds[feature - kEdgeAB][0]], u = tv[kEdgeEnds[feature - kEdgeAB][1]];
  for (std::uint32_t r = S.ringStart[v]; r < S.ringStart[v + 1]; ++r) {
    if (hasVertex(S.corners[S.ring[r]], u)) return static_cast<std::int32_t>(S.ring[r]);
  }
  return t;
}

// ---------------------------------------------------------------------------
// Grid helpers

struct Range {
  int lo = 0, hi = -1;  // inclusive; empty when lo > hi
};

// Cell positions are clamped in floating point before any conversion to int,
// so bounds of any magnitude (huge, infinite) are safe; NaN gives an empty range.

// cells whose centres lie in [lo, hi] along axis a (possibly empty)
Range centresIn(const GridSpec& s, int a, double lo, double hi) {
  const double last = s.n[a] - 1;
  const double tlo = (lo - s.min[a]) / s.cell[a] - 0.5, thi = (hi - s.min[a]) / s.cell[a] - 0.5;
  Range r;
  if (std::isnan(tlo) || std::isnan(thi)) return r;
  r.lo = std::max(0, static_cast<int>(std::ceil(std::clamp(tlo, -1.0, last + 1.0))));
  r.hi = std::min(s.n[a] - 1, static_cast<int>(std::floor(std::clamp(thi, -1.0, last + 1.0))));
  return r;
}

// as centresIn, but never empty: a box outside the grid maps to the nearest layer
Range centresNear(const GridSpec& s, int a, double lo, double hi) {
  Range r = centresIn(s, a, lo, hi);
  if (r.lo > r.hi) {
    const double mid = (0.5 * lo + 0.5 * hi - s.min[a]) / s.cell[a] - 0.5;  // halves first: no overflow
    const double last = s.n[a] - 1;
    r.lo = r.hi = std::isnan(mid) ? 0 : static_cast<int>(std::clamp(std::round(mid), 0.0, last));
  }
  return r;
}

// ---------------------------------------------------------------------------
// Unsigned distance: exact in a band, then closest-triangle propagation

struct MeshField {
  std::vector<float> d2;            // squared distance to the best triangle found
  std::vector<std::int32_t> tri;    // that triangle, -1 = none yet
  std::vector<std::uint8_t> stamp;  // propagation pass of the last change
};

void seedBand(const Surface& S, const GridSpec& s, MeshField& f) {
  const std::vector<Tri>& tris = S.tris;
  const double band = 1.5 * s.cell.maxCoeff();
  const Vec3d lo = s.center(0, 0, 0), hi = s.center(s.n[0] - 1, s.n[1] - 1, s.n[2] - 1);
  // per triangle: cells of its bounding box grown by the band (clamped to the
  // grid) and the plane-distance limit (grown by the gap to the grid, so that
  // triangles outside still seed the nearest cells)
  struct Seed {
    std::array<Range, 3> r;
    double limit;
  };
  std::vector<Seed> seeds(tris.size());
  for (std::size_t t = 0; t < tris.size(); ++t) {
    const Tri& T = tris[t];
    const Vec3d b = T.a + T.ab, c = T.a + T.ac;
    const Vec3d tmin = T.a.cwiseMin(b).cwiseMin(c), tmax = T.a.cwiseMax(b).cwiseMax(c);
    const Vec3d gap = (lo - tmax).cwiseMax(tmin - hi).cwiseMax(0.0);
    for (int a = 0; a < 3; ++a) seeds[t].r[a] = centresNear(s, a, tmin[a] - band, tmax[a] + band);
    seeds[t].limit = band + gap.norm();
  }
  // one z-plane per body; triangles in index order, so ties keep the lowest index
  forEachPlane(static_cast<std::size_t>(s.n[2]), [&](std::size_t kk) {
    const int k = static_cast<int>(kk);
    for (std::size_t t = 0; t < tris.size(); ++t) {
      const Seed& sd = seeds[t];
      if (k < sd.r[2].lo || k > sd.r[2].hi) continue;
      const Tri& T = tris[t];
      for (int j = sd.r[1].lo; j <= sd.r[1].hi; ++j) {
        const Vec3d row = s.center(0, j, k);
        Range ri = sd.r[0];
        // restrict the row to |plane distance| <= limit: n.x * x + c0
        if (!T.degenerate) {
          const double c0 = T.n.y() * (row.y() - T.a.y()) + T.n.z() * (row.z() - T.a.z()) - T.n.x() * T.a.x();
          if (std::abs(T.n.x()) > 1e-9) {
            double x0 = (-sd.limit - c0) / T.n.x(), x1 = (sd.limit - c0) / T.n.x();
            if (x0 > x1) std::swap(x0, x1);
            const Range rp = centresIn(s, 0, x0, x1);
            ri.lo = std::max(ri.lo, rp.lo);
            ri.hi = std::min(ri.hi, rp.hi);
          } else if (std::abs(c0 + T.n.x() * row.x()) > sd.limit) {
            continue;
          }
        }
        for (int i = ri.lo; i <= ri.hi; ++i) {
          const std::size_t cell = s.index(i, j, k);
          int feature = kFace;
          const double d2 = triDist2(s.center(i, j, k), T, feature);
          if (d2 < f.d2[cell]) {
            f.d2[cell] = static_cast<float>(d2);
            f.tri[cell] = static_cast<std::int32_t>(t);
          }
        }
      }
    }
  });
  // a mesh outside the grid may seed nothing: seed the cell nearest to its
  // first vertex with its nearest triangle
  if (std::all_of(f.tri.begin(), f.tri.end(), [](std::int32_t t) { return t < 0; })) {
    const Vec3d p0 = tris[0].a;
    const auto c = s.cellOf(p0);
    const Vec3d p = s.center(c[0], c[1], c[2]);
    const std::size_t cell = s.index(c[0], c[1], c[2]);
    for (std::size_t t = 0; t < tris.size(); ++t) {
      int feature = kFace;
      const double d2 = triDist2(p, tris[t], feature);
      if (d2 < f.d2[cell]) {
        f.d2[cell] = static_cast<float>(d2);
        f.tri[cell] = static_cast<std::int32_t>(t);
      }
    }
  }
}

// One propagation pass: cell c tries the triangle of its line
// neighbour nb; an improvement is refined by descent and stamped with the pass.
// A pair already compared in pass `seen` (same direction, previous round) is
// skipped when nb has not changed since.
struct Relax {
  const Surface& S;
  const GridSpec& s;
  MeshField& f;
  int pass, seen;

  // cell c = (i, j, k), neighbour nb
  void operator()(std::size_t c, std::size_t nb, int i, int j, int k) const {
    std::int32_t t = f.tri[nb];
    if (t < 0 || t == f.tri[c] || f.stamp[nb] <= seen) return;
    const Vec3d p = s.center(i, j, k);
    int feature = kFace;
    double d2 = triDist2(p, S.tris[static_cast<std::size_t>(t)], feature);
    if (!(d2 < f.d2[c])) return;
    descend(S, p, t, d2, feature);
    f.d2[c] = static_cast<float>(d2);
    f.tri[c] = canonical(S, t, feature);
    f.stamp[c] = static_cast<std::uint8_t>(pass);
  }
};

// Two rounds of forward and backward passes along x, y and z lines.
void propagate(const Surface& S, const GridSpec& s, MeshField& f) {
  const int nx = s.n[0], ny = s.n[1], nz = s.n[2];
  const std::size_t sy = static_cast<std::size_t>(nx), sz = static_cast<std::size_t>(nx) * ny;
  std::fill(f.stamp.begin(), f.stamp.end(), std::uint8_t{0});
  for (int round = 0; round < 2; ++round) {
    auto relax = [&](int dir) { return Relax{S, s, f, 6 * round + dir, round == 0 ? -1 : 6 * (round - 1) + dir}; };
    // x lines, one per body
    const Relax xf = relax(0), xb = relax(1);
    parallelForDynamic(static_cast<std::size_t>(ny) * nz, 16, [&](std::size_t line) {
      const int j = static_cast<int>(line % ny), k = static_cast<int>(line / ny);
      const std::size_t base = s.index(0, j, k);
      for (int i = 1; i < nx; ++i) xf(base + i, base + i - 1, i, j, k);
      for (int i = nx - 2; i >= 0; --i) xb(base + i, base + i + 1, i, j, k);
    });
    // y lines, one z-plane per body
    const Relax yf = relax(2), yb = relax(3);
    forEachPlane(static_cast<std::size_t>(nz), [&](std::size_t kk) {
      const int k = static_cast<int>(kk);
      for (int j = 1; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) yf(s.index(i, j, k), s.index(i, j, k) - sy, i, j, k);
      }
      for (int j = ny - 2; j >= 0; --j) {
        for (int i = 0; i < nx; ++i) yb(s.index(i, j, k), s.index(i, j, k) + sy, i, j, k);
      }
    });
    // z lines, one y-slab per body
    const Relax zf = relax(4), zb = relax(5);
    forEachPlane(static_cast<std::size_t>(ny), [&](std::size_t jj) {
      const int j = static_cast<int>(jj);
      for (int k = 1; k < nz; ++k) {
        for (int i = 0; i < nx; ++i) zf(s.index(i, j, k), s.index(i, j, k) - sz, i, j, k);
      }
      for (int k = nz - 2; k >= 0; --k) {
        for (int i = 0; i < nx; ++i) zb(s.index(i, j, k), s.index(i, j, k) + sz, i, j, k);
      }
    });
  }
}

// Unsigned distance to the triangles of S at the cells of spec.
MeshField unsignedField(const Surface& S, const GridSpec& spec) {
  MeshField f;
  f.d2.assign(spec.size(), std::numeric_limits<float>::infinity());
  f.tri.assign(spec.size(), -1);
  f.stamp.assign(spec.size(), 0);
  seedBand(S, spec, f);
  propagate(S, spec, f);
  f.stamp = {};
  return f;
}

// ---------------------------------------------------------------------------
// Sign: crossing parity along grid lines, exact in integer coordinates

// a box of cells: lo[a] .. lo[a] + n[a] - 1
struct Block {
  std::array<int, 3> lo{}, n{};
  bool empty() const { return n[0] <= 0 || n[1] <= 0 || n[2] <= 0; }
  std::size_t size() const { return empty() ? 0 : static_cast<std::size_t>(n[0]) * n[1] * n[2]; }
  std::size_t local(int i, int j, int k) const {
    return (static_cast<std::size_t>(k - lo[2]) * n[1] + (j - lo[1])) * n[0] + (i - lo[0]);
  }
  // the cells of the block as a grid of their own (same centres)
  GridSpec spec(const GridSpec& g) const {
    GridSpec s = g;
    s.n = n;
    for (int a = 0; a < 3; ++a) s.min[a] = g.min[a] + lo[a] * g.cell[a];
    return s;
  }
};

// the cells whose centres lie in box (only they can be inside a mesh bounded by it)
Block blockOf(const Eigen::AlignedBox3d& box, const GridSpec& s) {
  Block b;
  for (int a = 0; a < 3; ++a) {
    const Range r = centresIn(s, a, box.min()[a], box.max()[a]);
    b.lo[a] = r.lo;
    b.n[a] = r.hi - r.lo + 1;
  }
  return b;
}

using Lattice = std::array<std::int64_t, 3>;

// 2-D orientation of (b - a) x (q - a) in the (m, o) coordinates; exact (|coords| < 2^28)
inline std::int64_t orient(const Lattice& a, const Lattice& b, std::int64_t qm, std::int64_t qo, int m, int o) {
  return (b[m] - a[m]) * (qo - a[o]) - (b[o] - a[o]) * (qm - a[m]);
}

// does a point on the (counter-clockwise) edge with direction (dm, dO) count as
// inside? Equivalent to testing the point moved by an infinitesimal (1, eps)
// in (m, o), so edges and vertices shared by a fan of triangles count once.
inline bool ownsEdge(std::int64_t dm, std::int64_t dO) { return dO < 0 || (dO == 0 && dm > 0); }

// Inside/outside votes (-6..6, see the header) of the cells of block b for one mesh.
std::vector<std::int8_t> voteSigns(const TriangleMesh& mesh, const GridSpec& s, const Block& b) {
  // lattice: about 2^-28 of the extent of grid and mesh together, centred
  Eigen::AlignedBox3d box = mesh.bounds();
  box.extend(s.min);
  box.extend(s.max());
  // centre and half extent from halves, finite for any finite coordinates
  const Vec3d origin = 0.5 * box.min() + 0.5 * box.max();
  const double halfExtent = (0.5 * box.max() - 0.5 * box.min()).maxCoeff();
  const double unit = halfExtent > 0.0 ? std::ldexp(halfExtent, -27) : 1.0;
  // |(x - origin) / unit| <= 2^27 inside the box; the clamp only guards the conversion
  auto snap = [&](double x, int a) {
    const double q = std::clamp((x - origin[a]) / unit, -0x1p29, 0x1p29);
    return static_cast<std::int64_t>(std::llround(std::isnan(q) ? 0.0 : q));
  };
  std::vector<Lattice> verts(mesh.vertices.size());
  for (std::size_t v = 0; v < verts.size(); ++v) {
    for (int a = 0; a < 3; ++a) verts[v][a] = snap(mesh.vertices[v][a], a);
  }
  std::array<std::vector<std::int64_t>, 3> centres;  // snapped cell-centre coordinates of the block per axis
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < b.n[a]; ++i) centres[a].push_back(snap(s.min[a] + (b.lo[a] + i + 0.5) * s.cell[a], a));
  }
  // block cells whose snapped centre lies in [lo, hi] along axis a
  auto latticeRange = [&](int a, std::int64_t lo, std::int64_t hi) {
    const auto& c = centres[a];
    Range r;
    r.lo = static_cast<int>(std::lower_bound(c.begin(), c.end(), lo) - c.begin());
    r.hi = static_cast<int>(std::upper_bound(c.begin(), c.end(), hi) - c.begin()) - 1;
    return r;
  };

  std::vector<std::int8_t> votes(b.size(), 0);
  for (int axis = 0; axis < 3; ++axis) {
    // lines along `axis` at (m, o) positions; bodies take one o-plane each
    const int m = axis == 0 ? 1 : 0, o = axis == 2 ? 1 : 2;
    struct Proj {
      Range rm, ro;
      int sign;  // of the projected area; 0 = edge-on, skipped
    };
    std::vector<Proj> proj(mesh.triangles.size());
    for (std::size_t t = 0; t < proj.size(); ++t) {
      const auto& idx = mesh.triangles[t];
      const Lattice &A = verts[idx[0]], &B = verts[idx[1]], &C = verts[idx[2]];
      const std::int64_t area = orient(A, B, C[m], C[o], m, o);
      proj[t].sign = area > 0 ? 1 : (area < 0 ? -1 : 0);
      proj[t].rm = latticeRange(m, std::min({A[m], B[m], C[m]}), std::max({A[m], B[m], C[m]}));
      proj[t].ro = latticeRange(o, std::min({A[o], B[o], C[o]}), std::max({A[o], B[o], C[o]}));
    }
    forEachPlane(static_cast<std::size_t>(b.n[o]), [&](std::size_t qq) {
      const int q = static_cast<int>(qq);
      const std::int64_t qo = centres[o][q];
      std::vector<std::pair<int, double>> hits;  // (line index along m, crossing coordinate along axis)
      for (std::size_t t = 0; t < proj.size(); ++t) {
        const Proj& P = proj[t];
        if (P.sign == 0 || q < P.ro.lo || q > P.ro.hi) continue;
        const auto& idx = mesh.triangles[t];
        const Lattice* v[3] = {&verts[idx[0]], &verts[idx[1]], &verts[idx[2]]};
        for (int r = P.rm.lo; r <= P.rm.hi; ++r) {
          const std::int64_t qm = centres[m][r];
          // edge functions of the counter-clockwise (normalised) triangle; e[k] is opposite vertex k
          std::int64_t e[3];
          bool inside = true;
          for (int k = 0; k < 3 && inside; ++k) {
            const Lattice& ea = *v[(k + 1) % 3];
            const Lattice& eb = *v[(k + 2) % 3];
            e[k] = P.sign * orient(ea, eb, qm, qo, m, o);
            inside = e[k] > 0 || (e[k] == 0 && ownsEdge(P.sign * (eb[m] - ea[m]), P.sign * (eb[o] - ea[o])));
          }
          if (!inside) continue;
          // crossing point: barycentric weights from the edge functions
          const double w0 = static_cast<double>(e[0]), w1 = static_cast<double>(e[1]), w2 = static_cast<double>(e[2]);
          const double x =
              (w0 * mesh.vertices[idx[0]][axis] + w1 * mesh.vertices[idx[1]][axis] + w2 * mesh.vertices[idx[2]][axis]) /
              (w0 + w1 + w2);
          hits.emplace_back(r, x);
        }
      }
      std::sort(hits.begin(), hits.end());
      // walk each line: parity of the crossings before and after every cell
      std::size_t h = 0;
      for (int r = 0; r < b.n[m]; ++r) {
        const std::size_t begin = h;
        while (h < hits.size() && hits[h].first == r) ++h;
        const std::size_t total = h - begin;
        std::size_t before = begin, upTo = begin;  // first hit >= x, first hit > x
        std::array<int, 3> c{};
        c[m] = b.lo[m] + r;
        c[o] = b.lo[o] + q;
        for (int i = 0; i < b.n[axis]; ++i) {
          c[axis] = b.lo[axis] + i;
          const double x = s.min[axis] + (c[axis] + 0.5) * s.cell[axis];
          while (before < h && hits[before].second < x) ++before;
          while (upTo < h && hits[upTo].second <= x) ++upTo;
          const bool insideFromStart = (before - begin) % 2 == 1;
          const bool insideFromEnd = (total - (upTo - begin)) % 2 == 1;
          votes[b.local(c[0], c[1], c[2])] +=
              static_cast<std::int8_t>((insideFromStart ? 1 : -1) + (insideFromEnd ? 1 : -1));
        }
      }
    });
  }
  return votes;
}

// ---------------------------------------------------------------------------
// All meshes together

// the meshes as one triangle set; meshOf[t] names the mesh of triangle t
struct MergedMeshes {
  TriangleMesh all;
  std::vector<std::uint32_t> meshOf, firstTri;

  explicit MergedMeshes(const std::vector<TriangleMesh>& meshes) {
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      const TriangleMesh& mesh = meshes[m];
      const auto offset = static_cast<std::uint32_t>(all.vertices.size());
      firstTri.push_back(static_cast<std::uint32_t>(all.triangles.size()));
      for (const auto& t : mesh.triangles) {
        if (std::max({t[0], t[1], t[2]}) >= mesh.vertices.size()) {
          throw std::invalid_argument("signedDistance: mesh " + mesh.source + " has a vertex index out of range");
        }
        all.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
        meshOf.push_back(static_cast<std::uint32_t>(m));
      }
      all.vertices.insert(all.vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
    }
    firstTri.push_back(static_cast<std::uint32_t>(all.triangles.size()));
  }
};

// Signed distance to the union of the meshes, min'ed into out. One unsigned
// field for all triangles gives every cell outside all meshes, and every cell
// inside one mesh whose nearest triangle is that mesh's; the others (inside
// one mesh but nearer another, or inside several) get minus the largest of
// their containing meshes' own distances, from a field of that mesh alone
// over its bounding block.
void addMeshes(const std::vector<TriangleMesh>& meshes, const GridSpec& s, std::vector<float>& out) {
  const MergedMeshes merged(meshes);
  if (merged.all.triangles.empty()) return;
  const Surface S(merged.all);
  const MeshField f = unsignedField(S, s);
  const std::size_t nm = meshes.size();
  auto meshOfCell = [&](std::size_t c) {
    return static_cast<std::int32_t>(merged.meshOf[static_cast<std::size_t>(f.tri[c])]);
  };

  // inside tests, mesh by mesh over its block: container = -1 none, m, or -2 several
  std::vector<std::int32_t> container(s.size(), -1);
  std::vector<Block> blocks(nm);
  std::vector<std::vector<std::uint8_t>> inside(nm);
  for (std::size_t m = 0; m < nm; ++m) {
    if (meshes[m].triangles.empty()) continue;
    const Block b = blocks[m] = blockOf(meshes[m].bounds(), s);
    if (b.empty()) continue;
    const std::vector<std::int8_t> votes = voteSigns(meshes[m], s, b);
    inside[m].assign(b.size(), 0);
    const auto mi = static_cast<std::int32_t>(m);
    forEachPlane(static_cast<std::size_t>(b.n[2]), [&](std::size_t kk) {
      const int k = b.lo[2] + static_cast<int>(kk);
      for (int j = b.lo[1]; j < b.lo[1] + b.n[1]; ++j) {
        for (int i = b.lo[0]; i < b.lo[0] + b.n[0]; ++i) {
          const std::size_t l = b.local(i, j, k), c = s.index(i, j, k);
          bool in = votes[l] > 0;
          if (votes[l] == 0) {  // tie: side of the plane of this mesh's nearest triangle
            std::size_t t = static_cast<std::size_t>(f.tri[c]);
            if (meshOfCell(c) != mi) {
              double best = std::numeric_limits<double>::infinity();
              for (std::size_t u = merged.firstTri[m]; u < merged.firstTri[m + 1]; ++u) {
                int feature = kFace;
                const double d2 = triDist2(s.center(i, j, k), S.tris[u], feature);
                if (d2 < best) {
                  best = d2;
                  t = u;
                }
              }
            }
            in = (s.center(i, j, k) - S.tris[t].a).dot(S.tris[t].n) < 0.0;
          }
          inside[m][l] = in ? 1 : 0;
          if (in) container[c] = container[c] == -1 ? mi : -2;
        }
      }
    });
  }

  // depth of the cells that need their containing meshes' own distances
  std::vector<float> depth;
  for (std::size_t m = 0; m < nm; ++m) {
    const Block& b = blocks[m];
    if (inside[m].empty()) continue;
    const auto mi = static_cast<std::int32_t>(m);
    auto needs = [&](int i, int j, int k) {
      const std::size_t c = s.index(i, j, k);
      return inside[m][b.local(i, j, k)] != 0 && (container[c] == -2 || meshOfCell(c) != mi);
    };
    bool any = false;
    for (int k = b.lo[2]; k < b.lo[2] + b.n[2] && !any; ++k) {
      for (int j = b.lo[1]; j < b.lo[1] + b.n[1] && !any; ++j) {
        for (int i = b.lo[0]; i < b.lo[0] + b.n[0] && !any; ++i) any = needs(i, j, k);
      }
    }
    if (!any) continue;
    if (depth.empty()) depth.assign(s.size(), 0.0f);
    const MeshField own = unsignedField(Surface(meshes[m]), b.spec(s));
    forEachPlane(static_cast<std::size_t>(b.n[2]), [&](std::size_t kk) {
      const int k = b.lo[2] + static_cast<int>(kk);
      for (int j = b.lo[1]; j < b.lo[1] + b.n[1]; ++j) {
        for (int i = b.lo[0]; i < b.lo[0] + b.n[0]; ++i) {
          if (!needs(i, j, k)) continue;
          float& d = depth[s.index(i, j, k)];
          d = std::max(d, std::sqrt(own.d2[b.local(i, j, k)]));
        }
      }
    });
  }

  // signed values
  forEachPlane(static_cast<std::size_t>(s.n[2]), [&](std::size_t kk) {
    const int k = static_cast<int>(kk);
    for (int j = 0; j < s.n[1]; ++j) {
      for (int i = 0; i < s.n[0]; ++i) {
        const std::size_t c = s.index(i, j, k);
        const std::int32_t box = container[c];
        const float d = std::sqrt(f.d2[c]);
        const float v = box == -1 ? d : (box >= 0 && meshOfCell(c) == box ? -d : -depth[c]);
        out[c] = std::min(out[c], v);
      }
    }
  });
}

}  // namespace

Grid3<float> signedDistance(const Obstacles& obstacles, const GridSpec& spec) {
  for (int a = 0; a < 3; ++a) {
    if (spec.n[a] < 1 || !(spec.cell[a] > 0.0) || !std::isfinite(spec.cell[a]) || !std::isfinite(spec.min[a])) {
      throw std::invalid_argument("signedDistance: invalid grid");
    }
  }
  Grid3<float> g(spec, kSdfFar);
  // analytic obstacles, exact
  if (!obstacles.spheres.empty() || !obstacles.boxes.empty()) {
    forEachPlane(static_cast<std::size_t>(spec.n[2]), [&](std::size_t kk) {
      const int k = static_cast<int>(kk);
      for (int j = 0; j < spec.n[1]; ++j) {
        for (int i = 0; i < spec.n[0]; ++i) {
          const Vec3d p = spec.center(i, j, k);
          double d = kSdfFar;
          for (const SphereObstacle& sp : obstacles.spheres) d = std::min(d, sphereSignedDistance(sp, p));
          for (const BoxObstacle& b : obstacles.boxes) d = std::min(d, boxSignedDistance(b, p));
          g.at(i, j, k) = static_cast<float>(d);
        }
      }
    });
  }
  if (!obstacles.meshes.empty()) addMeshes(obstacles.meshes, spec, g.data);
  return g;
}

Vec3 normalAt(const Grid3<float>& sdf, const Vec3& p) {
  Vec3 grad;
  for (int a = 0; a < 3; ++a) {
    const float h = 0.5f * static_cast<float>(sdf.spec.cell[a]);
    Vec3 lo = p, hi = p;
    lo[a] -= h;
    hi[a] += h;
    grad[a] = (sdf.sample(hi) - sdf.sample(lo)) / (2.0f * h);
  }
  return normalizedOrZero(grad);
}

void addBoxWalls(Grid3<float>& distance, const Aabb& box) {
  parallelFor(distance.data.size(), [&](std::size_t c) {
    const Vec3d p = distance.spec.centerOfIndex(c);
    const double wall = std::min((p - box.min).minCoeff(), (box.max - p).minCoeff());
    distance.data[c] = std::min(distance.data[c], static_cast<float>(wall));
  });
}

}  // namespace swarmsim
