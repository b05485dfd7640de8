#pragma once
// Stratified sampling of a triangle mesh's surface for the shape model (Chen et
// al. 2019, section 5.1: "we apply a stratified sampling method to obtain
// sample points from the guidance meshes"). The samples are the insects'
// target positions.
//
// Stratified at two levels, and unbiased (every point of the surface has the
// same probability density 1 / A, A the total area):
//  1. over triangles, systematic: the triangles of positive area are ordered
//     along a Hilbert curve through their centroids, so that consecutive
//     triangles are neighbours on the surface, and laid end to end as
//     intervals of length area / A * n (the expected number of samples);
//     stratum j = [j, j + 1) gets one sample at a uniform position x_j in it,
//     which picks the triangle. A triangle thus receives its expected count
//     to within 1 either way, and neighbouring triangles share strata instead
//     of drawing independently.
//  2. inside a triangle: it is cut into k^2 congruent sub-triangles (a k-grid in
//     barycentric coordinates, k^2 >= its expected count), ordered in a snake
//     through the rows so consecutive ones touch, each covering an equal part
//     of the triangle's interval; x_j also picks the sub-triangle, and the
//     sample is uniform in it. So the samples of one triangle are spread over
//     it (about one per sub-triangle) rather than placed independently.
// The random numbers are counter-based (Philox): a sample is a pure function
// of (mesh, n, seed, its stratum), so the result never depends on threads.
//
// Samples refer to triangles and barycentric coordinates, so the same samples
// follow a mesh through animated keyframes that keep its faces.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/vec.hpp"
#include "geometry/mesh.hpp"

namespace swarmsim {

// a point on a mesh: triangle index and barycentric (u, v):
// p = a + u (b - a) + v (c - a), u, v >= 0, u + v <= 1
struct SurfacePoint {
  std::uint32_t triangle = 0;
  float u = 0, v = 0;
};

// total area of the mesh's triangles
double surfaceArea(const TriangleMesh& mesh);

// the position of s on mesh (any mesh with the same faces, e.g. an animated
// keyframe); throws std::out_of_range when s.triangle is not a triangle of mesh
Vec3d surfacePoint(const TriangleMesh& mesh, const SurfacePoint& s);

// Exactly n points, area-weighted and stratified so samples do not clump (see
// above), in the Hilbert order of their triangles; deterministic for
// (mesh, n, seed). Zero-area triangles get no samples. Throws InputError naming
// mesh.source when the mesh has no triangles, a vertex index out of range, or
// zero (or non-finite) total area.
std::vector<SurfacePoint> sampleSurface(const TriangleMesh& mesh, std::size_t n, std::uint64_t seed);

}  // namespace swarmsim
