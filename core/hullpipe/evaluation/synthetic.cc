#include "hullpipe/evaluation/synthetic.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "hullpipe/geometry/rigid3.h"

namespace hullpipe {

Shape Shape::Sphere(const Eigen::Vector3d& c, double r) {
  Shape s;
  s.type = Type::kSphere;
  s.a = c;
  s.radius = r;
  return s;
}

Shape Shape::Box(const Eigen::Vector3d& c, const Eigen::Vector3d& half, const Eigen::Matrix3d& rot) {
  Shape s;
  s.type = Type::kBox;
  s.a = c;
  s.half_extents = half;
  s.rotation = rot;
  return s;
}

Shape Shape::Capsule(const Eigen::Vector3d& p, const Eigen::Vector3d& q, double r) {
  Shape s;
  s.type = Type::kCapsule;
  s.a = p;
  s.b = q;
  s.radius = r;
  return s;
}

Shape Shape::Torus(const Eigen::Vector3d& c, double R, double r, const Eigen::Matrix3d& rot) {
  Shape s;
  s.type = Type::kTorus;
  s.a = c;
  s.major_radius = R;
  s.radius = r;
  s.rotation = rot;
  return s;
}

namespace {
// Closest point of segment [a, b] to p.
Eigen::Vector3d ClosestOnSegment(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                 const Eigen::Vector3d& p) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * ab;
}

// Smallest root s >= 0 of |o + s d - c|^2 = r^2, or -1.
double RaySphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c,
                 double r) {
  const Eigen::Vector3d oc = o - c;
  const double A = d.squaredNorm(), B = oc.dot(d), C = oc.squaredNorm() - r * r;
  if (C <= 0) return 0;  // inside
  const double disc = B * B - A * C;
  if (disc < 0 || B > 0) return -1;
  return (-B - std::sqrt(disc)) / A;
}
}  // namespace

bool Shape::Contains(const Eigen::Vector3d& p) const {
  switch (type) {
    case Type::kSphere:
      return (p - a).squaredNorm() <= radius * radius;
    case Type::kBox: {
      const Eigen::Vector3d q = rotation.transpose() * (p - a);
      return (q.array().abs() <= half_extents.array()).all();
    }
    case Type::kCapsule:
      return (p - ClosestOnSegment(a, b, p)).squaredNorm() <= radius * radius;
    case Type::kTorus:
      return SignedDistance(p) <= 0;
  }
  return false;
}

double Shape::SignedDistance(const Eigen::Vector3d& p) const {
  switch (type) {
    case Type::kSphere:
      return (p - a).norm() - radius;
    case Type::kBox: {
      const Eigen::Vector3d q = (rotation.transpose() * (p - a)).cwiseAbs() - half_extents;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case Type::kCapsule:
      return (p - ClosestOnSegment(a, b, p)).norm() - radius;
    case Type::kTorus: {
      const Eigen::Vector3d q = rotation.transpose() * (p - a);
      const double ring = std::hypot(q.x(), q.y()) - major_radius;
      return std::hypot(ring, q.z()) - radius;
    }
  }
  return 0;
}

std::optional<double> Shape::Intersect(const Eigen::Vector3d& o, const Eigen::Vector3d& d) const {
  switch (type) {
    case Type::kSphere: {
      const double s = RaySphere(o, d, a, radius);
      if (s < 0) return std::nullopt;
      return s;
    }
    case Type::kBox: {
      const Eigen::Vector3d ob = rotation.transpose() * (o - a), db = rotation.transpose() * d;
      double lo = 0, hi = 1e300;
      for (int i = 0; i < 3; ++i) {
        if (std::abs(db[i]) < 1e-300) {
          if (std::abs(ob[i]) > half_extents[i]) return std::nullopt;
          continue;
        }
        double t0 = (-half_extents[i] - ob[i]) / db[i], t1 = (half_extents[i] - ob[i]) / db[i];
        if (t0 > t1) std::swap(t0, t1);
        lo = std::max(lo, t0);
        hi = std::min(hi, t1);
        if (lo > hi) return std::nullopt;
      }
      return lo;
    }
    case Type::kCapsule: {
      if (Contains(o)) return 0.0;
      // Infinite cylinder around the axis, clipped to the segment, then end caps.
      double best = -1;
      const Eigen::Vector3d ab = b - a;
      const double len2 = ab.squaredNorm();
      if (len2 > 0) {
        const Eigen::Vector3d ao = o - a;
        const Eigen::Vector3d dp = d - ab * (d.dot(ab) / len2);
        const Eigen::Vector3d op = ao - ab * (ao.dot(ab) / len2);
        const double A = dp.squaredNorm(), B = op.dot(dp), C = op.squaredNorm() - radius * radius;
        const double disc = B * B - A * C;
        if (A > 0 && disc >= 0) {
          const double s = (-B - std::sqrt(disc)) / A;
          const double t = (ao + s * d).dot(ab) / len2;
          if (s >= 0 && t >= 0 && t <= 1) best = s;
        }
      }
      for (const auto* c : {&a, &b}) {
        const double s = RaySphere(o, d, *c, radius);
        if (s >= 0 && (best < 0 || s < best)) best = s;
      }
      if (best < 0) return std::nullopt;
      return best;
    }
    case Type::kTorus: {
      // Sphere tracing: the distance is exact, so a step never crosses the surface.
      const double bound = RaySphere(o, d, a, major_radius + radius);
      if (bound < 0) return std::nullopt;
      const double dn = d.norm();
      double s = bound;
      for (int it = 0; it < 4000; ++it) {
        const double dist = SignedDistance(o + s * d);
        if (dist < 1e-10) return s;
        s += dist / dn;
        if ((o + s * d - a).norm() > major_radius + radius + 1e-9 && (o + s * d - a).dot(d) > 0) break;
      }
      return std::nullopt;
    }
  }
  return std::nullopt;
}

Eigen::Vector3d Shape::Normal(const Eigen::Vector3d& p) const {
  switch (type) {
    case Type::kSphere:
      return (p - a).normalized();
    case Type::kBox: {
      const Eigen::Vector3d q = rotation.transpose() * (p - a);
      int axis = 0;
      double best = -1e300;
      for (int i = 0; i < 3; ++i) {
        const double closeness = std::abs(q[i]) - half_extents[i];
        if (closeness > best) best = closeness, axis = i;
      }
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[axis] = q[axis] >= 0 ? 1 : -1;
      return rotation * n;
    }
    case Type::kCapsule:
      return (p - ClosestOnSegment(a, b, p)).normalized();
    case Type::kTorus: {
      const Eigen::Vector3d q = rotation.transpose() * (p - a);
      const double rho = std::hypot(q.x(), q.y());
      const Eigen::Vector3d ring = rho > 0 ? Eigen::Vector3d(q.x() * major_radius / rho, q.y() * major_radius / rho, 0)
                                           : Eigen::Vector3d::Zero();
      return rotation * (q - ring).normalized();
    }
  }
  return Eigen::Vector3d::UnitZ();
}

bool SyntheticScene::Contains(const Eigen::Vector3d& p) const {
  return std::any_of(shapes.begin(), shapes.end(), [&](const Shape& s) { return s.Contains(p); });
}

std::optional<std::pair<double, int>> SyntheticScene::Intersect(const Eigen::Vector3d& o,
                                                                const Eigen::Vector3d& d) const {
  std::optional<std::pair<double, int>> best;
  for (size_t i = 0; i < shapes.size(); ++i) {
    const auto s = shapes[i].Intersect(o, d);
    if (s && (!best || *s < best->first)) best = std::make_pair(*s, int(i));
  }
  return best;
}

SyntheticScene AnimatedFigure(double t) {
  // z is down: heights are negative z.
  auto P = [](double x, double y, double h) { return Eigen::Vector3d(x, y, -h); };
  SyntheticScene s;
  const cv::Vec3b skin{120, 150, 210}, shirt{150, 60, 40}, jeans{90, 50, 30};
  auto add = [&](Shape sh, cv::Vec3b c) {
    sh.colour = c;
    s.shapes.push_back(sh);
  };
  add(Shape::Sphere(P(0, 0, 1.58), 0.11), skin);                    // head
  add(Shape::Capsule(P(0, 0, 1.05), P(0, 0, 1.35), 0.17), shirt);   // torso
  add(Shape::Capsule(P(-0.1, 0, 0.1), P(-0.1, 0, 0.9), 0.07), jeans);  // legs
  add(Shape::Capsule(P(0.1, 0, 0.1), P(0.1, 0, 0.9), 0.07), jeans);
  add(Shape::Capsule(P(-0.24, 0, 1.38), P(-0.3, 0, 0.95), 0.05), shirt);  // left arm down
  // Right arm: upper arm raised sideways, forearm + hand waving (period 4 s).
  const double phase = 2 * M_PI * t / 4.0;
  const Eigen::Vector3d shoulder = P(0.24, 0, 1.38);
  const Eigen::Vector3d elbow = shoulder + Eigen::Vector3d(0.28, 0.05 * std::sin(phase), 0.02);
  const double ang = 0.6 * std::sin(phase);
  const Eigen::Vector3d hand = elbow + 0.27 * Eigen::Vector3d(std::sin(ang), 0.3 * std::cos(phase), -std::cos(ang));
  add(Shape::Capsule(shoulder, elbow, 0.045), shirt);
  add(Shape::Capsule(elbow, hand, 0.04), skin);
  add(Shape::Sphere(hand + 0.05 * (hand - elbow).normalized(), 0.05), skin);  // hand
  return s;
}

SyntheticScene HandAndForearm(double t, const Eigen::Vector3d& wrist) {
  SyntheticScene s;
  const cv::Vec3b skin{120, 150, 210}, sleeve{150, 60, 40};
  const double phase = 2 * M_PI * t / 3.0;
  const double open = 0.5 + 0.5 * std::sin(phase);  // 0 fist-ish, 1 open
  // Hand frame: x along the hand (wrist to fingers), y across the palm, z the palm
  // normal; turning slowly about x.
  const Eigen::Matrix3d R =
      (Eigen::AngleAxisd(0.4 * std::sin(0.5 * phase), Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  auto H = [&](double x, double y, double z) { return Eigen::Vector3d(wrist + R * Eigen::Vector3d(x, y, z)); };
  auto add = [&](Shape sh, cv::Vec3b c) {
    sh.colour = c;
    s.shapes.push_back(sh);
  };
  add(Shape::Capsule(H(-0.26, 0, 0), H(-0.02, 0, 0), 0.032), sleeve);  // forearm
  add(Shape::Capsule(H(0.0, -0.025, 0), H(0.07, -0.03, 0), 0.016), skin);  // palm, three strips
  add(Shape::Capsule(H(0.0, 0.0, 0), H(0.075, 0.0, 0), 0.016), skin);
  add(Shape::Capsule(H(0.0, 0.025, 0), H(0.07, 0.03, 0), 0.016), skin);
  // Fingers: base across the palm's end, spread by `open`, curled by 1 - open.
  const double ys[4] = {-0.033, -0.011, 0.011, 0.033};
  const double lens[4] = {0.07, 0.08, 0.075, 0.06};
  for (int f = 0; f < 4; ++f) {
    const double spread = (f - 1.5) * 0.12 * open;
    const double curl = 0.9 * (1 - open);
    Eigen::Vector3d p = H(0.08, ys[f], 0);
    Eigen::Vector3d dir = R * Eigen::Vector3d(std::cos(spread), std::sin(spread), 0);
    const Eigen::Vector3d bend_axis = R * Eigen::Vector3d::UnitY();
    for (int seg = 0; seg < 3; ++seg) {
      const Eigen::Vector3d q = p + dir * (lens[f] / 3.0);
      add(Shape::Capsule(p, q, 0.0085 - 0.001 * seg), skin);
      p = q;
      dir = Eigen::AngleAxisd(curl * 0.6, bend_axis) * dir;
    }
  }
  // Thumb: two segments from the palm's side, swinging in and out.
  const Eigen::Vector3d t0 = H(0.02, -0.04, 0.0);
  const Eigen::Vector3d t1 = t0 + R * Eigen::Vector3d(0.03, -0.03 * (0.5 + open), 0.01);
  const Eigen::Vector3d t2 = t1 + R * Eigen::Vector3d(0.035, -0.01 * open, 0.005);
  add(Shape::Capsule(t0, t1, 0.011), skin);
  add(Shape::Capsule(t1, t2, 0.0095), skin);
  return s;
}

SyntheticScene NamedScene(const std::string& name, double t) {
  const Eigen::Vector3d c(0, 0, -1.0);
  const Eigen::Vector3d drift(0.1 * std::sin(2 * M_PI * t / 5.0), 0.1 * std::cos(2 * M_PI * t / 5.0), 0);
  SyntheticScene s;
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(0.5 + 0.3 * t, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  if (name == "sphere") {
    s.shapes.push_back(Shape::Sphere(c + drift, 0.3));
  } else if (name == "box") {
    s.shapes.push_back(Shape::Box(c + drift, {0.25, 0.15, 0.1}, turn));
  } else if (name == "torus") {
    s.shapes.push_back(Shape::Torus(c + drift, 0.25, 0.08, turn));
  } else if (name == "hand") {
    return HandAndForearm(t, c + drift);
  } else if (name == "figure") {
    return AnimatedFigure(t);
  } else if (name == "mixed") {
    s.shapes.push_back(Shape::Sphere(c + drift + Eigen::Vector3d(-0.35, 0.1, 0.1), 0.15));
    s.shapes.push_back(Shape::Box(c + drift + Eigen::Vector3d(0.3, -0.2, 0.15), {0.12, 0.08, 0.1}, turn));
    s.shapes.push_back(Shape::Torus(c + drift + Eigen::Vector3d(0.05, 0.25, -0.1), 0.16, 0.05, turn));
    s.shapes.push_back(Shape::Capsule(c + drift + Eigen::Vector3d(-0.2, -0.3, 0.2),
                                      c + drift + Eigen::Vector3d(0.1, -0.1, -0.25), 0.05));
  } else {
    throw std::invalid_argument("unknown synthetic scene '" + name +
                                "' (sphere, box, torus, hand, figure, mixed)");
  }
  return s;
}

Camera LookingCamera(int id, const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up,
                     int width, int height_px, double hfov, const Distortion& distortion) {
  Camera c;
  c.id = id;
  c.width = width;
  c.height = height_px;
  c.fx = c.fy = 0.5 * width / std::tan(0.5 * hfov);
  c.cx = 0.5 * width;
  c.cy = 0.5 * height_px;
  c.distortion = distortion;
  c.cam_from_world = LookAt(eye, target, up).Inverse();
  return c;
}

std::vector<Camera> DomeCameras(int n, double radius, const Eigen::Vector3d& target, int width, int height_px,
                                double hfov, const Distortion& distortion) {
  std::vector<Camera> cams;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double f = n > 1 ? double(i) / double(n - 1) : 0.5;
    const double elev = (15.0 + 55.0 * f) * M_PI / 180.0, az = golden * i + 0.3;
    // z is down: "above" is -z.
    const Eigen::Vector3d eye = target + radius * Eigen::Vector3d(std::cos(elev) * std::cos(az),
                                                                  std::cos(elev) * std::sin(az), -std::sin(elev));
    const Eigen::Vector3d up = std::abs(std::sin(elev)) > 0.99 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 0, -1);
    cams.push_back(LookingCamera(i + 1, eye, target, up, width, height_px, hfov, distortion));
  }
  return cams;
}

std::vector<Camera> RingCameras(int n, double radius, double height, const Eigen::Vector3d& target,
                                int width, int height_px, double hfov, const Distortion& distortion) {
  std::vector<Camera> cams;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n + 0.3;
    const Eigen::Vector3d eye(target.x() + radius * std::cos(a), target.y() + radius * std::sin(a), -height);
    cams.push_back(LookingCamera(i + 1, eye, target, Eigen::Vector3d(0, 0, -1), width, height_px, hfov, distortion));
  }
  return cams;
}

cv::Mat RenderExactMap(const Camera& camera, const SyntheticScene& scene) {
  cv::Mat map(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  const Eigen::Vector3d o = camera.Center();
  for (int r = 0; r < camera.height; ++r)
    for (int c = 0; c < camera.width; ++c) {
      const Eigen::Vector3d d = camera.PixelRayWorld({c + 0.5, r + 0.5});
      if (scene.Intersect(o, d)) map.at<uint8_t>(r, c) = 255;
    }
  return map;
}

cv::Mat RenderColour(const Camera& camera, const SyntheticScene& scene) {
  cv::Mat img(camera.height, camera.width, CV_8UC3);
  const Eigen::Vector3d o = camera.Center();
  const Eigen::Vector3d light = Eigen::Vector3d(0.3, -0.4, -1.0).normalized();  // towards light
  for (int r = 0; r < camera.height; ++r)
    for (int c = 0; c < camera.width; ++c) {
      const Eigen::Vector3d d = camera.PixelRayWorld({c + 0.5, r + 0.5});
      cv::Vec3b px;
      if (const auto hit = scene.Intersect(o, d)) {
        const Shape& sh = scene.shapes[size_t(hit->second)];
        const Eigen::Vector3d p = o + hit->first * d;
        const double lambert = 0.35 + 0.65 * std::max(0.0, sh.Normal(p).dot(light));
        for (int k = 0; k < 3; ++k) px[k] = cv::saturate_cast<uint8_t>(sh.colour[k] * lambert);
      } else if (d.z() > 1e-9 && (-o.z() / d.z()) > 0) {
        // Floor z = 0: green checkers of 0.5 m.
        const Eigen::Vector3d f = o + (-o.z() / d.z()) * d;
        const bool odd = (int(std::floor(f.x() * 2)) + int(std::floor(f.y() * 2))) & 1;
        px = odd ? cv::Vec3b(110, 150, 40) : cv::Vec3b(90, 130, 30);
      } else {
        px = cv::Vec3b(215, 220, 210);  // wall
      }
      img.at<cv::Vec3b>(r, c) = px;
    }
  return img;
}

Eigen::Vector3d SmoothHullNormal(const SyntheticScene& scene, const std::vector<Eigen::Vector3d>& centres,
                                 const Eigen::Vector3d& X, double edge_tolerance, bool* on_edge) {
  auto sdf = [&](const Eigen::Vector3d& p) {
    double d = 1e300;
    for (const auto& sh : scene.shapes) d = std::min(d, sh.SignedDistance(p));
    return d;
  };
  struct Graze {
    double dist;
    Eigen::Vector3d point, dir;
  };
  std::vector<Graze> g;
  for (const Eigen::Vector3d& C : centres) {
    const Eigen::Vector3d d = (X - C).normalized();
    const double t_end = (X - C).norm() + 2.0, step = 0.002;
    double best_t = 0.05, best = sdf(C + best_t * d);
    for (double t = 0.05; t <= t_end; t += step) {
      const double v = sdf(C + t * d);
      if (v < best) best = v, best_t = t;
    }
    // Golden section on [best_t - step, best_t + step].
    double lo = std::max(0.0, best_t - step), hi = best_t + step;
    const double r = (std::sqrt(5.0) - 1) / 2;
    double x1 = hi - r * (hi - lo), x2 = lo + r * (hi - lo);
    double f1 = sdf(C + x1 * d), f2 = sdf(C + x2 * d);
    while (hi - lo > 1e-7) {
      if (f1 < f2) {
        hi = x2, x2 = x1, f2 = f1, x1 = hi - r * (hi - lo), f1 = sdf(C + x1 * d);
      } else {
        lo = x1, x1 = x2, f1 = f2, x2 = lo + r * (hi - lo), f2 = sdf(C + x2 * d);
      }
    }
    const double t = 0.5 * (lo + hi);
    g.push_back({sdf(C + t * d), C + t * d, d});
  }
  // The line nearest to grazing; lines through the shape's inside have dist < 0.
  std::sort(g.begin(), g.end(), [](const Graze& a, const Graze& b) { return std::abs(a.dist) < std::abs(b.dist); });
  if (on_edge) *on_edge = g.size() > 1 && std::abs(g[1].dist) - std::abs(g[0].dist) < edge_tolerance;
  auto normal_at = [&](double h) {
    Eigen::Vector3d grad;
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d e = Eigen::Vector3d::Zero();
      e[k] = h;
      grad[k] = (sdf(g[0].point + e) - sdf(g[0].point - e)) / (2 * h);
    }
    grad -= grad.dot(g[0].dir) * g[0].dir;
    return Eigen::Vector3d(grad.normalized());
  };
  const Eigen::Vector3d n = normal_at(1e-6);
  // A crease of the shape (a box's edge) within ~2 mm of the tangent point: the
  // silhouette has a corner there and the hull's normal is undefined too.
  if (on_edge && n.dot(normal_at(2e-3)) < std::cos(5.0 * M_PI / 180.0)) *on_edge = true;
  return n;
}

}  // namespace hullpipe
