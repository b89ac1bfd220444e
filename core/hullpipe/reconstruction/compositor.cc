#include "hullpipe/reconstruction/compositor.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/mesh.h"

namespace hullpipe {

namespace {

// Rasterises the meshes into out/depth (eye z), depth-tested.
void DrawMeshes(const NovelView& view, const MeshDraws& meshes, const Eigen::Vector3d& light,
                const CompositeOptions& o, cv::Mat* out, cv::Mat* depth, StopFlag stop) {
  const Rigid3d eye_from_world = view.world_from_eye.Inverse();
  const Eigen::Vector3d light_eye = eye_from_world.rotation * light;
  constexpr double kNear = 0.05;
  for (const VirtualMeshDraw* mp : meshes) {
    if (!mp) continue;
    const VirtualMeshDraw& m = *mp;
    std::vector<Eigen::Vector3d> e(m.vertices.size());  // eye frame
    for (size_t i = 0; i < e.size(); ++i) e[i] = eye_from_world * m.vertices[i];
    auto colour_of = [&](size_t k, double shade) {
      const bool hit = k < m.colliding.size() && m.colliding[k];
      const cv::Vec3b base = hit ? o.collide_colour : m.colour;
      cv::Vec3b c;
      for (int j = 0; j < 3; ++j) c[j] = cv::saturate_cast<uint8_t>(base[j] * shade);
      return c;
    };
    if (m.triangles.empty()) {
      for (size_t i = 0; i < e.size(); ++i) {
        const Eigen::Vector3d& p = e[i];
        if (p.z() < kNear) continue;
        const double u = view.fx * p.x() / p.z() + view.cx, v = view.fy * p.y() / p.z() + view.cy;
        const double r = std::max(0.7, view.fx * m.point_radius / p.z());
        const cv::Vec3b c = colour_of(i, 0.9);
        const int py0 = std::max(0, FloorPixel(v - r)), py1 = std::min(view.height - 1, CeilPixel(v + r));
        const int px0 = std::max(0, FloorPixel(u - r)), px1 = std::min(view.width - 1, CeilPixel(u + r));
        for (int y = py0; y <= py1; ++y)
          for (int x = px0; x <= px1; ++x) {
            const double dx = x + 0.5 - u, dy = y + 0.5 - v;
            if (dx * dx + dy * dy > r * r) continue;
            float& d = depth->at<float>(y, x);
            if (float(p.z()) >= d) continue;
            d = float(p.z());
            out->at<cv::Vec3b>(y, x) = c;
          }
      }
      continue;
    }
    // Each vertex projected once (shared by ~6 triangles in a closed mesh).
    std::vector<Eigen::Vector2d> P(e.size());
    std::vector<double> iz(e.size());
    for (size_t i = 0; i < e.size(); ++i) {
      if (e[i].z() < kNear) continue;
      iz[i] = 1.0 / e[i].z();
      P[i] = Eigen::Vector2d(view.fx * e[i].x() * iz[i] + view.cx, view.fy * e[i].y() * iz[i] + view.cy);
    }
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      if ((t & 1023) == 0) ThrowIfStopped(stop, "composite");
      const Eigen::Vector3i& tri = m.triangles[t];
      if ((tri.array() < 0).any() || (tri.array() >= int(e.size())).any()) continue;
      const size_t i0 = size_t(tri[0]), i1 = size_t(tri[1]), i2 = size_t(tri[2]);
      if (e[i0].z() < kNear || e[i1].z() < kNear || e[i2].z() < kNear) continue;  // no near clipping: skip
      const Eigen::Vector2d& p0 = P[i0];
      const Eigen::Vector2d& p1 = P[i1];
      const Eigen::Vector2d& p2 = P[i2];
      const double area = (p1 - p0).x() * (p2 - p0).y() - (p1 - p0).y() * (p2 - p0).x();
      if (std::abs(area) < 1e-12) continue;
      // Only pixels whose centre (x + 0.5, y + 0.5) lies in the triangle's box:
      // most of a CAD model's triangles cover no pixel centre at all.
      const double min_x = std::min(p0.x(), std::min(p1.x(), p2.x())),
                   max_x = std::max(p0.x(), std::max(p1.x(), p2.x()));
      const double min_y = std::min(p0.y(), std::min(p1.y(), p2.y())),
                   max_y = std::max(p0.y(), std::max(p1.y(), p2.y()));
      if (!(max_x >= 0.5 && max_y >= 0.5 && min_x <= view.width - 0.5 && min_y <= view.height - 0.5)) continue;
      const int x0 = std::max(0, CeilPixel(min_x - 0.5));
      const int x1 = std::min(view.width - 1, FloorPixel(max_x - 0.5));
      const int y0 = std::max(0, CeilPixel(min_y - 0.5));
      const int y1 = std::min(view.height - 1, FloorPixel(max_y - 0.5));
      if (x0 > x1 || y0 > y1) continue;
      const Eigen::Vector2d* V[3] = {&p0, &p1, &p2};
      const double z3[3] = {iz[i0], iz[i1], iz[i2]};
      bool shaded = false;
      cv::Vec3b col;
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const Eigen::Vector2d q(x + 0.5, y + 0.5);
          double w[3];
          for (int k = 0; k < 3; ++k) {
            const Eigen::Vector2d& a1 = *V[(k + 1) % 3];
            const Eigen::Vector2d& a2 = *V[(k + 2) % 3];
            w[k] = ((a2 - a1).x() * (q - a1).y() - (a2 - a1).y() * (q - a1).x()) / area;
          }
          if (w[0] < 0 || w[1] < 0 || w[2] < 0) continue;
          const double z = 1.0 / (w[0] * z3[0] + w[1] * z3[1] + w[2] * z3[2]);  // perspective-correct
          float& d = depth->at<float>(y, x);
          if (float(z) >= d) continue;
          if (!shaded) {  // only triangles that cover a pixel are shaded
            Eigen::Vector3d n = (e[i1] - e[i0]).cross(e[i2] - e[i0]);
            const double len = n.norm();
            const double shade = len > 1e-15 ? 0.35 + 0.65 * std::abs(n.dot(light_eye) / len) : 0.35;  // two-sided
            col = colour_of(t, shade);
            shaded = true;
          }
          d = float(z);
          out->at<cv::Vec3b>(y, x) = col;
        }
    }
  }
}

}  // namespace

VirtualMeshDraw BoxDraw(const VirtualObjectSample& box, const cv::Vec3b& colour) {
  Rigid3d world_from_body;
  world_from_body.rotation = box.orientation.normalized().toRotationMatrix();
  world_from_body.translation = box.position;
  const TriangleMesh mesh = TriangleMesh::Box(box.half_extents, 1e9).Transformed(world_from_body);
  VirtualMeshDraw d;
  d.vertices = mesh.vertices;
  d.triangles = mesh.triangles;
  d.colliding.assign(mesh.triangles.size(), box.colliding ? 1 : 0);
  d.colour = colour;
  return d;
}

cv::Mat Composite(const NovelView& view, const cv::Mat& hull_depth, const cv::Mat& hull_colour,
                  const std::vector<VirtualSphere>& spheres, const CompositeOptions& o,
                  cv::Mat* depth_out, const MeshDraws& meshes, StopFlag stop) {
  CV_Assert(hull_depth.type() == CV_32FC1 && hull_colour.type() == CV_8UC3);
  CV_Assert(hull_depth.cols == view.width && hull_depth.rows == view.height);
  CV_Assert(hull_colour.size() == hull_depth.size());
  cv::Mat out(view.height, view.width, CV_8UC3);
  cv::Mat depth(view.height, view.width, CV_32FC1);
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  const Eigen::Vector3d light = (-o.floor_normal + Eigen::Vector3d(0.3, 0.2, 0)).normalized() * -1.0;
  for (int r = 0; r < view.height; ++r) {
    ThrowIfStopped(stop, "composite");
    for (int c = 0; c < view.width; ++c) {
      const Eigen::Vector3d D = R * view.EyeRay(c + 0.5, r + 0.5);  // eye z of D is 1
      float best = hull_depth.at<float>(r, c);
      cv::Vec3b colour = std::isfinite(best) ? hull_colour.at<cv::Vec3b>(r, c) : cv::Vec3b(0, 0, 0);
      if (!std::isfinite(best)) {
        // Sky: a vertical gradient.
        const double up = std::clamp(-D.normalized().dot(-o.floor_normal) * 0.5 + 0.5, 0.0, 1.0);
        colour = cv::Vec3b(cv::saturate_cast<uint8_t>(120 + 100 * up),
                           cv::saturate_cast<uint8_t>(90 + 60 * up), cv::saturate_cast<uint8_t>(60 + 30 * up));
      }
      if (o.draw_floor) {
        const double denom = o.floor_normal.dot(D);
        if (std::abs(denom) > 1e-12) {
          const double s = (o.floor_offset - o.floor_normal.dot(O)) / denom;
          if (s > 0 && s < best) {
            best = float(s);
            const Eigen::Vector3d f = O + s * D;
            // Checkers of 0.5 m in the floor plane's two world axes most in it.
            const Eigen::Vector3d a = o.floor_normal.unitOrthogonal(), b = o.floor_normal.cross(a);
            const bool odd = (FloorPixel(f.dot(a) * 2) + FloorPixel(f.dot(b) * 2)) & 1;
            const double fade = std::exp(-0.08 * s);
            const cv::Vec3b base = odd ? cv::Vec3b(180, 180, 170) : cv::Vec3b(110, 110, 100);
            for (int k = 0; k < 3; ++k) colour[k] = cv::saturate_cast<uint8_t>(base[k] * (0.4 + 0.6 * fade));
          }
        }
      }
      for (const auto& sp : spheres) {
        const Eigen::Vector3d oc = O - sp.centre;
        const double A = D.squaredNorm(), B = oc.dot(D), C = oc.squaredNorm() - sp.radius * sp.radius;
        const double disc = B * B - A * C;
        if (disc < 0) continue;
        const double s = (-B - std::sqrt(disc)) / A;
        if (s <= 0 || s >= best) continue;
        best = float(s);
        const Eigen::Vector3d n = (O + s * D - sp.centre).normalized();
        const double shade = 0.3 + 0.7 * std::max(0.0, n.dot(light));
        const cv::Vec3b base = sp.colliding ? o.collide_colour : o.ball_colour;
        for (int k = 0; k < 3; ++k) colour[k] = cv::saturate_cast<uint8_t>(base[k] * shade);
      }
      out.at<cv::Vec3b>(r, c) = colour;
      depth.at<float>(r, c) = best;
    }
  }
  if (!meshes.empty()) DrawMeshes(view, meshes, light, o, &out, &depth, stop);
  if (depth_out) *depth_out = depth;
  return out;
}

Rigid3d OrbitPath::WorldFromEye(double t) const {
  const Eigen::Vector3d u = up.normalized();
  const Eigen::Vector3d a = u.unitOrthogonal(), b = u.cross(a);
  const double ang = phase + 2 * M_PI * t / period;
  const Eigen::Vector3d eye = centre + radius * (std::cos(ang) * a + std::sin(ang) * b) + height * u;
  return LookAt(eye, centre, u);
}

}  // namespace hullpipe
