#include "geometry/tessellate.hpp"

#include <cmath>
#include <map>
#include <utility>

namespace swarmsim {

TriangleMesh sphereMesh(const SphereObstacle& s, int subdivisions) {
  // unit icosahedron: the 12 vertices (0, +-1, +-g) cyclically, g the golden ratio
  const double g = 0.5 * (1.0 + std::sqrt(5.0));
  std::vector<Vec3d> v = {{-1, g, 0}, {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g}, {0, 1, g},
                          {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  for (Vec3d& p : v) p.normalize();
  std::vector<std::array<std::uint32_t, 3>> t = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back((v[a] + v[b]).normalized());
      const auto k = static_cast<std::uint32_t>(v.size() - 1);
      mid.emplace(key, k);
      return k;
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    next.reserve(4 * t.size());
    for (const auto& f : t) {
      const std::uint32_t a = midpoint(f[0], f[1]), b = midpoint(f[1], f[2]), c = midpoint(f[2], f[0]);
      next.push_back({f[0], a, c});
      next.push_back({f[1], b, a});
      next.push_back({f[2], c, b});
      next.push_back({a, b, c});
    }
    t = std::move(next);
  }
  TriangleMesh m;
  m.source = "sphere";
  for (const Vec3d& p : v) m.vertices.push_back(s.center + s.radius * p);
  m.triangles = std::move(t);
  return m;
}

TriangleMesh boxMesh(const BoxObstacle& b) {
  TriangleMesh m;
  m.source = "box";
  for (int k = 0; k < 8; ++k) {  // corner k: bit 0 x, bit 1 y, bit 2 z
    m.vertices.emplace_back((k & 1) ? b.max.x() : b.min.x(), (k & 2) ? b.max.y() : b.min.y(),
                            (k & 4) ? b.max.z() : b.min.z());
  }
  m.triangles = {{0, 2, 3}, {0, 3, 1},   // z = min, normal -z
                 {4, 5, 7}, {4, 7, 6},   // z = max, +z
                 {0, 1, 5}, {0, 5, 4},   // y = min, -y
                 {2, 6, 7}, {2, 7, 3},   // y = max, +y
                 {0, 4, 6}, {0, 6, 2},   // x = min, -x
                 {1, 3, 7}, {1, 7, 5}};  // x = max, +x
  return m;
}

}  // namespace swarmsim
