#pragma once
// Triangle meshes for obstacles: loading Wavefront OBJ files and a topological
// closedness check.
//
// loadObj reads the file itself first and validates its 'v' and 'f' lines, so
// that errors name the line (tinyobjloader silently reads "nan" or "abc" as 0
// and only warns, without a precise line, about out-of-range face indices);
// tinyobjloader then does the actual parsing and triangulation. Comments ('#'
// to the end of a line, also after data) and a UTF-8 byte-order mark are
// removed first. All groups and objects of the file are merged into one mesh;
// normals, texture coordinates and materials are ignored (mtllib lines are not
// followed).
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

struct TriangleMesh {
  std::vector<Vec3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;  // vertex indices, counter-clockwise seen from outside
  std::string source;                                   // file the mesh came from (for messages)

  // bounding box of the vertices (empty box when there are none)
  Eigen::AlignedBox3d bounds() const;
};

// Placement of a mesh in the world. A point p of the file becomes
//   translate + Rz(rz) * Ry(ry) * Rx(rx) * (scale .* p),
// i.e. scale per axis first, then rotate about the X axis, then about Y, then
// about Z (angles in degrees, right-handed: +90 about Z takes +X to +Y), then
// translate. The axes are the fixed world axes.
struct MeshTransform {
  Vec3d translate = Vec3d::Zero();
  Vec3d rotateDeg = Vec3d::Zero();
  Vec3d scale = Vec3d::Ones();

  Eigen::Matrix3d rotation() const;  // Rz * Ry * Rx
  Vec3d apply(const Vec3d& p) const;
};

// Load an OBJ file, triangulate its faces (all shapes merged) and place it with
// t. Throws InputError naming the file (and the line where there is one) when
// the file cannot be read, has no faces, has a vertex with a coordinate that is
// missing, not a number or not finite (in the loader's precision), has a face
// with fewer than three vertices or an index out of range (absolute indices
// count all 'v' lines of the file, negative ones the 'v' lines before the
// face), or is rejected by tinyobjloader, or when a placed vertex has a
// coordinate of magnitude above maxCoordinate (the scenario's limit).
TriangleMesh loadObj(const std::string& path, const MeshTransform& t = MeshTransform(),
                     double maxCoordinate = std::numeric_limits<double>::max());
// the two halves of loadObj: the file's bytes, and the mesh from bytes (`path` names them in messages)
std::string readObjFile(const std::string& path);
TriangleMesh parseObj(const std::string& bytes, const std::string& path, const MeshTransform& t = MeshTransform(),
                      double maxCoordinate = std::numeric_limits<double>::max());

// True when every undirected edge (by vertex index) belongs to exactly two
// triangles that use it in opposite directions (consistent orientation) and no
// triangle repeats a vertex. Vertices are not welded: a closed surface stored
// with duplicated vertices is not watertight by this test. False when empty.
bool isWatertight(const TriangleMesh& mesh);

}  // namespace swarmsim
