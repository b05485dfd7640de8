#pragma once
// Triangle meshes of the analytic obstacles, for drawing (the scene stored in
// the output, docs/output.md#scene-and-inputs); the simulation itself uses the
// exact shapes.
#include "geometry/mesh.hpp"
#include "geometry/obstacles.hpp"

namespace swarmsim {

// icosphere: an icosahedron subdivided `subdivisions` times, every vertex on the sphere
// (subdivisions 2: 162 vertices, 320 triangles); triangles counter-clockwise seen from outside
TriangleMesh sphereMesh(const SphereObstacle& s, int subdivisions = 2);
// the box's 8 corners and 12 triangles, counter-clockwise seen from outside
TriangleMesh boxMesh(const BoxObstacle& b);

}  // namespace swarmsim
