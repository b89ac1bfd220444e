// Triangle meshes of virtual objects (world or body metres).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

/// Indexed triangle mesh; triangles wind counter-clockwise seen from outside.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;

  /// Unit-free icosphere of the given radius (metres) centred at the origin:
  /// subdivisions 0 gives 20 triangles, each level multiplies by 4.
  static TriangleMesh Icosphere(double radius, int subdivisions);
  /// A box of the given half extents (metres) centred at the origin, each face
  /// cut into a grid of squares no longer than max_edge (each two triangles), so
  /// its triangles are about max_edge across (paper §4.1 used ~2 cm triangles).
  /// Throws std::invalid_argument unless half_extents > 0 and max_edge > 0.
  static TriangleMesh Box(const Eigen::Vector3d& half_extents, double max_edge);
  /// The mesh moved by world_from_body.
  TriangleMesh Transformed(const Rigid3d& world_from_body) const;
  Aabb Bounds() const;
};

}  // namespace hullpipe
