#pragma once
// Static obstacles of a scenario: triangle meshes and analytic spheres and
// boxes, all in world coordinates (metres). signedDistance() turns them into a
// grid of signed distances (negative inside).
#include <vector>

#include <Eigen/Geometry>

#include "core/vec.hpp"
#include "geometry/mesh.hpp"

namespace swarmsim {

struct SphereObstacle {
  Vec3d center = Vec3d::Zero();
  double radius = 1.0;  // > 0
};

// axis-aligned box; min <= max on every axis
struct BoxObstacle {
  Vec3d min = Vec3d::Zero();
  Vec3d max = Vec3d::Ones();
};

struct Obstacles {
  std::vector<TriangleMesh> meshes;
  std::vector<SphereObstacle> spheres;
  std::vector<BoxObstacle> boxes;

  bool empty() const;
  // bounding box of everything (empty box when there are no obstacles)
  Eigen::AlignedBox3d bounds() const;
};

}  // namespace swarmsim
