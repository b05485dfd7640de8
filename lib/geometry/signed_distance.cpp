#include <chrono>
#include <cstdio>
#include <cstdlib>
#include "geometry/signed_distance.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/parallel.hpp"

namespace swarmsim {

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
long gEvals = 0, gRelax = 0, gSame = 0, gImprove = 0;
double triDist2(const Vec3d& p, const Tri& T, int& feature) {
  ++gEvals;
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

// triangles with their vertex-to-triangle adjacency
struct Surface {
  const TriangleMesh* mesh = nullptr;
  std::vector<Tri> tris;
  std::vector<std::uint32_t> ringStart, ring;  // triangles around vertex v: ring[ringStart[v], ringStart[v+1])

  explicit Surface(const TriangleMesh& m) : mesh(&m), tris(makeTris(m)) {
    ringStart.assign(m.vertices.size() + 1, 0);
    for (const auto& t : m.triangles) {
      for (const std::uint32_t v : t) ++ringStart[v + 1];
    }
    for (std::size_t v = 0; v < m.vertices.size(); ++v) ringStart[v + 1] += ringStart[v];
    ring.resize(ringStart.back());
    std::vector<std::uint32_t> fill(ringStart.begin(), ringStart.end() - 1);
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      for (const std::uint32_t v : m.triangles[t]) ring[fill[v]++] = static_cast<std::uint32_t>(t);
    }
  }
};

bool hasVertex(const std::array<std::uint32_t, 3>& t, std::uint32_t v) { return t[0] == v || t[1] == v || t[2] == v; }

// Local descent: while the closest point of triangle t is on an edge or vertex,
// move to a triangle across that edge (for a vertex: across the edge from it
// that points most towards p) if that is strictly closer. Keeps propagated
// candidates at a local minimum of the distance over the surface.
void descend(const Surface& S, const Vec3d& p, std::int32_t& t, double& d2, int& feature) {
  const auto& tris = S.mesh->triangles;
  const auto& verts = S.mesh->vertices;
  for (int step = 0; step < 64 && feature != kFace; ++step) {
    const auto& tv = tris[static_cast<std::size_t>(t)];
    std::uint32_t v = 0, u = 0;
    if (feature <= kVertexC) {
      // the edge from v with the steepest descent of the distance to p
      v = tv[feature - kVertexA];
      const Vec3d pv = p - verts[v];
      double best = 0.0;
      bool found = false;
      for (std::uint32_t r = S.ringStart[v]; r < S.ringStart[v + 1]; ++r) {
        for (const std::uint32_t w : tris[S.ring[r]]) {
          if (w == v) continue;
          const Vec3d e = verts[w] - verts[v];
          const double dot = pv.dot(e), len2 = e.squaredNorm();
          if (dot > 0.0 && len2 > 0.0 && dot * dot > best * len2) {  // dot / |e| largest
            best = dot * dot / len2;
            u = w;
            found = true;
          }
        }
      }
      if (!found) return;
    } else {
      static constexpr int kEnds[3][2] = {{0, 1}, {0, 2}, {1, 2}};
      v = tv[kEnds[feature - kEdgeAB][0]];
      u = tv[kEnds[feature - kEdgeAB][1]];
    }
    // the closest other triangle on edge (v, u)
    std::int32_t next = -1;
    int nextFeature = kFace;
    double nextD2 = d2;
    for (std::uint32_t r = S.ringStart[v]; r < S.ringStart[v + 1]; ++r) {
      const std::uint32_t cand = S.ring[r];
      if (static_cast<std::int32_t>(cand) == t || !hasVertex(tris[cand], u)) continue;
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
  const auto& tv = S.mesh->triangles[static_cast<std::size_t>(t)];
  if (feature <= kVertexC) return static_cast<std::int32_t>(S.ring[S.ringStart[tv[feature - kVertexA]]]);
  static constexpr int kEnds[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const std::uint32_t v = tv[kEnds[feature - kEdgeAB][0]], u = tv[kEnds[feature - kEdgeAB][1]];
  for (std::uint32_t r = S.ringStart[v]; r < S.ringStart[v + 1]; ++r) {
    if (hasVertex(S.mesh->triangles[S.ring[r]], u)) return static_cast<std::int32_t>(S.ring[r]);
  }
  return t;
}

// ---------------------------------------------------------------------------
// Grid helpers

struct Range {
  int lo = 0, hi = -1;  // inclusive; empty when lo > hi
};

// cells whose centres lie in [lo, hi] along axis a (possibly empty)
Range centresIn(const GridSpec& s, int a, double lo, double hi) {
  const double last = s.n[a] - 1;
  const double flo = std::clamp((lo - s.min[a]) / s.cell[a] - 0.5, -1.0, last + 1.0);
  const double fhi = std::clamp((hi - s.min[a]) / s.cell[a] - 0.5, -1.0, last + 1.0);
  Range r;
  r.lo = std::max(0, static_cast<int>(std::ceil(flo)));
  r.hi = std::min(s.n[a] - 1, static_cast<int>(std::floor(fhi)));
  return r;
}

// as centresIn, but never empty: a box outside the grid maps to the nearest layer
Range centresNear(const GridSpec& s, int a, double lo, double hi) {
  Range r = centresIn(s, a, lo, hi);
  if (r.lo > r.hi) {
    const double mid = (0.5 * (lo + hi) - s.min[a]) / s.cell[a] - 0.5;
    r.lo = r.hi = static_cast<int>(std::clamp(std::round(mid), 0.0, static_cast<double>(s.n[a] - 1)));
  }
  return r;
}

// ---------------------------------------------------------------------------
// Unsigned distance: exact in a band, then closest-triangle propagation

struct MeshField {
  std::vector<float> d2;          // squared distance to the best triangle found
  std::vector<std::int32_t> tri;  // that triangle, -1 = none yet
  std::vector<std::int8_t> votes;
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
  parallelForDynamic(static_cast<std::size_t>(s.n[2]), 1, [&](std::size_t kk) {
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
}

// cell c (centre p) tries the triangle of its neighbour nb
inline void relax(const Surface& S, MeshField& f, std::size_t c, std::size_t nb, const Vec3d& p) {
  std::int32_t t = f.tri[nb];
  ++gRelax;
  if (t < 0 || t == f.tri[c]) { ++gSame; return; }
  int feature = kFace;
  double d2 = triDist2(p, S.tris[static_cast<std::size_t>(t)], feature);
  if (!(d2 < f.d2[c])) return;
  ++gImprove;
  descend(S, p, t, d2, feature);
  f.d2[c] = static_cast<float>(d2);
  f.tri[c] = canonical(S, t, feature);
}

void propagate(const Surface& tris, const GridSpec& s, MeshField& f) {
  const int nx = s.n[0], ny = s.n[1], nz = s.n[2];
  const std::size_t sy = static_cast<std::size_t>(nx), sz = static_cast<std::size_t>(nx) * ny;
  static const int kRounds = getenv("SDF_ROUNDS") ? atoi(getenv("SDF_ROUNDS")) : 2;
  for (int round = 0; round < kRounds; ++round) {
    // x lines, one per body
    parallelFor(static_cast<std::size_t>(ny) * nz, [&](std::size_t line) {
      const int j = static_cast<int>(line % ny), k = static_cast<int>(line / ny);
      const std::size_t base = s.index(0, j, k);
      for (int i = 1; i < nx; ++i) relax(tris, f, base + i, base + i - 1, s.center(i, j, k));
      for (int i = nx - 2; i >= 0; --i) relax(tris, f, base + i, base + i + 1, s.center(i, j, k));
    });
    // y lines, one z-plane per body
    parallelFor(static_cast<std::size_t>(nz), [&](std::size_t kk) {
      const int k = static_cast<int>(kk);
      for (int j = 1; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) relax(tris, f, s.index(i, j, k), s.index(i, j, k) - sy, s.center(i, j, k));
      }
      for (int j = ny - 2; j >= 0; --j) {
        for (int i = 0; i < nx; ++i) relax(tris, f, s.index(i, j, k), s.index(i, j, k) + sy, s.center(i, j, k));
      }
    });
    // z lines, one y-slab per body
    parallelFor(static_cast<std::size_t>(ny), [&](std::size_t jj) {
      const int j = static_cast<int>(jj);
      for (int k = 1; k < nz; ++k) {
        for (int i = 0; i < nx; ++i) relax(tris, f, s.index(i, j, k), s.index(i, j, k) - sz, s.center(i, j, k));
      }
      for (int k = nz - 2; k >= 0; --k) {
        for (int i = 0; i < nx; ++i) relax(tris, f, s.index(i, j, k), s.index(i, j, k) + sz, s.center(i, j, k));
      }
    });
  }
}

// ---------------------------------------------------------------------------
// Sign: crossing parity along grid lines, exact in integer coordinates

using Lattice = std::array<std::int64_t, 3>;

// 2-D orientation of (b - a) x (q - a) in the (m, o) coordinates; exact (|coords| < 2^28)
inline std::int64_t orient(const Lattice& a, const Lattice& b, std::int64_t qm, std::int64_t qo, int m, int o) {
  return (b[m] - a[m]) * (qo - a[o]) - (b[o] - a[o]) * (qm - a[m]);
}

// does a point on the (counter-clockwise) edge with direction (dm, do) count as
// inside? Equivalent to testing the point moved by an infinitesimal (1, eps).
inline bool ownsEdge(std::int64_t dm, std::int64_t dO) { return dO < 0 || (dO == 0 && dm > 0); }

void voteSigns(const TriangleMesh& mesh, const GridSpec& s, MeshField& f) {
  // lattice: about 2^-28 of the extent of grid and mesh together, centred
  Eigen::AlignedBox3d box = mesh.bounds();
  box.extend(s.min);
  box.extend(s.max());
  const Vec3d origin = box.center();
  const double extent = box.sizes().maxCoeff();
  const double unit = extent > 0.0 ? extent / double(1 << 28) : 1.0;
  auto snap = [&](double x, int a) { return static_cast<std::int64_t>(std::llround((x - origin[a]) / unit)); };
  std::vector<Lattice> verts(mesh.vertices.size());
  for (std::size_t v = 0; v < verts.size(); ++v) {
    for (int a = 0; a < 3; ++a) verts[v][a] = snap(mesh.vertices[v][a], a);
  }
  std::array<std::vector<std::int64_t>, 3> centres;  // snapped cell-centre coordinates per axis
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < s.n[a]; ++i) centres[a].push_back(snap(s.min[a] + (i + 0.5) * s.cell[a], a));
  }
  // cells whose snapped centre lies in [lo, hi] along axis a
  auto latticeRange = [&](int a, std::int64_t lo, std::int64_t hi) {
    const auto& c = centres[a];
    Range r;
    r.lo = static_cast<int>(std::lower_bound(c.begin(), c.end(), lo) - c.begin());
    r.hi = static_cast<int>(std::upper_bound(c.begin(), c.end(), hi) - c.begin()) - 1;
    return r;
  };

  std::fill(f.votes.begin(), f.votes.end(), std::int8_t{0});
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
    parallelForDynamic(static_cast<std::size_t>(s.n[o]), 1, [&](std::size_t qq) {
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
            const Lattice& a = *v[(k + 1) % 3];
            const Lattice& b = *v[(k + 2) % 3];
            e[k] = P.sign * orient(a, b, qm, qo, m, o);
            inside = e[k] > 0 || (e[k] == 0 && ownsEdge(P.sign * (b[m] - a[m]), P.sign * (b[o] - a[o])));
          }
          if (!inside) continue;
          // crossing point: barycentric weights from the edge functions
          const double w0 = double(e[0]), w1 = double(e[1]), w2 = double(e[2]);
          const double x = (w0 * mesh.vertices[idx[0]][axis] + w1 * mesh.vertices[idx[1]][axis] +
                            w2 * mesh.vertices[idx[2]][axis]) /
                           (w0 + w1 + w2);
          hits.emplace_back(r, x);
        }
      }
      std::sort(hits.begin(), hits.end());
      // walk each line: parity of crossings before and after every cell
      std::size_t h = 0;
      for (int r = 0; r < s.n[m]; ++r) {
        const std::size_t begin = h;
        while (h < hits.size() && hits[h].first == r) ++h;
        const std::size_t total = h - begin;
        std::size_t before = begin, upTo = begin;  // first hit >= x, first hit > x
        std::array<int, 3> c{};
        c[m] = r;
        c[o] = q;
        for (int i = 0; i < s.n[axis]; ++i) {
          c[axis] = i;
          const double x = s.min[axis] + (i + 0.5) * s.cell[axis];
          while (before < h && hits[before].second < x) ++before;
          while (upTo < h && hits[upTo].second <= x) ++upTo;
          const bool insideFromStart = (before - begin) % 2 == 1;
          const bool insideFromEnd = (total - (upTo - begin)) % 2 == 1;
          f.votes[s.index(c[0], c[1], c[2])] += static_cast<std::int8_t>((insideFromStart ? 1 : -1) + (insideFromEnd ? 1 : -1));
        }
      }
    });
  }
}

// min of the mesh's signed distance into out
void addMesh(const TriangleMesh& mesh, const GridSpec& s, MeshField& f, std::vector<float>& out) {
  for (const auto& t : mesh.triangles) {
    if (std::max({t[0], t[1], t[2]}) >= mesh.vertices.size()) {
      throw std::invalid_argument("signedDistance: mesh " + mesh.source + " has a vertex index out of range");
    }
  }
  const Surface S(mesh);
  const std::vector<Tri>& tris = S.tris;
  std::fill(f.d2.begin(), f.d2.end(), std::numeric_limits<float>::infinity());
  std::fill(f.tri.begin(), f.tri.end(), -1);
  auto T0 = std::chrono::steady_clock::now();
  seedBand(S, s, f);
  auto T1 = std::chrono::steady_clock::now();
  if (getenv("SDF_TIMING")) fprintf(stderr, "seed evals %ld\n", gEvals); gEvals = 0;
  propagate(S, s, f);
  auto T2 = std::chrono::steady_clock::now();
  if (getenv("SDF_TIMING")) fprintf(stderr, "prop evals %ld relax %ld same %ld improve %ld\n", gEvals, gRelax, gSame, gImprove); gEvals = gRelax = gSame = gImprove = 0;
  voteSigns(mesh, s, f);
  auto T3 = std::chrono::steady_clock::now();
  if (getenv("SDF_TIMING")) fprintf(stderr, "seed %.1f prop %.1f sign %.1f\n", std::chrono::duration<double,std::milli>(T1-T0).count(), std::chrono::duration<double,std::milli>(T2-T1).count(), std::chrono::duration<double,std::milli>(T3-T2).count());
  parallelFor(static_cast<std::size_t>(s.n[2]), [&](std::size_t kk) {
    const int k = static_cast<int>(kk);
    for (int j = 0; j < s.n[1]; ++j) {
      for (int i = 0; i < s.n[0]; ++i) {
        const std::size_t c = s.index(i, j, k);
        bool inside = f.votes[c] > 0;
        if (f.votes[c] == 0) {  // tie: side of the nearest triangle's plane
          const Tri& T = tris[static_cast<std::size_t>(f.tri[c])];
          inside = (s.center(i, j, k) - T.a).dot(T.n) < 0.0;
        }
        const float d = std::sqrt(f.d2[c]);
        out[c] = std::min(out[c], inside ? -d : d);
      }
    }
  });
}

}  // namespace

Grid3<float> signedDistance(const Obstacles& obstacles, const GridSpec& spec) {
  Grid3<float> g(spec, kSdfFar);
  if (g.data.empty()) return g;
  // analytic obstacles, exact
  if (!obstacles.spheres.empty() || !obstacles.boxes.empty()) {
    parallelFor(static_cast<std::size_t>(spec.n[2]), [&](std::size_t kk) {
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
  // meshes, one at a time (scratch reused)
  MeshField f;
  for (const TriangleMesh& mesh : obstacles.meshes) {
    if (mesh.triangles.empty()) continue;
    if (f.d2.empty()) {
      f.d2.resize(spec.size());
      f.tri.resize(spec.size());
      f.votes.resize(spec.size());
    }
    addMesh(mesh, spec, f, g.data);
  }
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

}  // namespace swarmsim
