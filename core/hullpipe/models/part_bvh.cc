#include "hullpipe/models/part_bvh.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>
#include <stdexcept>

namespace hullpipe {

TriangleBvh::TriangleBvh(const TriangleMesh& mesh, int leaf_size) {
  if (leaf_size < 1) throw std::invalid_argument("TriangleBvh: leaf_size must be >= 1");
  const int n = int(mesh.triangles.size());
  if (n == 0) return;
  std::vector<Aabb> boxes(static_cast<size_t>(n));
  std::vector<Eigen::Vector3d> centroids(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[size_t(t)];
    for (int c = 0; c < 3; ++c) {
      if (tri[c] < 0 || tri[c] >= int(mesh.vertices.size()))
        throw std::invalid_argument("TriangleBvh: triangle " + std::to_string(t) + " has an index out of range");
      boxes[size_t(t)].Extend(mesh.vertices[size_t(tri[c])]);
    }
    centroids[size_t(t)] = boxes[size_t(t)].Center();
  }
  order_.resize(size_t(n));
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(size_t(2 * (n / leaf_size + 1)));
  // Iterative build: (node index, first, count).
  struct Job {
    int node, first, count;
  };
  nodes_.push_back({});
  std::vector<Job> jobs{{0, 0, n}};
  while (!jobs.empty()) {
    const Job j = jobs.back();
    jobs.pop_back();
    Aabb box, cbox;
    for (int k = j.first; k < j.first + j.count; ++k) {
      const Aabb& b = boxes[size_t(order_[size_t(k)])];
      box.Extend(b.min), box.Extend(b.max);
      cbox.Extend(centroids[size_t(order_[size_t(k)])]);
    }
    nodes_[size_t(j.node)].box = box;
    const Eigen::Vector3d extent = cbox.max - cbox.min;
    int axis = 0;
    extent.maxCoeff(&axis);
    if (j.count <= leaf_size || !(extent[axis] > 0)) {
      nodes_[size_t(j.node)].first = j.first;
      nodes_[size_t(j.node)].count = j.count;
      continue;
    }
    const int mid = j.first + j.count / 2;
    std::nth_element(order_.begin() + j.first, order_.begin() + mid, order_.begin() + j.first + j.count,
                     [&](int a, int b) { return centroids[size_t(a)][axis] < centroids[size_t(b)][axis]; });
    const int left = int(nodes_.size());
    nodes_.push_back({});
    nodes_.push_back({});
    nodes_[size_t(j.node)].left = left;
    jobs.push_back({left, j.first, mid - j.first});
    jobs.push_back({left + 1, mid, j.first + j.count - mid});
  }
}

Aabb TransformBox(const Rigid3d& T, const Aabb& box) {
  if (box.empty()) return box;
  // Arvo's method: the moved box's half extents are |R| times the old ones.
  const Eigen::Vector3d c = T * box.Center();
  const Eigen::Vector3d h = T.rotation.cwiseAbs() * (0.5 * (box.max - box.min));
  Aabb out;
  out.min = c - h;
  out.max = c + h;
  return out;
}

std::vector<int> TriangleBvh::Candidates(const VolumeQuery& query, const Rigid3d& world_from_body, bool identity,
                                         int64_t* boxes_tested) const {
  std::vector<int> out;
  if (nodes_.empty()) return out;
  int64_t tested = 0;
  size_t hint = 0;
  std::vector<int> stack{0};
  while (!stack.empty()) {
    const Node& node = nodes_[size_t(stack.back())];
    stack.pop_back();
    ++tested;
    const Aabb box = identity ? node.box : TransformBox(world_from_body, node.box);
    if (query.ProvesEmpty(box, &hint)) continue;
    if (node.count > 0) {
      out.insert(out.end(), order_.begin() + node.first, order_.begin() + node.first + node.count);
    } else {
      stack.push_back(node.left + 1);
      stack.push_back(node.left);
    }
  }
  std::sort(out.begin(), out.end());
  if (boxes_tested) *boxes_tested += tested;
  return out;
}

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double den = d1 - d3;
    return den > 0 ? Eigen::Vector3d(a + (d1 / den) * ab) : a;
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double den = d2 - d6;
    return den > 0 ? Eigen::Vector3d(a + (d2 / den) * ac) : a;
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double den = (d4 - d3) + (d5 - d6);
    return den > 0 ? Eigen::Vector3d(b + ((d4 - d3) / den) * (c - b)) : b;
  }
  const double sum = va + vb + vc;
  if (!(std::abs(sum) > 0)) {
    // Degenerate (collinear) triangle: the nearest of its three edges.
    auto seg = [&](const Eigen::Vector3d& s, const Eigen::Vector3d& t) {
      const Eigen::Vector3d d = t - s;
      const double l2 = d.squaredNorm();
      const double u = l2 > 0 ? std::clamp((p - s).dot(d) / l2, 0.0, 1.0) : 0.0;
      return Eigen::Vector3d(s + u * d);
    };
    Eigen::Vector3d best = seg(a, b);
    for (const Eigen::Vector3d& q : {seg(b, c), seg(c, a)})
      if ((q - p).squaredNorm() < (best - p).squaredNorm()) best = q;
    return best;
  }
  const double denom = 1.0 / sum;
  return a + ab * (vb * denom) + ac * (vc * denom);
}

namespace {
double BoxDistance2(const Aabb& b, const Eigen::Vector3d& p) {
  const Eigen::Vector3d d = (b.min - p).cwiseMax(p - b.max).cwiseMax(0.0);
  return d.squaredNorm();
}
}  // namespace

double TriangleBvh::Distance(const TriangleMesh& mesh, const Eigen::Vector3d& p, double bound,
                             Eigen::Vector3d* closest, int* triangle) const {
  if (nodes_.empty()) return bound;
  double best2 = bound * bound;
  bool found = false;
  // Median splits keep the depth under 64 for any mesh that fits in memory;
  // the stack holds at most one pending sibling per level.
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[size_t(stack[--top])];
    if (BoxDistance2(node.box, p) >= best2) continue;
    if (node.count > 0) {
      for (int k = node.first; k < node.first + node.count; ++k) {
        const Eigen::Vector3i& t = mesh.triangles[size_t(order_[size_t(k)])];
        const Eigen::Vector3d q = ClosestPointOnTriangle(p, mesh.vertices[size_t(t[0])], mesh.vertices[size_t(t[1])],
                                                         mesh.vertices[size_t(t[2])]);
        const double d2 = (q - p).squaredNorm();
        if (d2 < best2) {
          best2 = d2;
          found = true;
          if (closest) *closest = q;
          if (triangle) *triangle = order_[size_t(k)];
        }
      }
      continue;
    }
    // Nearer child last (popped first).
    const int l = node.left, r = node.left + 1;
    const bool left_nearer = BoxDistance2(nodes_[size_t(l)].box, p) <= BoxDistance2(nodes_[size_t(r)].box, p);
    if (top + 2 > 128) throw std::logic_error("TriangleBvh::Distance: hierarchy deeper than its stack");
    stack[top++] = left_nearer ? r : l;
    stack[top++] = left_nearer ? l : r;
  }
  return found ? std::sqrt(best2) : bound;
}

namespace {
bool IsIdentity(const Rigid3d& T) {
  return T.rotation == Eigen::Matrix3d::Identity() && T.translation == Eigen::Vector3d::Zero();
}
}  // namespace

void GatherBvhTriangles(const VolumeQuery& query, const TriangleMesh& mesh, const TriangleBvh& bvh, const Rigid3d& T,
                        std::vector<Triangle>* triangles, std::vector<int>* ids, BvhQueryStats* stats) {
  const bool identity = IsIdentity(T);
  int64_t boxes = 0;
  const size_t before = triangles->size();
  for (int id : bvh.Candidates(query, T, identity, &boxes)) {
    const Eigen::Vector3i& t = mesh.triangles[size_t(id)];
    Triangle tri{mesh.vertices[size_t(t[0])], mesh.vertices[size_t(t[1])], mesh.vertices[size_t(t[2])]};
    if (!identity) tri = {T * tri.a, T * tri.b, T * tri.c};
    // DetectCollisions' own test, so the queried set is a subset of its own.
    Aabb tb;
    tb.Extend(tri.a), tb.Extend(tri.b), tb.Extend(tri.c);
    if (!tb.Intersects(query.hull_box())) continue;
    triangles->push_back(tri);
    ids->push_back(id);
  }
  if (stats) {
    stats->boxes_tested += boxes;
    stats->triangles_queried += int64_t(triangles->size() - before);
  }
}

CollisionResult DetectCollisionsBvh(const VolumeQuery& query, const TriangleMesh& mesh, const TriangleBvh& bvh,
                                    const Rigid3d& T, const TriangleQueryOptions& options,
                                    const TriangleBatchQuery& batch, int threads, BvhQueryStats* stats) {
  options.Check();
  CollisionResult result;
  if (stats) stats->triangles_in_scene += int64_t(mesh.triangles.size());
  const Aabb world_box = bvh.empty()   ? Aabb{}
                         : IsIdentity(T) ? bvh.nodes()[0].box
                                         : TransformBox(T, bvh.nodes()[0].box);
  result.box_overlap = world_box.Intersects(query.hull_box());
  std::vector<Triangle> tris;
  std::vector<int> kept;
  GatherBvhTriangles(query, mesh, bvh, T, &tris, &kept, stats);
  result.triangles_queried = int(tris.size());
  if (tris.empty()) return result;
  const std::vector<TriangleQueryResult> rs = batch ? batch(tris) : QueryTrianglesCpu(query, tris, options, threads);
  if (rs.size() != tris.size()) throw std::logic_error("DetectCollisionsBvh: batch query returned the wrong count");
  for (size_t k = 0; k < rs.size(); ++k) AddTriangleResult(kept[k], rs[k], &result);
  return result;
}

}  // namespace hullpipe

namespace hullpipe {

PartClearance HullToPartClearance(const VolumeQuery& q, const TriangleMesh& mesh, const TriangleBvh& bvh,
                                  const Rigid3d& T, double max_clearance, const HullSamples& coarse,
                                  double refine_below) {
  PartClearance r;
  r.distance = max_clearance;
  if (bvh.empty() || !(max_clearance > 0)) return r;
  const Rigid3d body_from_world = T.Inverse();
  Aabb region = TransformBox(T, bvh.nodes()[0].box);
  region.min -= Eigen::Vector3d::Constant(max_clearance);
  region.max += Eigen::Vector3d::Constant(max_clearance);
  double best = max_clearance;
  Eigen::Vector3d best_p = Eigen::Vector3d::Zero();
  bool found = false;
  auto distance = [&](const Eigen::Vector3d& p) {
    const double d = bvh.Distance(mesh, body_from_world * p, best);
    if (d < best) best = d, best_p = p, found = true;
  };
  // Nearest to the part's box first: once the box alone is farther than the
  // best found, no later sample can beat it.
  const Aabb part_box = TransformBox(T, bvh.nodes()[0].box);
  std::vector<std::pair<double, const Eigen::Vector3d*>> near;
  for (const Eigen::Vector3d& p : coarse.points)
    if (region.Contains(p)) near.emplace_back(BoxDistance2(part_box, p), &p);
  std::sort(near.begin(), near.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [d2, p] : near) {
    if (d2 >= best * best) break;
    distance(*p);
  }
  if (!found) return r;
  double h = coarse.step;
  for (int level = 0; level < 6 && best < refine_below; ++level) {
    Aabb window;
    window.min = best_p - Eigen::Vector3d::Constant(h);
    window.max = best_p + Eigen::Vector3d::Constant(h);
    window = window.Intersection(q.hull_box());
    h /= 2;
    if (window.empty()) break;
    ForEachGridPoint(window, h, [&](const Eigen::Vector3d& p) {
      if (BoxDistance2(part_box, p) < best * best && q.Inside(p)) distance(p);
    });
  }
  r.distance = best;
  r.hull_near = best < max_clearance;
  r.hull_point = best_p;
  return r;
}

PartClearance HullToPartClearance(const VolumeQuery& q, const TriangleMesh& mesh, const TriangleBvh& bvh,
                                  const Rigid3d& T, double max_clearance, double step) {
  if (bvh.empty()) return HullToPartClearance(q, mesh, bvh, T, max_clearance, HullSamples{});
  Aabb region = TransformBox(T, bvh.nodes()[0].box);
  region.min -= Eigen::Vector3d::Constant(max_clearance);
  region.max += Eigen::Vector3d::Constant(max_clearance);
  return HullToPartClearance(q, mesh, bvh, T, max_clearance, SampleHull(q, region, step));
}

}  // namespace hullpipe
