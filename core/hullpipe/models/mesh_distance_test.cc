#include "hullpipe/models/mesh_distance.h"

#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace hullpipe {
namespace {

// The exact signed distance to an axis-aligned box centred at the origin.
double BoxSdf(const Eigen::Vector3d& p, const Eigen::Vector3d& half) {
  const Eigen::Vector3d q = p.cwiseAbs() - half;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// The least distance to every triangle, one by one: the hierarchy's reference.
double BruteDistance(const TriangleMesh& m, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : m.triangles)
    best = std::min(best, (ClosestPointOnTriangle(p, m.vertices[size_t(t[0])], m.vertices[size_t(t[1])],
                                                  m.vertices[size_t(t[2])]) -
                           p)
                              .norm());
  return best;
}

// A box's mesh is the box: its signed distance is the analytic one, to
// rounding, everywhere -- inside, outside, and where the nearest feature is a
// face, an edge or a corner (points spread around the corners and edges).
TEST(MeshSignedDistance, ABoxMeshGivesTheBoxsExactSignedDistance) {
  const Eigen::Vector3d half(0.15, 0.10, 0.05);
  for (double edge : {1.0, 0.02}) {  // 12 triangles; many, with vertices inside the faces and edges
    const MeshSignedDistance sdf(TriangleMesh::Box(half, edge));
    ASSERT_TRUE(sdf.closed()) << edge;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1, 1);
    int inside = 0, outside = 0;
    for (int i = 0; i < 4000; ++i) {
      // Half the points within 2 cm of a corner: nearest features are edges and corners.
      Eigen::Vector3d p(u(rng) * 0.3, u(rng) * 0.25, u(rng) * 0.2);
      if (i % 2) p = half.cwiseProduct(Eigen::Vector3d(u(rng) > 0 ? 1 : -1, u(rng) > 0 ? 1 : -1, u(rng) > 0 ? 1 : -1)) +
                     0.02 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      const double want = BoxSdf(p, half);
      ASSERT_NEAR(sdf.Signed(p), want, 1e-12) << p.transpose() << " edge " << edge;
      (want < 0 ? inside : outside) += 1;
    }
    EXPECT_GT(inside, 200);  // both sides were tried (313 and 3687 with this seed)
    EXPECT_GT(outside, 500);
  }
}

// A curved closed mesh: the sign agrees with the winding number (an
// independent exact test of inside), the magnitude with every triangle tried.
TEST(MeshSignedDistance, TheSignIsTheWindingNumbersAndTheDistanceTheLeastOverEveryTriangle) {
  const TriangleMesh sphere = TriangleMesh::Icosphere(0.2, 3);
  const MeshSignedDistance sdf(sphere);
  ASSERT_TRUE(sdf.closed());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  int inside = 0;
  for (int i = 0; i < 1500; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const double w = WindingNumber(sphere, p);
    ASSERT_TRUE(std::abs(w) < 1e-9 || std::abs(w - 1) < 1e-9) << w;  // closed: 0 or 1 exactly
    const double d = sdf.Signed(p);
    EXPECT_EQ(d < 0, w > 0.5) << p.transpose();
    EXPECT_NEAR(std::abs(d), BruteDistance(sphere, p), 1e-14);
    inside += w > 0.5;
  }
  EXPECT_GT(inside, 100);
  EXPECT_LT(inside, 1400);
  // Points on the mesh's vertices pushed just in and out along the radius:
  // nearest feature a vertex, the hardest case for a sign.
  for (size_t v = 0; v < sphere.vertices.size(); v += 7) {
    const Eigen::Vector3d r = sphere.vertices[v].normalized();
    EXPECT_LT(sdf.Signed(sphere.vertices[v] - 1e-6 * r), 0) << v;
    EXPECT_GT(sdf.Signed(sphere.vertices[v] + 1e-6 * r), 0) << v;
  }
}

// A file's mesh carries a copy of each vertex per face (normals, texture
// coordinates): welded by position, it still bounds a volume. One triangle
// removed, or one flipped, it no longer does: the distance is then unsigned.
TEST(MeshSignedDistance, PerFaceVertexCopiesAreWeldedAndAnOpenMeshIsUnsigned) {
  const TriangleMesh box = TriangleMesh::Box(Eigen::Vector3d(0.1, 0.1, 0.1), 1.0);
  TriangleMesh split;
  for (const auto& t : box.triangles) {
    const int base = int(split.vertices.size());
    for (int k = 0; k < 3; ++k) split.vertices.push_back(box.vertices[size_t(t[k])]);
    split.triangles.emplace_back(base, base + 1, base + 2);
  }
  const MeshSignedDistance welded(split);
  EXPECT_TRUE(welded.closed());
  EXPECT_NEAR(welded.Signed(Eigen::Vector3d(0.02, 0, 0)), -0.08, 1e-12);

  TriangleMesh open = box;
  open.triangles.pop_back();
  const MeshSignedDistance surface(open);
  EXPECT_FALSE(surface.closed());
  EXPECT_NEAR(surface.Signed(Eigen::Vector3d(0.02, 0, 0)), 0.08, 1e-12);  // unsigned

  TriangleMesh flipped = box;
  std::swap(flipped.triangles[0][1], flipped.triangles[0][2]);
  EXPECT_FALSE(MeshSignedDistance(flipped).closed());
  // Every triangle wound the other way (a file's inside-out part): still
  // closed, its inside still inside.
  TriangleMesh inverted = box;
  for (auto& t : inverted.triangles) std::swap(t[1], t[2]);
  const MeshSignedDistance turned(inverted);
  EXPECT_TRUE(turned.closed());
  EXPECT_NEAR(turned.Signed(Eigen::Vector3d(0.02, 0, 0)), -0.08, 1e-12);
  EXPECT_NEAR(turned.Signed(Eigen::Vector3d(0.3, 0, 0)), 0.2, 1e-12);

  EXPECT_THROW(MeshSignedDistance(TriangleMesh{}), std::invalid_argument);
  TriangleMesh bad = box;
  bad.triangles[0][0] = 99;
  EXPECT_THROW(MeshSignedDistance{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace hullpipe
