// Exact signed distance to a closed triangle mesh (paper §4.5: clearance of a
// CAD part; the payload task's parts when they are model files, §5.2). The
// distance is the exact least distance to the triangles (part_bvh.h's
// hierarchy, Ericson's closest point on a triangle); its sign is the side of
// the nearest feature's angle-weighted pseudonormal (Bærentzen and Aanæs,
// "Signed distance computation using the angle weighted pseudonormal", IEEE
// TVCG 2005), exact for a closed, consistently oriented mesh: negative inside.
// Body frame metres.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/models/part_bvh.h"

namespace hullpipe {

class MeshSignedDistance {
 public:
  /// Builds over `mesh` (body frame; vertices at the same position are one
  /// vertex, so a file's per-face copies do not open it). Throws
  /// std::invalid_argument for an empty mesh or an index out of range.
  explicit MeshSignedDistance(TriangleMesh mesh);
  /// Every edge (of welded vertices) is shared by exactly two triangles that
  /// run it in opposite directions: the mesh bounds a volume and the sign is
  /// exact (a mesh wound inside out, negative volume, is read the right way
  /// out). False: Signed gives the unsigned distance (a surface has no inside).
  bool closed() const { return closed_; }
  /// Least distance from p (body frame) to the mesh, metres; negative inside
  /// when closed(). *closest (optional): the nearest mesh point.
  double Signed(const Eigen::Vector3d& p, Eigen::Vector3d* closest = nullptr) const;
  /// The least distance, unsigned.
  double Unsigned(const Eigen::Vector3d& p) const;
  const TriangleMesh& mesh() const { return mesh_; }
  const TriangleBvh& bvh() const { return bvh_; }
  Aabb bounds() const { return bounds_; }

 private:
  TriangleMesh mesh_;
  TriangleBvh bvh_;
  Aabb bounds_;
  bool closed_ = false;
  bool inside_out_ = false;  // closed with its triangles wound clockwise seen from outside
  std::vector<int> weld_;                        // vertex -> its welded representative
  std::vector<Eigen::Vector3d> face_normal_;     // unit, per triangle
  std::vector<Eigen::Vector3d> vertex_normal_;   // angle-weighted, per welded vertex
  std::vector<Eigen::Vector3d> edge_normal_;     // per triangle edge (3 t + k: edge k -> k+1): both faces' sum
};

/// The reference the tests hold it to: the generalized winding number of a
/// closed mesh at p (the solid angles of its triangles over 4 pi; Van
/// Oosterom and Strackee 1983): 1 inside, 0 outside. O(triangles).
double WindingNumber(const TriangleMesh& mesh, const Eigen::Vector3d& p);

}  // namespace hullpipe
