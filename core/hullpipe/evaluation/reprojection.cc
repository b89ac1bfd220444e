#include "hullpipe/evaluation/reprojection.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/util/parallel.h"
#include "hullpipe/geometry/conventions.h"

namespace hullpipe {

cv::Mat ReprojectHull(const VolumeQuery& q, const Camera& camera, double step, int threads) {
  cv::Mat out(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  const Aabb& box = q.hull_box();
  if (box.empty()) return out;
  const auto& cams = q.fast();
  const size_t n = cams.size();
  const Eigen::Vector3d O = camera.Center();
  std::vector<Eigen::Vector3f> A(n);
  for (size_t c = 0; c < n; ++c) A[c] = (q.views()[c].camera.cam_from_world * O).cast<float>();
  // A camera of the query centred where this one is sees every ray of this camera
  // as a single point: if that point is not on its object pixels the whole ray is
  // outside, so it is tested once before marching (the iou_all case).
  std::vector<size_t> same_centre;
  for (size_t c = 0; c < n; ++c)
    if ((q.views()[c].camera.Center() - O).norm() < 1e-9) same_centre.push_back(c);
  auto rows = [&](int r0, int r1) {
    std::vector<Eigen::Vector3f> B(n);
    for (int r = r0; r < r1; ++r) {
      for (int col = 0; col < camera.width; ++col) {
        const Eigen::Vector3d D = camera.PixelRayWorld({col + 0.5, r + 0.5});
        double s0 = 0, s1 = 1e9;
        if (!box.ClipRay(O, D, &s0, &s1)) continue;
        for (size_t c = 0; c < n; ++c) B[c] = (q.views()[c].camera.cam_from_world.rotation * D).cast<float>();
        bool possible = true;
        for (size_t c : same_centre) {
          const Eigen::Vector3f X = A[c] + float(0.5 * (s0 + s1)) * B[c];
          const Vote v = VolumeQuery::VoteFast(cams[c], X.x(), X.y(), X.z());
          possible = possible && !q.Vetoes(v);
        }
        if (!possible) continue;
        for (double s = s0; s <= s1; s += step) {
          int object = 0, unseen = 0;
          bool rejected = false;
          for (size_t c = 0; c < n && !rejected; ++c) {
            const Eigen::Vector3f X = A[c] + float(s) * B[c];
            const Vote v = VolumeQuery::VoteFast(cams[c], X.x(), X.y(), X.z());
            rejected = q.Vetoes(v);
            object += v == Vote::kObject;
            unseen += v == Vote::kUnseen;
          }
          const bool inside = !rejected && q.Accepts(object, unseen);
          if (inside) {
            out.at<uint8_t>(r, col) = 255;
            break;
          }
        }
      }
    }
  };
  ForEachRowBand(camera.height, threads, [&](int r0, int r1, int) { rows(r0, r1); });
  return out;
}

namespace {

// camera.Project(X), inlined for a pinhole camera (`pinhole`: !HasDistortion();
// the same arithmetic, as a pinhole's valid radius is unbounded and its
// distortion the identity). False where X does not project.
inline bool ProjectTo(const Camera& camera, bool pinhole, const Eigen::Vector3d& X, Eigen::Vector2d* uv) {
  if (!pinhole) {
    const auto p = camera.Project(X);
    if (p) *uv = *p;
    return p.has_value();
  }
  const Eigen::Vector3d xc = camera.cam_from_world * X;
  if (!(xc.z() > 1e-9)) return false;
  *uv = camera.PixelFromImagePlane({xc.x() / xc.z(), xc.y() / xc.z()});
  return true;
}

// One camera's object-pixel map prepared for walking rays across it: per pixel,
// the distance (px, centre to centre) to the nearest pixel of the other vote, so
// a walk crosses a uniform region in a few long steps instead of pixel by pixel.
struct SilhouetteWalker {
  const Camera* camera = nullptr;
  const cv::Mat* map = nullptr;
  bool pinhole = false;  // !camera->HasDistortion()
  cv::Mat distance;  // CV_32FC1

  SilhouetteWalker(const Camera& c, const cv::Mat& m) : camera(&c), map(&m), pinhole(!c.HasDistortion()) {}

  // Computes `distance` (before any At or Walk).
  void Prepare() {
    cv::Mat to_background, to_object;
    cv::distanceTransform(*map != 0, to_background, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::distanceTransform(*map == 0, to_object, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    distance = to_background + to_object;  // each pixel has one of them zero
  }

  // `safe` where a point does not project (behind the camera, beyond the lens's
  // valid radius). Any other value, negative ones included (a pixel beside one of
  // the other vote), is a projection's.
  static constexpr double kNotProjecting = -std::numeric_limits<double>::infinity();
  static bool Projects(double safe) { return safe != kNotProjecting; }

  // The vote at X, and `safe`: how far (px) its projection can move and keep it
  // (kNotProjecting where it does not project).
  Vote At(const Eigen::Vector3d& X, Eigen::Vector2d* uv, double* safe) const {
    if (!ProjectTo(*camera, pinhole, X, uv)) {
      *safe = kNotProjecting;
      return Vote::kUnseen;
    }
    const Eigen::Vector2d* p = uv;
    const double u = p->x(), v = p->y(), w = camera->width, h = camera->height;
    if (!camera->InImage(*p)) {
      const double du = std::max({0.0, -u, u - w}), dv = std::max({0.0, -v, v - h});
      *safe = std::sqrt(du * du + dv * dv);
      return Vote::kUnseen;
    }
    const int col = std::min(int(u), camera->width - 1), row = std::min(int(v), camera->height - 1);
    // A point in pixel P is within 0.71 px of its centre, and so is any point of
    // the nearest pixel of the other vote of that pixel's centre.
    const double border = std::min({u, v, w - u, h - v});
    *safe = std::min(double(distance.at<float>(row, col)) - 1.42, border);
    return map->at<uint8_t>(row, col) ? Vote::kObject : Vote::kBackground;
  }

  // A pinhole camera: where on O + s D, s in [s0, s1), the vote first differs
  // from `vote`, found exactly: the projection is a straight segment, so its
  // vote changes only where it crosses a pixel line u = k or v = k (the image's
  // border among them); each crossing is solved in closed form in s and the
  // vote taken between consecutive crossings. uv0, uv1: the projections at s0,
  // s1 (both in front of the camera). Returns 1 with *at and *far (the vote
  // beyond) at the first change, 0 if there is none, -1 if the step crosses
  // more than 64 lines (the caller steps shorter).
  int FirstChange(const Eigen::Vector3d& O, const Eigen::Vector3d& D, double s0, double s1,
                  const Eigen::Vector2d& uv0, const Eigen::Vector2d& uv1, Vote vote, double* at, Vote* far) const {
    const Eigen::Vector3d P = camera->cam_from_world * O, Q = camera->cam_from_world.rotation * D;
    std::array<double, 66> cuts;
    size_t n = 0;
    cuts[n++] = s0;
    // u(s) = fx (P.x + s Q.x) / (P.z + s Q.z) + cx = k  <=>  s = (a P.z - P.x) / (Q.x - a Q.z), a = (k - cx) / fx;
    // with skew, P.x and Q.x become P.x + (skew / fx) P.y and Q.x + (skew / fx) Q.y.
    auto add_lines = [&](double w0, double w1, double f, double c, double p, double q) {
      const double lo = std::min(w0, w1), hi = std::max(w0, w1);
      for (double k = std::floor(lo) + 1; k <= hi; k += 1) {
        if (n + 1 >= cuts.size()) return false;
        const double a = (k - c) / f;
        const double den = q - a * Q.z();
        if (den == 0) continue;
        const double sk = (a * P.z() - p) / den;
        if (sk > s0 && sk < s1) cuts[n++] = sk;
      }
      return true;
    };
    const double shear = camera->skew / camera->fx;
    if (!add_lines(uv0.x(), uv1.x(), camera->fx, camera->cx, P.x() + shear * P.y(), Q.x() + shear * Q.y()) ||
        !add_lines(uv0.y(), uv1.y(), camera->fy, camera->cy, P.y(), Q.y()))
      return -1;
    std::sort(cuts.begin() + 1, cuts.begin() + long(n));
    cuts[n] = s1;
    for (size_t i = 0; i < n; ++i) {
      if (!(cuts[i + 1] > cuts[i])) continue;
      Eigen::Vector2d uv_m;
      double safe_m;
      // Between two crossings the projection stays in one pixel (or off the
      // image): one vote. At s0 itself a point on a line may round to the pixel
      // behind the walk; the change is then at s0.
      const Vote v = At(O + (0.5 * (cuts[i] + cuts[i + 1])) * D, &uv_m, &safe_m);
      if (v != vote) {
        *at = cuts[i];
        *far = v;
        return 1;
      }
    }
    return 0;
  }

  // Camera's votes along O + s D, s in [lo, hi]: sorted, covering, merged.
  // A pinhole camera: steps as long as the map's distance transform allows
  // (checked exactly: the projection is a straight segment from the centre of
  // the safe disk), and where that is under 4 px, 4-px steps scanned pixel by
  // pixel (FirstChange): every change of vote found, in closed form. A distorted
  // camera: quarter-pixel steps near a change, each bisected to 2^-14 of its
  // step (1.5e-5 px; a pixel corner cut by under ~0.25 px can be missed).
  void Walk(const Eigen::Vector3d& O, const Eigen::Vector3d& D, double lo, double hi,
            std::vector<VoteSegment>* out) const {
    out->clear();
    constexpr double kMinStepPx = 0.25, kScanPx = 4.0;
    Eigen::Vector2d uv, uv_next;
    double safe = 0, safe_next = 0;
    double s = lo;
    Vote vote = At(O + s * D, &uv, &safe);
    double seg_start = lo;
    const double span = hi - lo;
    auto change_at = [&](double at, Vote far) {
      if (at > seg_start) out->push_back({seg_start, at, vote});
      seg_start = at;
      s = at;
      At(O + s * D, &uv, &safe);  // where the walk goes on from
      vote = far;                 // the far side's vote, also at the boundary itself
    };
    while (s < hi) {
      const bool scan = pinhole && Projects(safe);
      // The step in s that moves the projection about max(safe, 1/4 or 4) px.
      const double want_px = std::max(safe, scan ? kScanPx : kMinStepPx);
      double ds;
      if (!Projects(safe)) {
        ds = 1e-3 * span;  // not projecting here: small fixed steps
      } else {
        // Pinhole speed of the projection along the ray (distortion changes it
        // little; the checks below keep the step safe either way).
        const Eigen::Vector3d a = camera->cam_from_world * (O + s * D), b = camera->cam_from_world.rotation * D;
        const double iz2 = 1.0 / (a.z() * a.z());
        const double speed = std::hypot((camera->fx * (b.x() * a.z() - a.x() * b.z()) +
                                         camera->skew * (b.y() * a.z() - a.y() * b.z())) * iz2,
                                        camera->fy * (b.y() * a.z() - a.y() * b.z()) * iz2);
        ds = speed > 0 ? want_px / speed : span;
      }
      ds = std::min(std::max(ds, 1e-9 * std::max(1.0, span)), hi - s);
      Vote next = At(O + (s + ds) * D, &uv_next, &safe_next);
      if (scan && Projects(safe_next)) {
        // Within the safe disk: one vote all the way.
        if ((uv_next - uv).norm() <= safe && next == vote) {
          s += ds, uv = uv_next, safe = safe_next;
          continue;
        }
        double at = 0;
        Vote far = next;
        int found = FirstChange(O, D, s, s + ds, uv, uv_next, vote, &at, &far);
        for (int k = 0; k < 30 && found == -1; ++k) {
          // Too many lines (the projection sped up along the step): shorter.
          ds *= 0.25;
          next = At(O + (s + ds) * D, &uv_next, &safe_next);
          far = next;
          found = FirstChange(O, D, s, s + ds, uv, uv_next, vote, &at, &far);
        }
        if (found == 1) {
          change_at(at, far);
          continue;
        }
        if (found == 0 && next == vote) {
          s += ds, uv = uv_next, safe = safe_next;
          continue;
        }
        // Else rounding left the end's vote unexplained: bisected below.
      } else {
        // The chord may not leave the safe disk: shrink until its end agrees.
        for (int k = 0; k < 30 && safe >= kMinStepPx && next != vote; ++k) {
          ds *= 0.5;
          next = At(O + (s + ds) * D, &uv_next, &safe_next);
        }
      }
      if (next != vote) {
        // A change within this step: bisect for it.
        double a = s, b = s + ds;
        for (int k = 0; k < 14; ++k) {
          const double m = 0.5 * (a + b);
          Eigen::Vector2d uv_m;
          double safe_m;
          (At(O + m * D, &uv_m, &safe_m) == vote ? a : b) = m;
        }
        change_at(b, next);
        continue;
      }
      s += ds;
      uv = uv_next;
      safe = safe_next;
    }
    out->push_back({seg_start, hi, vote});
  }
};

// Every camera but one, for classifying whole tiles of that one's pixels: the
// rays of a tile, at depths [z_near, z_far] of the tile's camera, fill a frustum
// (a convex solid); where it projects into another camera onto background only,
// every ray of the tile is outside the hull; onto object pixels only in every
// other camera (and inside the workspace), every ray meets it.
struct TileClassifier {
  struct Other {
    const Camera* camera;
    const cv::Mat* sum;  // integral image of map != 0 (CV_32S, (h+1) x (w+1))
    const SilhouetteWalker* walker;  // its distance transform
    /// Margin (px) around the sampled projection: 2 where this camera or the
    /// tile's is distorted (the projection bends between the samples), else 0.
    double margin;

    bool Project(const Eigen::Vector3d& X, Eigen::Vector2d* uv) const {
      return ProjectTo(*camera, walker->pinhole, X, uv);
    }
  };
  bool distorted = false;  // the tile's camera or one of the others: sample 27 points, not 8
  std::vector<Other> others;
  const Camera* camera;
  double z_near, z_far;
  Aabb workspace, hull_box;
  // Other cameras that must see a point of the cell for it to be inside: where
  // the tile's own map has an object pixel, one fewer than the whole query needs
  // (VolumeQuery::required_seen, the tile's camera counted, for `all`); where it
  // has none, `all` is empty there and only the leave-one-out hull, without the
  // tile's camera, is looked for (its required_seen).
  int others_needed_own_object = 0, others_needed_own_background = 1;
  const cv::Mat* own_sum = nullptr;  // integral image of the tile's camera's map != 0

  enum class Kind { kEmpty, kFull, kMixed };

  // `hint`: the other camera that emptied the caller's last empty cell, tried
  // first (neighbouring cells are mostly emptied by the same camera); updated.
  Kind Classify(int c0, int r0, int c1, int r1, double zn, double zf, size_t* hint) const {
    // The frustum is convex: with pinholes its 8 corners bound its projection;
    // a distorted camera also gets the edge and face midpoints (27 points). The
    // centre comes first, for the disk test.
    struct Points {
      std::array<Eigen::Vector3d, 28> p;
      size_t n = 0;
      void push_back(const Eigen::Vector3d& x) { p[n++] = x; }
      size_t size() const { return n; }
      const Eigen::Vector3d& operator[](size_t k) const { return p[k]; }
      const Eigen::Vector3d* begin() const { return p.data(); }
      const Eigen::Vector3d* end() const { return p.data() + n; }
    } pts;
    const Eigen::Vector3d O = camera->Center();
    const Eigen::Matrix3d world_from_cam = camera->cam_from_world.rotation.transpose();
    auto point = [&](double u, double v, double z) {
      const Eigen::Vector2d xn = camera->Undistort(camera->ImagePlaneFromPixel({u, v}));
      return Eigen::Vector3d(O + z * (world_from_cam * Eigen::Vector3d(xn.x(), xn.y(), 1.0)));
    };
    pts.push_back(point(0.5 * (c0 + c1), 0.5 * (r0 + r1), 0.5 * (zn + zf)));
    for (double u : {double(c0), 0.5 * (c0 + c1), double(c1)})
      for (double v : {double(r0), 0.5 * (r0 + r1), double(r1)})
        for (double z : {zn, 0.5 * (zn + zf), zf}) {
          const bool corner = u != 0.5 * (c0 + c1) && v != 0.5 * (r0 + r1) && z != 0.5 * (zn + zf);
          if (distorted || corner) pts.push_back(point(u, v, z));
        }
    // Outside the hull's box (which the workspace holds): nothing to meet.
    Aabb cell;
    for (const auto& p : pts) cell.Extend(p);
    if (!cell.Intersects(hull_box)) return Kind::kEmpty;
    bool all_full = true;
    for (const auto& p : pts) all_full &= workspace.Contains(p);
    std::array<Eigen::Vector2d, 28> uvs;
    int seeing = 0;  // other cameras whose image the cell's projection may touch
    for (size_t n = 0; n < others.size(); ++n) {
      const size_t oi = n == 0 ? *hint : (n <= *hint ? n - 1 : n);
      const Other& o = others[oi];
      double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
      bool projects = true;
      for (size_t k = 0; k < pts.size() && projects; ++k) {
        Eigen::Vector2d uv;
        if (!o.Project(pts[k], &uv)) {
          projects = false;
          break;
        }
        uvs[k] = uv;
        u0 = std::min(u0, uv.x()), v0 = std::min(v0, uv.y());
        u1 = std::max(u1, uv.x()), v1 = std::max(v1, uv.y());
      }
      // The disk around the cell centre's projection (pts[0]) that holds the
      // whole projection: uniform if the distance transform says so there.
      if (projects) {
        const Eigen::Vector2d c = uvs[0];
        double radius = 0;
        for (const auto& uv : uvs) radius = std::max(radius, (uv - c).norm());
        radius += o.margin;
        const int col = FloorPixel(c.x()), row = FloorPixel(c.y());
        if (c.x() - radius >= 0 && c.y() - radius >= 0 && c.x() + radius <= o.camera->width &&
            c.y() + radius <= o.camera->height && o.walker->distance.at<float>(row, col) - 1.42 >= radius) {
          if (!o.walker->map->at<uint8_t>(row, col)) {
            *hint = oi;
            return Kind::kEmpty;
          }
          ++seeing;
          continue;  // all object in this camera
        }
      }
      const double m = o.margin;
      // Clamped in floating point first (FloorPixel): a corner far outside a
      // distorted camera's view can project to ~1e11 px, past int.
      const int x0 = FloorPixel(u0 - m), y0 = FloorPixel(v0 - m);
      const int x1 = FloorPixel(u1 + m) + 1, y1 = FloorPixel(v1 + m) + 1;
      const bool inside = projects && x0 >= 0 && y0 >= 0 && x1 <= o.camera->width && y1 <= o.camera->height;
      if (!inside) {
        all_full = false;
        // Wholly off its image (a cell that does not project at all may still
        // cross into view): this camera cannot see any of the cell.
        const bool off = projects && (x1 <= 0 || y1 <= 0 || x0 >= o.camera->width || y0 >= o.camera->height);
        seeing += !off;
        continue;
      }
      ++seeing;
      const int count =
          o.sum->at<int>(y1, x1) - o.sum->at<int>(y0, x1) - o.sum->at<int>(y1, x0) + o.sum->at<int>(y0, x0);
      if (count == 0) {  // background under the whole tile's rays: vetoed
        *hint = oi;
        return Kind::kEmpty;
      }
      all_full &= count == (x1 - x0) * (y1 - y0);
    }
    // Too few cameras see any of it to make a point inside (kUnknown's
    // min_seen; the tile's own camera, which sees all of it, counted only where
    // its map has object pixels).
    const int own =
        own_sum->at<int>(r1, c1) - own_sum->at<int>(r0, c1) - own_sum->at<int>(r1, c0) + own_sum->at<int>(r0, c0);
    if (seeing < (own > 0 ? others_needed_own_object : others_needed_own_background)) return Kind::kEmpty;
    return all_full ? Kind::kFull : Kind::kMixed;
  }
};

}  // namespace

struct ExactReprojector::Impl {
  std::vector<SilhouetteWalker> walkers;  // per camera of the query
  std::vector<cv::Mat> sums;              // per camera: integral image of map != 0 (CV_32S)
};

ExactReprojector::ExactReprojector(const VolumeQuery& query, int threads) : q_(query) {
  if (threads < 1) throw std::invalid_argument("ExactReprojector: threads must be >= 1");
  auto impl = std::make_unique<Impl>();
  const size_t n = q_.size();
  impl->walkers.reserve(n);
  for (size_t c = 0; c < n; ++c) impl->walkers.push_back(SilhouetteWalker(q_.views()[c].camera, q_.views()[c].map));
  impl->sums.resize(n);
  ForEachRowBand(int(n), threads, [&](int c0, int c1, int) {
    for (int c = c0; c < c1; ++c) {
      impl->walkers[size_t(c)].Prepare();
      cv::integral(q_.views()[size_t(c)].map != 0, impl->sums[size_t(c)], CV_32S);
      impl->sums[size_t(c)] /= 255;
    }
  });
  impl_ = std::move(impl);
}

ExactReprojector::~ExactReprojector() = default;

Reprojection ReprojectHullExact(const VolumeQuery& q, size_t index, int threads) {
  return ExactReprojector(q, threads).Reproject(index, threads);
}

Reprojection ExactReprojector::Reproject(size_t index, int threads) const {
  if (index >= q_.size()) throw std::out_of_range("ExactReprojector::Reproject: no camera " + std::to_string(index));
  if (threads < 1) throw std::invalid_argument("ExactReprojector::Reproject: threads must be >= 1");
  const VolumeQuery& q = q_;
  const Camera& camera = q.views()[index].camera;
  const cv::Mat& own_map = q.views()[index].map;
  Reprojection out{cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(0)),
                   cv::Mat(camera.height, camera.width, CV_8UC1, cv::Scalar(0))};
  std::vector<int> others;
  for (size_t c = 0; c < q.size(); ++c)
    if (c != index) others.push_back(int(c));
  const VolumeQuery loo = q.Subset(others);
  const Aabb box = loo.hull_box();
  if (box.empty()) return out;
  std::vector<const SilhouetteWalker*> walkers;
  for (int c : others) walkers.push_back(&impl_->walkers[size_t(c)]);
  const Eigen::Vector3d O = camera.Center();
  struct Piece {
    double s0, s1;
    int object, unseen;
  };
  TileClassifier tiles;
  tiles.camera = &camera;
  tiles.workspace = q.workspace();
  tiles.hull_box = box;
  tiles.others_needed_own_object = q.required_seen() - 1;
  tiles.others_needed_own_background = loo.required_seen();
  tiles.own_sum = &impl_->sums[index];
  tiles.z_near = 1e300;
  tiles.z_far = 0;
  for (const auto& corner : box.Corners()) {
    const double z = (camera.cam_from_world * corner).z();
    tiles.z_near = std::min(tiles.z_near, z);
    tiles.z_far = std::max(tiles.z_far, z);
  }
  // A camera inside the hull box (a dome camera in a loose box): the cells start
  // at kNearDepth in front of it, so a hull within 0.1 mm of a camera's centre
  // is not looked for (a camera is not inside the object).
  constexpr double kNearDepth = 1e-4;
  tiles.z_near = std::max(tiles.z_near, kNearDepth);
  const bool tiled = tiles.z_far > tiles.z_near && q.options().out_of_view != OutOfView::kOutside;
  for (int c : others) {
    const Camera& oc = q.views()[size_t(c)].camera;
    const bool bent = camera.HasDistortion() || oc.HasDistortion();
    tiles.others.push_back({&oc, &impl_->sums[size_t(c)], walkers[tiles.others.size()], bent ? 2.0 : 0.0});
    tiles.distorted |= bent;
  }
  // Where each other camera can see at all: a pinhole camera sees only inside
  // its frustum (five half-spaces: in front, and within its image widened by
  // 1e-6 px), so it is cut out of each ray in closed form. Parts of a ray fewer
  // other cameras see than a point needs (kUnknown's min_seen; camera `index`
  // counted only where its pixel is object, TileClassifier's rule) are dropped
  // before any walk: otherwise a ray through a region
  // no other camera sees keeps its pieces, unvetoed, through every camera's walk.
  // Plane k holds O + s D where at_o(k) + s n.row(k) D >= 0 (at_o: the planes'
  // values at this camera's centre O, the same for every ray).
  struct Frustum {
    bool bounded = false;  // false (a distorted camera): may see the whole ray
    Eigen::Matrix<double, 5, 3> n;
    Eigen::Matrix<double, 5, 1> at_o;
  };
  std::vector<Frustum> frusta;
  for (int c : others) {
    const Camera& oc = q.views()[size_t(c)].camera;
    Frustum f;
    f.bounded = !oc.HasDistortion();
    const Eigen::Matrix3d R = oc.cam_from_world.rotation;
    const Eigen::Vector3d t = oc.cam_from_world.translation;
    constexpr double m = 1e-6;  // px beyond the image: conservative by a hair
    // Rows over camera coordinates (x, y, z): n_cam . X_cam + e >= 0.
    const Eigen::Matrix<double, 5, 3> n_cam =
        (Eigen::Matrix<double, 5, 3>() << 0, 0, 1,           //
         oc.fx, oc.skew, oc.cx + m,                          //
         -oc.fx, -oc.skew, oc.width + m - oc.cx,             //
         0, oc.fy, oc.cy + m,                                //
         0, -oc.fy, oc.height + m - oc.cy)
            .finished();
    f.n = n_cam * R;
    f.at_o = f.n * O + n_cam * t;
    f.at_o(0) -= 1e-9;
    frusta.push_back(f);
  }
  // Where on O + s D, s in [s0, s1], each other camera may see ([a, b], empty
  // when b <= a).
  auto visible_intervals = [&](const Eigen::Vector3d& D, double s0, double s1,
                               std::vector<std::pair<double, double>>* iv) {
    iv->clear();
    for (const Frustum& f : frusta) {
      double a = s0, b = s1;
      if (f.bounded) {
        const Eigen::Matrix<double, 5, 1> rate = f.n * D;
        for (int k = 0; k < 5 && a < b; ++k) {  // at_o + s rate >= 0
          if (rate(k) > 0)
            a = std::max(a, -f.at_o(k) / rate(k));
          else if (rate(k) < 0)
            b = std::min(b, -f.at_o(k) / rate(k));
          else if (f.at_o(k) < 0)
            b = a;
        }
      }
      iv->push_back({a, b});
    }
  };
  // The parts of the ray that at least seeing_needed other cameras may see, as
  // pieces (the whole of [s0, s1] when one camera's vote is enough).
  // Appended to *pieces.
  auto seen_pieces = [&](const std::vector<std::pair<double, double>>& iv, double s0, double s1, int seeing_needed,
                         std::vector<Piece>* pieces, std::vector<std::pair<double, int>>* events) {
    if (seeing_needed <= 0) {
      pieces->push_back({s0, s1, 0, 0});
      return;
    }
    events->clear();
    for (const auto& [a0, b0] : iv) {
      const double a = std::max(a0, s0), b = std::min(b0, s1);
      if (b > a) events->push_back({a, +1}), events->push_back({b, -1});
    }
    std::sort(events->begin(), events->end());
    int count = 0;
    double start = 0;
    for (const auto& [sv, delta] : *events) {
      const int before = count;
      count += delta;
      if (before < seeing_needed && count >= seeing_needed) start = sv;
      if (before >= seeing_needed && count < seeing_needed && sv > start) {
        if (!pieces->empty() && pieces->back().s1 >= start)
          pieces->back().s1 = sv;
        else
          pieces->push_back({start, sv, 0, 0});
      }
    }
  };
  // One pixel: its ray walked across every other camera, over the depths
  // [z0, z1] of `depths` (camera `index`'s z; sorted, disjoint) only: the
  // depths where its cells stayed mixed.
  // `first`: the camera that emptied the last ray walked, tried first (a
  // neighbouring ray is usually emptied by the same camera).
  struct Scratch {
    std::vector<Piece> pieces, next;
    std::vector<std::pair<double, double>> spans;  // the depths as ray parameters s
    std::vector<VoteSegment> segs, span_segs;
    std::vector<std::pair<double, int>> events;
    std::vector<std::pair<double, double>> visible;
    std::vector<char> walked;
    size_t first = 0;
  };
  auto pixel = [&](int r, int col, const std::vector<std::pair<double, double>>& depths, Scratch& sc) {
    std::vector<Piece>& pieces = sc.pieces;
    std::vector<Piece>& next = sc.next;
    const Eigen::Vector3d D = camera.PixelRayWorld({col + 0.5, r + 0.5});
    double s0 = 0, s1 = 1e9;
    if (!box.ClipRay(O, D, &s0, &s1) || !(s1 > s0)) return;
    if (!q.workspace().ClipRay(O, D, &s0, &s1) || !(s1 > s0)) return;
    // Camera `index` sees its own ray as one pixel: its map's. Where that is
    // background, `all` is empty and the leave-one-out hull needs its own count
    // of the other cameras (TileClassifier's rule).
    const Vote own = own_map.at<uint8_t>(r, col) ? Vote::kObject : Vote::kBackground;
    const int seeing_needed =
        own == Vote::kObject ? tiles.others_needed_own_object : tiles.others_needed_own_background;
    visible_intervals(D, s0, s1, &sc.visible);
    // Depth z along this ray is s times its direction's z in camera `index`.
    const double dz = (camera.cam_from_world.rotation * D).z();
    if (!(dz > 0)) return;
    pieces.clear();
    sc.spans.clear();
    for (const auto& [z0, z1] : depths) {
      const double a = std::max(s0, z0 / dz), b = std::min(s1, z1 / dz);
      if (!(b > a)) continue;
      const size_t before = pieces.size();
      seen_pieces(sc.visible, a, b, seeing_needed, &pieces, &sc.events);
      if (pieces.size() > before) sc.spans.push_back({a, b});
    }
    if (pieces.empty()) return;
    sc.walked.assign(walkers.size(), 0);
    size_t& first = sc.first;
    std::vector<VoteSegment>& segs = sc.segs;
    for (size_t n = 0; n < walkers.size(); ++n) {
      const size_t wi = n == 0 ? first : (n <= first ? n - 1 : n);
      const SilhouetteWalker& w = *walkers[wi];
      // This camera's votes over each span's pieces still alive (sorted, so
      // segs is too); each piece is cut by them.
      segs.clear();
      {
        size_t k = 0;
        for (const auto& [a, b] : sc.spans) {
          while (k < pieces.size() && pieces[k].s1 <= a) ++k;
          if (k == pieces.size()) break;
          size_t e = k;
          while (e + 1 < pieces.size() && pieces[e + 1].s0 < b) ++e;
          if (pieces[k].s0 >= b) continue;
          w.Walk(O, D, pieces[k].s0, pieces[e].s1, &sc.span_segs);
          segs.insert(segs.end(), sc.span_segs.begin(), sc.span_segs.end());
          k = e + 1;
        }
      }
      next.clear();
      size_t k = 0;
      for (const Piece& p : pieces) {
        while (k < segs.size() && segs[k].s1 <= p.s0) ++k;
        for (size_t j = k; j < segs.size() && segs[j].s0 < p.s1; ++j) {
          const VoteSegment& sg = segs[j];
          if (q.Vetoes(sg.vote)) continue;
          const double a = std::max(p.s0, sg.s0), b = std::min(p.s1, sg.s1);
          if (!(b > a)) continue;
          const Piece np{a, b, p.object + (sg.vote == Vote::kObject), p.unseen + (sg.vote == Vote::kUnseen)};
          if (!next.empty() && next.back().s1 == a && next.back().object == np.object &&
              next.back().unseen == np.unseen)
            next.back().s1 = b;
          else
            next.push_back(np);
        }
      }
      pieces.swap(next);
      // A piece that too few of the cameras still to walk can see, with the
      // object votes it has, cannot become inside: dropped now, not after every
      // walk (a sliver at a frustum's edge otherwise keeps every walk going).
      sc.walked[wi] = 1;
      if (seeing_needed > 0) {
        next.clear();
        for (const Piece& p : pieces) {
          int could = p.object;
          for (size_t c = 0; c < walkers.size() && could < seeing_needed; ++c)
            could += !sc.walked[c] && sc.visible[c].first < p.s1 && sc.visible[c].second > p.s0;
          if (could >= seeing_needed) next.push_back(p);
        }
        pieces.swap(next);
      }
      if (pieces.empty()) {
        first = wi;
        break;
      }
    }
    if (pieces.empty()) return;
    bool in_loo = false;
    for (const Piece& p : pieces) in_loo |= loo.Accepts(p.object, p.unseen);
    if (in_loo) out.leave_one_out.at<uint8_t>(r, col) = 255;
    if (q.Vetoes(own)) return;
    bool in_all = false;
    for (const Piece& p : pieces) in_all |= q.Accepts(p.object + 1, p.unseen);
    if (in_all) out.all.at<uint8_t>(r, col) = 255;
  };
  // Cells of camera `index`'s frustum (a tile of pixels times a depth range),
  // from 32-px tiles over the hull box's depths, split until each is empty, full
  // or one pixel wide: the tile in four where it is wider than the depth range is
  // deep, else the depth range in two. Cells are taken in the order made (coarse
  // first), so a full cell decides its pixels before their finer cells come up.
  // Only pixels that no full cell decided and whose one-pixel cells stayed mixed
  // are walked, once each, over those cells' depths, after the row's tiles.
  constexpr int kTile = 32;
  const int tiles_x = (camera.width + kTile - 1) / kTile, tiles_y = (camera.height + kTile - 1) / kTile;
  cv::Mat decided(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  struct Cell {
    cv::Rect rect;
    double z0, z1;
  };
  // A one-pixel cell left mixed: its pixel and depths, walked after the rest.
  struct Leaf {
    int r, col;
    double z0, z1;
    bool operator<(const Leaf& o) const {
      return r != o.r ? r < o.r : col != o.col ? col < o.col : z0 < o.z0;
    }
  };
  // One row of tiles.
  auto tile_row = [&](int ty) {
    Scratch scratch;
    std::vector<Cell> queue;
    std::vector<Leaf> leaves;
    size_t hint = 0;
    for (int tx = 0; tx < tiles_x; ++tx) {
      queue.assign(1, {cv::Rect(tx * kTile, ty * kTile, std::min(kTile, camera.width - tx * kTile),
                                std::min(kTile, camera.height - ty * kTile)),
                       tiles.z_near, tiles.z_far});
      bool any_full = false;  // in this tile: else nothing in it is decided yet
      for (size_t head = 0; head < queue.size(); ++head) {
        const Cell cell = queue[head];
        const cv::Rect& t = cell.rect;
        if (any_full && cv::countNonZero(decided(t)) == t.area()) continue;
        if (t.width <= 1 && t.height <= 1) {
          leaves.push_back({t.y, t.x, cell.z0, cell.z1});  // walked below, unless a full cell decides it first
          continue;
        }
        const auto kind = !tiled ? TileClassifier::Kind::kMixed
                                 : tiles.Classify(t.x, t.y, t.x + t.width, t.y + t.height, cell.z0, cell.z1, &hint);
        if (kind == TileClassifier::Kind::kEmpty) continue;
        if (kind == TileClassifier::Kind::kFull) {
          out.leave_one_out(t).setTo(255);
          out.all(t).setTo(255, own_map(t));
          decided(t).setTo(1);
          any_full = true;
          continue;
        }
        // Split the depth where the cell is deeper than it is wide (in metres at its near depth).
        const double width_m = std::max(t.width, t.height) * cell.z0 / camera.fx;
        if (tiled && cell.z1 - cell.z0 > 2 * width_m) {
          const double zm = 0.5 * (cell.z0 + cell.z1);
          queue.push_back({t, zm, cell.z1});
          queue.push_back({t, cell.z0, zm});
          continue;
        }
        const int hw = std::max(1, t.width / 2), hh = std::max(1, t.height / 2);
        for (const cv::Rect& sub : {cv::Rect(t.x, t.y, hw, hh), cv::Rect(t.x + hw, t.y, t.width - hw, hh),
                                    cv::Rect(t.x, t.y + hh, hw, t.height - hh),
                                    cv::Rect(t.x + hw, t.y + hh, t.width - hw, t.height - hh)})
          if (sub.area() > 0) queue.push_back({sub, cell.z0, cell.z1});
      }
    }
    // Each pixel's mixed depths, sorted and merged where they touch.
    std::sort(leaves.begin(), leaves.end());
    std::vector<std::pair<double, double>> depths;
    for (size_t i = 0; i < leaves.size();) {
      const int r = leaves[i].r, col = leaves[i].col;
      depths.clear();
      for (; i < leaves.size() && leaves[i].r == r && leaves[i].col == col; ++i) {
        if (!depths.empty() && leaves[i].z0 <= depths.back().second)
          depths.back().second = std::max(depths.back().second, leaves[i].z1);
        else
          depths.push_back({leaves[i].z0, leaves[i].z1});
      }
      if (!decided.at<uint8_t>(r, col)) pixel(r, col, depths, scratch);
    }
  };
  ForEachRowDynamic(tiles_y, threads, [&](int ty, int) { tile_row(ty); });
  return out;
}

double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  CV_Assert(a.size() == b.size() && a.type() == CV_8UC1 && b.type() == CV_8UC1);
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni == 0 ? 1.0 : double(inter) / double(uni);
}

}  // namespace hullpipe
