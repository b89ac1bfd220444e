#include "hullpipe/mesh.h"

#include <cmath>
#include <map>
#include <utility>

namespace hullpipe {

TriangleMesh TriangleMesh::Icosphere(double radius, int subdivisions) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh m;
  m.vertices = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  m.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& v : m.vertices) v.normalize();
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      const auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      m.vertices.push_back((m.vertices[size_t(a)] + m.vertices[size_t(b)]).normalized());
      const int idx = int(m.vertices.size()) - 1;
      midpoint[key] = idx;
      return idx;
    };
    std::vector<Eigen::Vector3i> next;
    for (const auto& tri : m.triangles) {
      const int a = mid(tri[0], tri[1]), b = mid(tri[1], tri[2]), c = mid(tri[2], tri[0]);
      next.push_back({tri[0], a, c});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], c, b});
      next.push_back({a, b, c});
    }
    m.triangles = std::move(next);
  }
  for (auto& v : m.vertices) v *= radius;
  return m;
}

TriangleMesh TriangleMesh::Transformed(const Rigid3d& world_from_body) const {
  TriangleMesh m = *this;
  for (auto& v : m.vertices) v = world_from_body * v;
  return m;
}

Aabb TriangleMesh::Bounds() const {
  Aabb b;
  for (const auto& v : vertices) b.Extend(v);
  return b;
}

}  // namespace hullpipe
