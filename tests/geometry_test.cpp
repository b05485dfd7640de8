// Geometry: OBJ loading (placement, errors with file and line), watertightness,
// and signed distance fields against analytic shapes and brute force.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "brute_distance.hpp"
#include "core/error.hpp"
#include "core/parallel.hpp"
#include "geometry/clearance.hpp"
#include "geometry/mesh.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "test_util.hpp"

using Catch::Matchers::Contains;
using swarmsim::BoxObstacle;
using swarmsim::Grid3;
using swarmsim::GridSpec;
using swarmsim::InputError;
using swarmsim::MeshTransform;
using swarmsim::Obstacles;
using swarmsim::SphereObstacle;
using swarmsim::TriangleMesh;
using swarmsim::Vec3;
using swarmsim::Vec3d;
using swarmsim_test::TempDir;
using swarmsim_test::bruteDistance;

namespace {

// a cube [-1, 1]^3 with quad faces, outward counter-clockwise
const char* const kCubeObj = R"(# unit cube
o cube
v -1 -1 -1
v  1 -1 -1
v  1  1 -1
v -1  1 -1
v -1 -1  1
v  1 -1  1
v  1  1  1
v -1  1  1
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
)";

// the message of the InputError loadObj throws (fails if it throws nothing or something else)
std::string loadError(const std::string& path) {
  try {
    swarmsim::loadObj(path);
  } catch (const InputError& e) {
    return e.what();
  }
  FAIL("loadObj accepted " << path << "; expected an InputError");
  return {};
}

std::string writeObj(const TempDir& dir, const std::string& name, const std::string& text) {
  const std::string path = dir.file(name);
  swarmsim_test::writeText(path, text);
  return path;
}

// icosahedron subdivided `levels` times, projected onto a sphere
TriangleMesh icosphere(int levels, double radius, const Vec3d& center) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3d> v = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                          {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  for (Vec3d& p : v) p.normalize();
  std::vector<std::array<std::uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mids;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mids.find(key);
      if (it != mids.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const auto id = static_cast<std::uint32_t>(v.size() - 1);
      mids[key] = id;
      return id;
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    for (const auto& t : f) {
      const std::uint32_t a = mid(t[0], t[1]), b = mid(t[1], t[2]), c = mid(t[2], t[0]);
      next.push_back({t[0], a, c});
      next.push_back({t[1], b, a});
      next.push_back({t[2], c, b});
      next.push_back({a, b, c});
    }
    f = next;
  }
  TriangleMesh m;
  for (const Vec3d& p : v) m.vertices.push_back(center + radius * p);
  m.triangles = f;
  m.source = "icosphere";
  return m;
}

// closed box mesh, outward counter-clockwise
TriangleMesh boxMesh(const Vec3d& lo, const Vec3d& hi) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back(i & 1 ? hi.x() : lo.x(), i & 2 ? hi.y() : lo.y(), i & 4 ? hi.z() : lo.z());
  }
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  m.source = "box";
  return m;
}

// torus around z, radii R (ring) and r (tube)
TriangleMesh torus(int nu, int nv, double R, double r) {
  TriangleMesh m;
  const double twoPi = 2.0 * std::acos(-1.0);
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      const double u = twoPi * i / nu, w = twoPi * j / nv;
      m.vertices.emplace_back((R + r * std::cos(w)) * std::cos(u), (R + r * std::cos(w)) * std::sin(u),
                              r * std::sin(w));
    }
  }
  auto id = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i) {
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  }
  return m;
}

// reference signed distance of an axis-aligned box (written independently of the library)
double boxDistance(const Vec3d& lo, const Vec3d& hi, const Vec3d& p) {
  double outside2 = 0.0, inside = -1e300;
  for (int a = 0; a < 3; ++a) {
    const double below = lo[a] - p[a], above = p[a] - hi[a];
    const double d = std::max(below, above);  // > 0 outside the slab
    if (d > 0.0) outside2 += d * d;
    inside = std::max(inside, d);
  }
  return outside2 > 0.0 ? std::sqrt(outside2) : inside;
}

Obstacles meshes(std::vector<TriangleMesh> ms) {
  Obstacles o;
  o.meshes = std::move(ms);
  return o;
}

// 40^3 cells over [-2, 2]^3 (cell 0.1)
GridSpec grid40() { return GridSpec::covering(Vec3d(-2, -2, -2), Vec3d(2, 2, 2), {40, 40, 40}); }

}  // namespace

// ---------------------------------------------------------------------------
// OBJ loading

TEST_CASE("loadObj: a quad cube loads as 12 triangles with its bounds", "[geometry][obj]") {
  TempDir dir;
  const std::string path = writeObj(dir, "cube.obj", kCubeObj);
  const TriangleMesh m = swarmsim::loadObj(path);
  CHECK(m.source == path);
  CHECK(m.vertices.size() == 8);
  CHECK(m.triangles.size() == 12);
  const auto box = m.bounds();
  CHECK(box.min().isApprox(Vec3d(-1, -1, -1)));
  CHECK(box.max().isApprox(Vec3d(1, 1, 1)));
  CHECK(swarmsim::isWatertight(m));
}

TEST_CASE("loadObj: groups, CRLF line ends, BOM, comments and relative indices", "[geometry][obj]") {
  TempDir dir;
  const std::string path = writeObj(dir, "two.obj",
                                    "\xEF\xBB\xBF# two triangles\r\ng first\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\n"
                                    "f -3 -2 -1 # relative\r\ng second\r\nv 0 0 1\r\nf 1/1/1 2//2 4\r\n");
  const TriangleMesh m = swarmsim::loadObj(path);
  REQUIRE(m.triangles.size() == 2);
  CHECK(m.triangles[0] == std::array<std::uint32_t, 3>{0, 1, 2});
  CHECK(m.triangles[1] == std::array<std::uint32_t, 3>{0, 1, 3});
  CHECK_FALSE(swarmsim::isWatertight(m));
}

TEST_CASE("MeshTransform: scale, then rotate X, Y, Z, then translate", "[geometry][obj]") {
  TempDir dir;
  const std::string path = writeObj(dir, "cube.obj", kCubeObj);
  MeshTransform t;
  t.scale = Vec3d(2, 3, 4);
  t.rotateDeg = Vec3d(0, 0, 90);
  t.translate = Vec3d(10, 20, 30);
  const TriangleMesh m = swarmsim::loadObj(path, t);
  // vertex 7 is (1, 1, 1): scaled (2, 3, 4), +90 about Z (x, y) -> (-y, x): (-3, 2, 4), moved (7, 22, 34)
  CHECK((m.vertices[6] - Vec3d(7, 22, 34)).norm() < 1e-12);
  const auto box = m.bounds();
  CHECK((box.min() - Vec3d(7, 18, 26)).norm() < 1e-12);
  CHECK((box.max() - Vec3d(13, 22, 34)).norm() < 1e-12);

  // order of the rotations: X first, then Y (both +90 degrees)
  MeshTransform r;
  r.rotateDeg = Vec3d(90, 90, 0);
  CHECK((r.apply(Vec3d(0, 1, 0)) - Vec3d(1, 0, 0)).norm() < 1e-12);   // X: -> (0,0,1); Y: -> (1,0,0)
  CHECK((r.apply(Vec3d(1, 0, 0)) - Vec3d(0, 0, -1)).norm() < 1e-12);  // X: unchanged; Y: -> (0,0,-1)
  MeshTransform q;
  q.rotateDeg = Vec3d(0, 0, 30);
  CHECK((q.apply(Vec3d(1, 0, 0)) - Vec3d(std::sqrt(3.0) / 2, 0.5, 0)).norm() < 1e-12);
}

TEST_CASE("loadObj: errors name the file and the line", "[geometry][obj]") {
  TempDir dir;
  const std::string cube8 = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";

  SECTION("missing file") {
    const std::string path = dir.file("nope.obj");
    const std::string msg = loadError(path);
    CHECK_THAT(msg, Contains(path + ": cannot open OBJ file"));
  }
  SECTION("a directory") {
    CHECK_THAT(loadError(dir.path().string()), Contains(dir.path().string() + ": cannot open OBJ file"));
  }
  SECTION("no faces") {
    const std::string path = writeObj(dir, "nofaces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    CHECK_THAT(loadError(path), Contains(path + ": no faces (expected at least one 'f' line)"));
  }
  SECTION("NaN, infinite and overflowing vertices") {
    const std::string nan = writeObj(dir, "nan.obj", "# c\nv 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(loadError(nan), Contains(nan + ":3: vertex is not finite"));
    const std::string inf = writeObj(dir, "inf.obj", "v 0 0 0\nv 1 0 0\n\nv 0 -Inf 0\nf 1 2 3\n");
    CHECK_THAT(loadError(inf), Contains(inf + ":4: vertex is not finite"));
    // finite as a decimal number but not in the loader's float precision
    const std::string big = writeObj(dir, "big.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(loadError(big), Contains(big + ":2: vertex is not finite"));
  }
  SECTION("malformed vertices") {
    const std::string word = writeObj(dir, "word.obj", "v 0 0 0\nv 1 abc 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(loadError(word), Contains(word + ":2: vertex coordinate 'abc' is not a number"));
    const std::string few = writeObj(dir, "few.obj", "v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n");
    CHECK_THAT(loadError(few), Contains(few + ":2: vertex needs 3 coordinates"));
  }
  SECTION("face index out of range") {
    const std::string path = writeObj(dir, "range.obj", cube8 + "f 1 2 3\nf 1 2 12\n");
    CHECK_THAT(loadError(path), Contains(path + ":10: face index 12 out of range (file has 8 vertices)"));
  }
  SECTION("relative face index out of range") {
    const std::string path = writeObj(dir, "rel.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n" + cube8);
    CHECK_THAT(loadError(path), Contains(path + ":4: face index -4 out of range (3 vertices before this line)"));
  }
  SECTION("face index zero and malformed faces") {
    const std::string zero = writeObj(dir, "zero.obj", cube8 + "f 0 1 2\n");
    CHECK_THAT(loadError(zero), Contains(zero + ":9: face index 0 is invalid"));
    const std::string two = writeObj(dir, "two.obj", cube8 + "\n\nf 1 2\n");
    CHECK_THAT(loadError(two), Contains(two + ":11: face has 2 vertices (expected at least 3)"));
    const std::string junk = writeObj(dir, "junk.obj", cube8 + "f 1 2 x\n");
    CHECK_THAT(loadError(junk), Contains(junk + ":9: bad face vertex 'x'"));
  }
  SECTION("lines tinyobjloader rejects: its message, with the file name") {
    // a zero texture-coordinate index passes our checks (only vertex indices
    // are ours) and is rejected by tinyobjloader, which names the line
    const std::string path = writeObj(dir, "tex.obj", cube8 + "vt 0 0\nf 1/0 2/1 3/1\n");
    const std::string msg = loadError(path);
    CHECK_THAT(msg, Contains(path + ": "));
    CHECK_THAT(msg, Contains("line 10"));
  }
}

TEST_CASE("isWatertight: closed, open and inconsistently oriented meshes", "[geometry]") {
  TriangleMesh cube = boxMesh(Vec3d(-1, -1, -1), Vec3d(1, 1, 1));
  CHECK(swarmsim::isWatertight(cube));
  CHECK(swarmsim::isWatertight(icosphere(2, 1.0, Vec3d::Zero())));
  CHECK(swarmsim::isWatertight(torus(12, 8, 1.0, 0.3)));

  TriangleMesh open = cube;
  open.triangles.resize(10);  // the +x face (last two triangles) removed
  CHECK_FALSE(swarmsim::isWatertight(open));

  TriangleMesh flipped = cube;
  std::swap(flipped.triangles[3][1], flipped.triangles[3][2]);
  CHECK_FALSE(swarmsim::isWatertight(flipped));

  CHECK_FALSE(swarmsim::isWatertight(TriangleMesh{}));
}

// ---------------------------------------------------------------------------
// Signed distance

TEST_CASE("signedDistance: unit sphere mesh matches |p| - 1", "[geometry][sdf]") {
  const TriangleMesh sphere = icosphere(3, 1.0, Vec3d::Zero());  // 1280 triangles
  REQUIRE(sphere.triangles.size() >= 1000);
  const GridSpec spec = grid40();
  const Grid3<float> sdf = swarmsim::signedDistance(meshes({sphere}), spec);
  double maxErr = 0.0;
  bool signsOk = true;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Vec3d p = spec.center(i, j, k);
        const double exact = p.norm() - 1.0;
        const double v = sdf.at(i, j, k);
        maxErr = std::max(maxErr, std::abs(v - exact));
        if (std::abs(exact) > 0.01 && (v < 0) != (exact < 0)) signsOk = false;
      }
    }
  }
  WARN("unit sphere mesh (1280 triangles), 40^3 grid: max |sdf - (|p| - 1)| = " << maxErr << " m (" << maxErr / 0.1
                                                                                << " cells)");
  CHECK(maxErr < 0.1);   // the requirement: one cell
  CHECK(maxErr < 0.01);  // mostly the facets' distance from the true sphere
  CHECK(signsOk);
  // the centre lies between cells 0.087 m from it
  CHECK(sdf.sample(Vec3(0, 0, 0)) == Approx(0.0866 - 1.0).margin(0.01));
}

TEST_CASE("signedDistance: box mesh and analytic box match the box distance", "[geometry][sdf]") {
  const Vec3d lo(-1.23, -0.61, -0.77), hi(0.93, 0.48, 1.31);
  const GridSpec spec = grid40();
  Obstacles analytic;
  analytic.boxes.push_back(BoxObstacle{lo, hi});
  const Grid3<float> fromMesh = swarmsim::signedDistance(meshes({boxMesh(lo, hi)}), spec);
  const Grid3<float> fromBox = swarmsim::signedDistance(analytic, spec);
  double errMesh = 0.0, errBox = 0.0;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const double exact = boxDistance(lo, hi, spec.center(i, j, k));
        errMesh = std::max(errMesh, std::abs(fromMesh.at(i, j, k) - exact));
        errBox = std::max(errBox, std::abs(fromBox.at(i, j, k) - exact));
      }
    }
  }
  WARN("box: max error mesh " << errMesh << " m, analytic " << errBox << " m (cell 0.1 m)");
  CHECK(errMesh < 1e-5);  // exact up to float rounding
  CHECK(errBox < 1e-5);
}

TEST_CASE("signedDistance: rotated box mesh matches the rotated box distance", "[geometry][sdf]") {
  TempDir dir;
  const std::string path = writeObj(dir, "cube.obj", kCubeObj);
  MeshTransform t;
  t.scale = Vec3d(1.2, 0.5, 0.7);
  t.rotateDeg = Vec3d(20, -35, 50);
  t.translate = Vec3d(0.1, -0.2, 0.15);
  const TriangleMesh m = swarmsim::loadObj(path, t);
  const GridSpec spec = grid40();
  const Grid3<float> sdf = swarmsim::signedDistance(meshes({m}), spec);
  const Eigen::Matrix3d rt = t.rotation().transpose();
  double maxErr = 0.0;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Vec3d local = rt * (spec.center(i, j, k) - t.translate);  // box frame
        const double exact = boxDistance(-t.scale, t.scale, local);
        maxErr = std::max(maxErr, std::abs(sdf.at(i, j, k) - exact));
      }
    }
  }
  WARN("rotated box mesh: max error " << maxErr << " m (cell 0.1 m)");
  CHECK(maxErr < 1e-5);
}

TEST_CASE("signedDistance: torus matches brute force; signs exact", "[geometry][sdf]") {
  const TriangleMesh m = torus(48, 24, 1.1, 0.4);  // 2304 triangles
  const GridSpec spec = GridSpec::covering(Vec3d(-1.8, -1.7, -0.9), Vec3d(1.8, 1.9, 0.9), {36, 36, 18});
  const Grid3<float> sdf = swarmsim::signedDistance(meshes({m}), spec);
  double maxErr = 0.0;
  int wrongSigns = 0;
  for (int k = 0; k < spec.n[2]; ++k) {
    for (int j = 0; j < spec.n[1]; ++j) {
      for (int i = 0; i < spec.n[0]; i += 3) {
        const Vec3d p = spec.center(i, j, k);
        const double d = bruteDistance(m, p);
        const double v = sdf.at(i, j, k);
        maxErr = std::max(maxErr, std::abs(std::abs(v) - d));
        // inside the (polygonal) tube: a safe margin away from the facets
        const double tube = std::hypot(std::hypot(p.x(), p.y()) - 1.1, p.z()) - 0.4;
        if (std::abs(tube) > 0.02 && (v < 0) != (tube < 0)) ++wrongSigns;
      }
    }
  }
  WARN("torus (2304 triangles): max |distance error| vs brute force " << maxErr << " m (cell 0.1 m)");
  CHECK(maxErr < 0.25 * 0.1);
  CHECK(wrongSigns == 0);
}

TEST_CASE("signedDistance: surfaces through cell centres get exact signs", "[geometry][sdf]") {
  // cell 0.5, centres at -2, -1.5, ..., 2: the cube's faces, edges and corners
  // lie on grid lines, which the inside/outside test must count consistently
  const GridSpec spec = GridSpec::covering(Vec3d(-2.25, -2.25, -2.25), Vec3d(2.25, 2.25, 2.25), {9, 9, 9});
  const Vec3d lo(-1, -1, -1), hi(1, 1, 1);
  TriangleMesh cube = boxMesh(lo, hi);
  MeshTransform spin;  // also a cube turned 90 degrees (same shape, other triangulation)
  spin.rotateDeg = Vec3d(90, 0, 90);
  TriangleMesh turned = cube;
  for (Vec3d& v : turned.vertices) v = spin.apply(v);
  for (const TriangleMesh& m : {cube, turned}) {
    const Grid3<float> sdf = swarmsim::signedDistance(meshes({m}), spec);
    for (int k = 0; k < 9; ++k) {
      for (int j = 0; j < 9; ++j) {
        for (int i = 0; i < 9; ++i) {
          const double exact = boxDistance(lo, hi, spec.center(i, j, k));
          CHECK(sdf.at(i, j, k) == Approx(exact).margin(1e-6));
        }
      }
    }
  }
}

TEST_CASE("signedDistance: a cube with a missing face keeps its inside", "[geometry][sdf]") {
  const Vec3d lo(-1, -1, -1), hi(1, 1, 1);
  TriangleMesh open = boxMesh(lo, hi);
  open.triangles.erase(open.triangles.begin() + 2, open.triangles.begin() + 4);  // the +z face
  REQUIRE_FALSE(swarmsim::isWatertight(open));
  REQUIRE(swarmsim::isWatertight(boxMesh(lo, hi)));
  const GridSpec spec = grid40();
  const Grid3<float> sdf = swarmsim::signedDistance(meshes({open}), spec);
  CHECK(sdf.sample(Vec3(0, 0, 0)) < -0.9f);
  CHECK(sdf.sample(Vec3(0, 0, 1.5f)) > 0.0f);   // above the hole
  CHECK(sdf.sample(Vec3(0, 0, -1.5f)) > 0.0f);  // below the bottom face
  CHECK(sdf.sample(Vec3(1.5f, 0, 0)) > 0.0f);
  // every cell more than half a cell from the surface has the closed cube's sign
  int wrong = 0;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const double exact = boxDistance(lo, hi, spec.center(i, j, k));
        if (std::abs(exact) > 0.05 && (sdf.at(i, j, k) < 0) != (exact < 0)) ++wrong;
      }
    }
  }
  CHECK(wrong == 0);
}

TEST_CASE("signedDistance: unions are the min over obstacles", "[geometry][sdf]") {
  const GridSpec spec = grid40();
  // analytic spheres: min of the exact distances
  Obstacles two;
  two.spheres = {SphereObstacle{Vec3d(-0.7, 0.1, 0), 0.8}, SphereObstacle{Vec3d(0.6, -0.2, 0.3), 0.5}};
  const Grid3<float> both = swarmsim::signedDistance(two, spec);
  double maxErr = 0.0;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Vec3d p = spec.center(i, j, k);
        const double exact =
            std::min((p - two.spheres[0].center).norm() - 0.8, (p - two.spheres[1].center).norm() - 0.5);
        maxErr = std::max(maxErr, std::abs(both.at(i, j, k) - exact));
      }
    }
  }
  CHECK(maxErr < 1e-6);
  // meshes: the union field is the min of the separate fields, exactly
  const TriangleMesh a = icosphere(2, 0.8, Vec3d(-0.7, 0.1, 0)), b = icosphere(2, 0.5, Vec3d(0.6, -0.2, 0.3));
  const Grid3<float> fa = swarmsim::signedDistance(meshes({a}), spec);
  const Grid3<float> fb = swarmsim::signedDistance(meshes({b}), spec);
  Obstacles mixed = meshes({a, b});
  mixed.boxes.push_back(BoxObstacle{Vec3d(1.2, 1.2, 1.2), Vec3d(1.8, 1.9, 2.5)});
  const Grid3<float> fab = swarmsim::signedDistance(meshes({a, b}), spec);
  const Grid3<float> fmixed = swarmsim::signedDistance(mixed, spec);
  for (std::size_t c = 0; c < spec.size(); ++c) {
    // one propagation for both meshes: the same exact distances, up to the
    // choice among near-equal triangles at medial surfaces
    REQUIRE(fab.data[c] == Approx(std::min(fa.data[c], fb.data[c])).margin(1e-4));
    const Vec3d p = spec.center(static_cast<int>(c % 40), static_cast<int>(c / 40 % 40), static_cast<int>(c / 1600));
    const float box = static_cast<float>(boxDistance(mixed.boxes[0].min, mixed.boxes[0].max, p));
    REQUIRE(fmixed.data[c] == Approx(std::min(fab.data[c], box)).margin(1e-6));
  }
}

TEST_CASE("signedDistance: overlapping and nested meshes", "[geometry][sdf]") {
  // a and b overlap; c lies inside a, so cells inside a can be nearer to c's
  // surface than to a's, and cells inside c are inside two meshes
  const std::array<std::pair<Vec3d, Vec3d>, 3> boxes = {{{Vec3d(-1.3, -0.5, -0.6), Vec3d(0.4, 0.55, 0.5)},
                                                         {Vec3d(-0.2, -0.7, -0.3), Vec3d(1.1, 0.35, 0.9)},
                                                         {Vec3d(-1.0, -0.2, -0.2), Vec3d(-0.6, 0.2, 0.25)}}};
  Obstacles o;
  for (const auto& b : boxes) o.meshes.push_back(boxMesh(b.first, b.second));
  const GridSpec spec = grid40();
  const Grid3<float> sdf = swarmsim::signedDistance(o, spec);
  double maxErr = 0.0;
  for (int k = 0; k < 40; ++k) {
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Vec3d p = spec.center(i, j, k);
        double exact = 1e300;
        for (const auto& b : boxes) exact = std::min(exact, boxDistance(b.first, b.second, p));
        maxErr = std::max(maxErr, std::abs(sdf.at(i, j, k) - exact));
      }
    }
  }
  CHECK(maxErr < 1e-5);
}

TEST_CASE("signedDistance: identical with 1 and 2 threads", "[geometry][sdf]") {
  const int saved = swarmsim::threadCount();
  Obstacles o = meshes({icosphere(3, 0.9, Vec3d(0.2, -0.1, 0.05)), torus(24, 12, 1.3, 0.3)});
  o.spheres.push_back(SphereObstacle{Vec3d(1.5, 1.5, 1.5), 0.3});
  const GridSpec spec = GridSpec::covering(Vec3d(-2, -2, -1), Vec3d(2, 2, 1), {41, 37, 23});
  swarmsim::setThreadCount(1);
  const Grid3<float> one = swarmsim::signedDistance(o, spec);
  swarmsim::setThreadCount(2);
  const Grid3<float> two = swarmsim::signedDistance(o, spec);
  swarmsim::setThreadCount(saved);
  CHECK(one.data == two.data);
}

TEST_CASE("signedDistance: a mesh outside the grid, no obstacles, normals", "[geometry][sdf]") {
  const GridSpec spec = grid40();
  // sphere of radius 0.5 at x = 4: the grid only sees distances >= 1.5
  const Grid3<float> far = swarmsim::signedDistance(meshes({icosphere(3, 0.5, Vec3d(4, 0, 0))}), spec);
  double maxErr = 0.0;
  for (int k = 0; k < 40; k += 3) {
    for (int j = 0; j < 40; j += 3) {
      for (int i = 0; i < 40; i += 3) {
        const Vec3d p = spec.center(i, j, k);
        maxErr = std::max(maxErr, std::abs(far.at(i, j, k) - ((p - Vec3d(4, 0, 0)).norm() - 0.5)));
      }
    }
  }
  CHECK(maxErr < 0.01);

  const Grid3<float> none = swarmsim::signedDistance(Obstacles{}, spec);
  CHECK(Obstacles{}.empty());
  CHECK(std::all_of(none.data.begin(), none.data.end(), [](float v) { return v == swarmsim::kSdfFar; }));
  CHECK(std::isfinite(none.sample(Vec3(0.3f, 0.2f, 0.1f))));

  Obstacles ball;
  ball.spheres.push_back(SphereObstacle{Vec3d::Zero(), 1.0});
  CHECK_FALSE(ball.empty());
  const Grid3<float> sdf = swarmsim::signedDistance(ball, spec);
  const Vec3 n = swarmsim::normalAt(sdf, Vec3(1.2f, 0.3f, -0.4f));
  const Vec3 expected = Vec3(1.2f, 0.3f, -0.4f).normalized();
  CHECK(n.norm() == Approx(1.0).margin(1e-5));
  CHECK(n.dot(expected) > 0.999f);
}

TEST_CASE("ObstacleClearance::distanceBound: never above distance, and within a cell diagonal of it",
          "[geometry][sdf]") {
  Obstacles o = meshes({icosphere(3, 0.6, Vec3d(0.2, -0.1, 0.05)), torus(24, 12, 1.1, 0.25)});
  o.spheres.push_back(SphereObstacle{Vec3d(1.2, 1.1, 0.4), 0.3});
  // a grid with a single cell along z too: its samples have no z neighbour
  for (const GridSpec& spec : {GridSpec::covering(Vec3d(-2, -2, -1), Vec3d(2, 2, 1), {41, 37, 23}),
                               GridSpec::covering(Vec3d(-2, -2, -0.1), Vec3d(2, 2, 0.1), {30, 33, 1})}) {
    swarmsim::ObstacleClearance c(swarmsim::signedDistance(o, spec), 0.05f, true);
    c.prepareDistanceBound();
    const Grid3<float>::Sampler s = c.sdf().sampler();
    const float diagonal = static_cast<float>(spec.cell.norm());
    std::uint64_t state = 12345;
    const auto uniform = [&](double lo, double hi) {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      return static_cast<float>(lo + (hi - lo) * static_cast<double>(state >> 11) * 0x1.0p-53);
    };
    int above = 0, loose = 0, inside = 0;
    for (int t = 0; t < 200000; ++t) {
      // points inside the grid and up to half a metre beyond it (clamped like the samples)
      const Vec3 x(uniform(-2.5, 2.5), uniform(-2.5, 2.5), uniform(spec.min.z() - 0.5, spec.max().z() + 0.5));
      const float d = c.distance(x), b = c.distanceBound(s, x);
      CHECK(s(x) == d);
      above += b > d ? 1 : 0;
      loose += b < d - diagonal * 1.001f ? 1 : 0;
      inside += d < 0.0f ? 1 : 0;
    }
    CHECK(above == 0);
    CHECK(loose == 0);
    CHECK(inside > 1000);  // the bound is checked on both signs
  }
}

TEST_CASE("ObstacleClearance::settle gives apply and the domain clamp point by point, on every lane set",
          "[geometry][sdf]") {
  Obstacles o = meshes({icosphere(3, 0.6, Vec3d(0.2, -0.1, 0.05))});
  o.spheres.push_back(SphereObstacle{Vec3d(1.2, 1.1, 0.4), 0.3});
  const GridSpec spec = GridSpec::covering(Vec3d(-2, -2, -1), Vec3d(2, 2, 1), {41, 37, 23});
  const bool any = GENERATE(true, false);
  const swarmsim::ObstacleClearance c(swarmsim::signedDistance(o, spec), 0.05f, any);
  const Vec3 lo(-1.5f, -1.5f, 0.0f), hi(1.5f, 1.5f, 0.8f);
  std::uint64_t state = 777;
  const auto uniform = [&](double a, double b) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<float>(a + (b - a) * static_cast<double>(state >> 11) * 0x1.0p-53);
  };
  std::vector<float> x, y, z;
  // first (so that the eights take them): on the domain's bounds, signed zeros on a zero bound (far from both
  // obstacles, so apply leaves them), a point in the last cell of the grid, one inside an obstacle
  for (const Vec3& p : {Vec3(-1.5f, 1.5f, 0.8f), Vec3(-1.4f, -1.4f, -0.0f), Vec3(-1.3f, -1.4f, 0.0f),
                        Vec3(1.99f, 1.99f, 0.99f), Vec3(0.2f, -0.1f, 0.05f)}) {
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
  }
  for (int t = 0; t < 5000; ++t) {
    // over the grid and beyond it, so points fall inside the obstacles, near them, far, and out of the domain
    x.push_back(uniform(-2.5, 2.5));
    y.push_back(uniform(-2.5, 2.5));
    z.push_back(uniform(-1.5, 1.5));
  }
  const std::size_t n = x.size();
  std::vector<float> wx(n), wy(n), wz(n);
  int moved = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 a = c.apply(Vec3(x[i], y[i], z[i]));
    moved += a != Vec3(x[i], y[i], z[i]) ? 1 : 0;
    const Vec3 p = a.cwiseMax(lo).cwiseMin(hi);
    wx[i] = p.x();
    wy[i] = p.y();
    wz[i] = p.z();
  }
  if (any) CHECK(moved > 50);  // clearance pushed many of them
  for (const auto lanes : {swarmsim::LaneSet::kSse, swarmsim::LaneSet::kAvx2}) {
    if (lanes > swarmsim::laneSet()) continue;
    for (const std::size_t m : {std::size_t{0}, std::size_t{5}, std::size_t{8}, std::size_t{21}, n}) {
      std::vector<float> gx = x, gy = y, gz = z;
      c.settle(gx.data(), gy.data(), gz.data(), m, lo, hi, lanes);
      INFO("lanes " << static_cast<int>(lanes) << ", " << m << " points");
      CHECK(std::memcmp(gx.data(), wx.data(), m * sizeof(float)) == 0);
      CHECK(std::memcmp(gy.data(), wy.data(), m * sizeof(float)) == 0);
      CHECK(std::memcmp(gz.data(), wz.data(), m * sizeof(float)) == 0);
      if (m < n) CHECK(gx[m] == x[m]);  // nothing past m
    }
  }
}
