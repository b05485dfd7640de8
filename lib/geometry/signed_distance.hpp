#pragma once
// Signed distance fields of obstacles on cell-centred grids.
//
// signedDistance() gives, at every cell centre, the signed distance in metres
// to the union of the obstacles: min over the obstacles of each one's signed
// distance (negative inside, positive outside). Spheres and boxes are exact
// (analytic). For each triangle mesh:
//
//  * Distance. Cells within a band of 1.5 cell edges (the largest edge) of a
//    triangle get the exact distance to their nearest triangle (each triangle
//    visits the cells of its expanded bounding box near its plane). The
//    nearest-triangle ids are then propagated to the rest of the grid by
//    closest-point sweeping: forward and backward passes along x, then y, then
//    z lines, twice, where a cell takes its line neighbour's triangle when the
//    exact point-triangle distance to it is smaller. Every value is thus the
//    exact distance to some triangle of the mesh; it is the nearest one except
//    where propagation picked a slightly farther one near a boundary between
//    nearest-triangle regions, far from the surface (measured error there: a
//    few thousandths of a cell, see tests/geometry_test.cpp).
//  * Sign. Grid lines along each axis are cast through the mesh: crossings are
//    found with exact integer orientation tests (vertices and line positions
//    snapped to a lattice of about 2^-28 of the scene size) and a top-left
//    rule for lines through edges and vertices, so a closed surface is crossed
//    a consistent number of times. Each axis gives two votes per cell: the
//    parity of the crossings before the cell and of those after it. A
//    watertight mesh gets six equal votes, i.e. exact signs (up to cells
//    within rounding of the surface, where the distance is ~0 anyway). A hole
//    makes the lines through it cross an odd number of times: their two votes
//    then disagree and cancel, and the other axes decide. Inside means more
//    inside votes than outside votes; a tie is broken by the side of the
//    nearest triangle's plane.
//    Limits: a cell seen through holes along two or more axes can get the
//    wrong sign; an open sheet (e.g. a lone ground quad) has no inside, so
//    it gets positive (unsigned) distances; self-intersecting or
//    inconsistently oriented parts are classified by crossing parity (the
//    orientation of the triangles is not used except to break ties).
//
// Cost is linear in the grid size (a few passes) plus the triangles' band
// cells; all loops run through parallelFor over disjoint grid planes, so the
// result does not depend on the number of threads.
#include "core/vec.hpp"
#include "fields/grid3.hpp"
#include "geometry/obstacles.hpp"

namespace swarmsim {

// value of every cell when there are no obstacles (finite, so trilinear
// sampling stays finite)
constexpr float kSdfFar = 1e30f;

// signed distance (metres) at the cell centres of spec
Grid3<float> signedDistance(const Obstacles& obstacles, const GridSpec& spec);

// Outward unit normal at p: the normalised central-difference gradient of the
// trilinear SDF (steps of half a cell per axis); zero where it is degenerate.
Vec3 normalAt(const Grid3<float>& sdf, const Vec3& p);

// exact signed distances of the analytic obstacles
double sphereSignedDistance(const SphereObstacle& s, const Vec3d& p);
double boxSignedDistance(const BoxObstacle& b, const Vec3d& p);

}  // namespace swarmsim
