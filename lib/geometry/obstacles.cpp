#include "geometry/obstacles.hpp"

namespace swarmsim {

bool Obstacles::empty() const { return meshes.empty() && spheres.empty() && boxes.empty(); }

Eigen::AlignedBox3d Obstacles::bounds() const {
  Eigen::AlignedBox3d box;  // empty
  for (const TriangleMesh& m : meshes) box.extend(m.bounds());
  for (const SphereObstacle& s : spheres) {
    const Vec3d r = Vec3d::Constant(s.radius);
    box.extend(s.center - r);
    box.extend(s.center + r);
  }
  for (const BoxObstacle& b : boxes) {
    box.extend(b.min);
    box.extend(b.max);
  }
  return box;
}

}  // namespace swarmsim
