#include "hullpipe/models/mesh_distance.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

namespace hullpipe {

namespace {

// The angle of the triangle at vertex a.
double AngleAt(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d u = b - a, v = c - a;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

MeshSignedDistance::MeshSignedDistance(TriangleMesh mesh) : mesh_(std::move(mesh)) {
  if (mesh_.triangles.empty()) throw std::invalid_argument("MeshSignedDistance: the mesh has no triangle");
  const int nv = int(mesh_.vertices.size());
  for (const auto& t : mesh_.triangles)
    for (int k = 0; k < 3; ++k)
      if (t[k] < 0 || t[k] >= nv)
        throw std::invalid_argument("MeshSignedDistance: a triangle indexes past the vertices");
  bvh_ = TriangleBvh(mesh_);
  bounds_ = mesh_.Bounds();
  // Weld vertices at the same position (exactly: a file's per-face copies).
  std::map<std::tuple<double, double, double>, int> first;
  weld_.resize(size_t(nv));
  for (int i = 0; i < nv; ++i) {
    const Eigen::Vector3d& v = mesh_.vertices[size_t(i)];
    weld_[size_t(i)] = first.try_emplace({v.x(), v.y(), v.z()}, i).first->second;
  }
  const size_t nt = mesh_.triangles.size();
  face_normal_.resize(nt);
  vertex_normal_.assign(size_t(nv), Eigen::Vector3d::Zero());
  edge_normal_.assign(3 * nt, Eigen::Vector3d::Zero());
  // Directed welded edge -> (triangle, edge index), to pair each with its twin.
  std::map<std::pair<int, int>, std::vector<size_t>> directed;
  for (size_t t = 0; t < nt; ++t) {
    const Eigen::Vector3i& tri = mesh_.triangles[t];
    const Eigen::Vector3d &a = mesh_.vertices[size_t(tri[0])], &b = mesh_.vertices[size_t(tri[1])],
                          &c = mesh_.vertices[size_t(tri[2])];
    const Eigen::Vector3d n = (b - a).cross(c - a);
    face_normal_[t] = n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
    vertex_normal_[size_t(weld_[size_t(tri[0])])] += AngleAt(a, b, c) * face_normal_[t];
    vertex_normal_[size_t(weld_[size_t(tri[1])])] += AngleAt(b, c, a) * face_normal_[t];
    vertex_normal_[size_t(weld_[size_t(tri[2])])] += AngleAt(c, a, b) * face_normal_[t];
    for (int k = 0; k < 3; ++k)
      directed[{weld_[size_t(tri[k])], weld_[size_t(tri[(k + 1) % 3])]}].push_back(3 * t + size_t(k));
  }
  // Its volume's sign says which way it is wound (divergence theorem).
  double volume6 = 0;
  for (const auto& tri : mesh_.triangles)
    volume6 += mesh_.vertices[size_t(tri[0])].dot(mesh_.vertices[size_t(tri[1])].cross(mesh_.vertices[size_t(tri[2])]));
  inside_out_ = volume6 < 0;
  closed_ = true;
  for (const auto& [edge, uses] : directed) {
    const auto twin = directed.find({edge.second, edge.first});
    if (uses.size() != 1 || twin == directed.end() || twin->second.size() != 1 || edge.first == edge.second) {
      closed_ = false;
      continue;
    }
    edge_normal_[uses[0]] = face_normal_[uses[0] / 3] + face_normal_[twin->second[0] / 3];
  }
}

double MeshSignedDistance::Unsigned(const Eigen::Vector3d& p) const {
  return bvh_.Distance(mesh_, p, std::numeric_limits<double>::infinity());
}

double MeshSignedDistance::Signed(const Eigen::Vector3d& p, Eigen::Vector3d* closest) const {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  int t = -1;
  const double d = bvh_.Distance(mesh_, p, std::numeric_limits<double>::infinity(), &q, &t);
  if (closest) *closest = q;
  if (!closed_ || t < 0 || d == 0) return d;
  // Which feature of triangle t holds q: its barycentric coordinates, a
  // coordinate at most a few ulps of the triangle's size from 0 counting as 0.
  const Eigen::Vector3i& tri = mesh_.triangles[size_t(t)];
  const Eigen::Vector3d &a = mesh_.vertices[size_t(tri[0])], &b = mesh_.vertices[size_t(tri[1])],
                        &c = mesh_.vertices[size_t(tri[2])];
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  Eigen::Vector3d normal = face_normal_[size_t(t)];
  if (area2 > 0) {
    const std::array<double, 3> w = {n.dot((c - b).cross(q - b)) / area2, n.dot((a - c).cross(q - c)) / area2,
                                     n.dot((b - a).cross(q - a)) / area2};
    constexpr double kEps = 1e-9;
    int zeros = 0, zero = -1, nonzero = -1;
    for (int k = 0; k < 3; ++k) (std::abs(w[size_t(k)]) <= kEps ? (++zeros, zero) : nonzero) = k;
    if (zeros == 1) {
      // On the edge opposite vertex `zero`: from vertex zero+1 to zero+2.
      normal = edge_normal_[3 * size_t(t) + size_t((zero + 1) % 3)];
    } else if (zeros >= 2) {
      normal = vertex_normal_[size_t(weld_[size_t(tri[nonzero])])];  // at the one vertex left
    }
  }
  return ((p - q).dot(normal) < 0) != inside_out_ ? -d : d;
}

double WindingNumber(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double sum = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[size_t(t[0])] - p, b = mesh.vertices[size_t(t[1])] - p,
                          c = mesh.vertices[size_t(t[2])] - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    const double num = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    sum += 2 * std::atan2(num, den);
  }
  return sum / (4 * M_PI);
}

}  // namespace hullpipe
