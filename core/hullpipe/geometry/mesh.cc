#include "hullpipe/geometry/mesh.h"

#include <cmath>
#include <map>
#include <stdexcept>
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

TriangleMesh TriangleMesh::Box(const Eigen::Vector3d& half, double max_edge) {
  if (!((half.array() > 0).all() && max_edge > 0)) throw std::invalid_argument("TriangleMesh::Box: sizes must be > 0");
  TriangleMesh m;
  // Each face: axis k fixed at +-half[k], a grid over the other two axes.
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    const int ni = std::max(1, int(std::ceil(2 * half[i] / max_edge)));
    const int nj = std::max(1, int(std::ceil(2 * half[j] / max_edge)));
    for (const double side : {-1.0, 1.0}) {
      const int base = int(m.vertices.size());
      for (int b = 0; b <= nj; ++b)
        for (int a = 0; a <= ni; ++a) {
          Eigen::Vector3d v;
          v[k] = side * half[k];
          v[i] = -half[i] + 2 * half[i] * a / ni;
          v[j] = -half[j] + 2 * half[j] * b / nj;
          m.vertices.push_back(v);
        }
      for (int b = 0; b < nj; ++b)
        for (int a = 0; a < ni; ++a) {
          const int v00 = base + b * (ni + 1) + a, v10 = v00 + 1, v01 = v00 + ni + 1, v11 = v01 + 1;
          // (i, j, k) is right-handed: counter-clockwise seen from +k.
          if (side > 0) {
            m.triangles.push_back({v00, v10, v11});
            m.triangles.push_back({v00, v11, v01});
          } else {
            m.triangles.push_back({v00, v11, v10});
            m.triangles.push_back({v00, v01, v11});
          }
        }
    }
  }
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
