#include "hullpipe/evaluation/reprojection.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/util/parallel.h"

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

// One camera's object-pixel map prepared for walking rays across it: per pixel,
// the distance (px, centre to centre) to the nearest pixel of the other vote, so
// a walk crosses a uniform region in a few long steps instead of pixel by pixel.
struct SilhouetteWalker {
  const Camera* camera = nullptr;
  const cv::Mat* map = nullptr;
  cv::Mat distance;  // CV_32FC1

  SilhouetteWalker(const Camera& c, const cv::Mat& m) : camera(&c), map(&m) {
    cv::Mat to_background, to_object;
    cv::distanceTransform(m != 0, to_background, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    cv::distanceTransform(m == 0, to_object, cv::DIST_L2, cv::DIST_MASK_PRECISE);
    distance = to_background + to_object;  // each pixel has one of them zero
  }

  // The vote at X, and `safe`: how far (px) its projection can move and keep it;
  // -1 where the point does not project (behind the camera, beyond the lens's
  // valid radius).
  Vote At(const Eigen::Vector3d& X, Eigen::Vector2d* uv, double* safe) const {
    const auto p = camera->Project(X);
    if (!p) {
      *safe = -1;
      return Vote::kUnseen;
    }
    *uv = *p;
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

  // Camera's votes along O + s D, s in [lo, hi]: sorted, covering, merged.
  // Long steps while the projection stays `safe`, quarter-pixel steps near a
  // change of vote, each change bisected to 2^-14 of its step (1.5e-5 px).
  void Walk(const Eigen::Vector3d& O, const Eigen::Vector3d& D, double lo, double hi,
            std::vector<VoteSegment>* out) const {
    out->clear();
    constexpr double kMinStepPx = 0.25;
    Eigen::Vector2d uv, uv_next;
    double safe = 0, safe_next = 0;
    double s = lo;
    Vote vote = At(O + s * D, &uv, &safe);
    double seg_start = lo;
    const double span = hi - lo;
    while (s < hi) {
      // The step in s that moves the projection about max(safe, 1/4) px.
      const double want_px = std::max(safe, kMinStepPx);
      double ds;
      if (safe < 0) {
        ds = 1e-3 * span;  // not projecting here: small fixed steps
      } else {
        // Pinhole speed of the projection along the ray (distortion changes it
        // little; the chord check below keeps the step safe either way).
        const Eigen::Vector3d a = camera->cam_from_world * (O + s * D), b = camera->cam_from_world.rotation * D;
        const double iz2 = 1.0 / (a.z() * a.z());
        const double speed = std::hypot(camera->fx * (b.x() * a.z() - a.x() * b.z()) * iz2,
                                        camera->fy * (b.y() * a.z() - a.y() * b.z()) * iz2);
        ds = speed > 0 ? want_px / speed : span;
      }
      ds = std::min(std::max(ds, 1e-9 * std::max(1.0, span)), hi - s);
      // The chord may not leave the safe disk: shrink until it does not.
      Vote next = At(O + (s + ds) * D, &uv_next, &safe_next);
      for (int k = 0; k < 30 && safe >= kMinStepPx && next != vote; ++k) {
        ds *= 0.5;
        next = At(O + (s + ds) * D, &uv_next, &safe_next);
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
        out->push_back({seg_start, b, vote});
        seg_start = b;
        s = b;
        vote = At(O + s * D, &uv, &safe);
        if (vote != next) vote = next;  // at the boundary itself: take the far side's vote
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
    cv::Mat sum;  // integral image of map != 0 (CV_32S, (h+1) x (w+1))
    const SilhouetteWalker* walker;  // its distance transform
    bool distorted;
  };
  bool margin_ = false;          // the tile's camera is distorted
  bool any_distorted_ = false;  // one of the others is
  std::vector<Other> others;
  const Camera* camera;
  double z_near, z_far;
  Aabb workspace, hull_box;

  enum class Kind { kEmpty, kFull, kMixed };

  Kind Classify(int c0, int r0, int c1, int r1) const { return Classify(c0, r0, c1, r1, z_near, z_far); }

  Kind Classify(int c0, int r0, int c1, int r1, double zn, double zf) const {
    // The frustum's corners and edge midpoints (a distorted camera's tile edges
    // bend a little: a 2-px margin below covers it).
    // The frustum is convex: with pinholes its 8 corners bound its projection;
    // a distorted camera also gets the edge and face midpoints (27 points). The
    // centre comes first, for the disk test.
    std::vector<Eigen::Vector3d> pts;
    pts.reserve(28);
    const Eigen::Vector3d O = camera->Center();
    const Eigen::Matrix3d world_from_cam = camera->cam_from_world.rotation.transpose();
    auto point = [&](double u, double v, double z) {
      const Eigen::Vector2d xn = camera->Undistort({(u - camera->cx) / camera->fx, (v - camera->cy) / camera->fy});
      return Eigen::Vector3d(O + z * (world_from_cam * Eigen::Vector3d(xn.x(), xn.y(), 1.0)));
    };
    pts.push_back(point(0.5 * (c0 + c1), 0.5 * (r0 + r1), 0.5 * (zn + zf)));
    const bool fine = margin_ || any_distorted_;
    for (double u : {double(c0), 0.5 * (c0 + c1), double(c1)})
      for (double v : {double(r0), 0.5 * (r0 + r1), double(r1)})
        for (double z : {zn, 0.5 * (zn + zf), zf}) {
          const bool corner = u != 0.5 * (c0 + c1) && v != 0.5 * (r0 + r1) && z != 0.5 * (zn + zf);
          if (fine || corner) pts.push_back(point(u, v, z));
        }
    // Outside the hull's box (which the workspace holds): nothing to meet.
    Aabb cell;
    for (const auto& p : pts) cell.Extend(p);
    if (!cell.Intersects(hull_box)) return Kind::kEmpty;
    bool all_full = true;
    for (const auto& p : pts) all_full &= workspace.Contains(p);
    std::vector<Eigen::Vector2d> uvs(pts.size());
    for (const Other& o : others) {
      double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
      bool projects = true;
      for (size_t k = 0; k < pts.size() && projects; ++k) {
        const auto uv = o.camera->Project(pts[k]);
        if (!uv) {
          projects = false;
          break;
        }
        uvs[k] = *uv;
        u0 = std::min(u0, uv->x()), v0 = std::min(v0, uv->y());
        u1 = std::max(u1, uv->x()), v1 = std::max(v1, uv->y());
      }
      // The disk around the cell centre's projection (pts[0]) that holds the
      // whole projection: uniform if the distance transform says so there.
      if (projects) {
        const Eigen::Vector2d c = uvs[0];
        double radius = 0;
        for (const auto& uv : uvs) radius = std::max(radius, (uv - c).norm());
        radius += margin_ || o.distorted ? 2.0 : 0.0;  // bent edges where a camera is distorted
        const int col = int(std::floor(c.x())), row = int(std::floor(c.y()));
        if (c.x() - radius >= 0 && c.y() - radius >= 0 && c.x() + radius <= o.camera->width &&
            c.y() + radius <= o.camera->height && o.walker->distance.at<float>(row, col) - 1.42 >= radius) {
          if (!o.walker->map->at<uint8_t>(row, col)) return Kind::kEmpty;
          continue;  // all object in this camera
        }
      }
      // A distorted camera (this one or the tile's) bends the projection a
      // little between the sampled points: 2 px of margin; none for pinholes.
      const double m = margin_ || o.distorted ? 2.0 : 0.0;
      const int x0 = int(std::floor(u0 - m)), y0 = int(std::floor(v0 - m));
      const int x1 = int(std::floor(u1 + m)) + 1, y1 = int(std::floor(v1 + m)) + 1;
      const bool inside = projects && x0 >= 0 && y0 >= 0 && x1 <= o.camera->width && y1 <= o.camera->height;
      if (!inside) {
        all_full = false;
        continue;
      }
      const int count = o.sum.at<int>(y1, x1) - o.sum.at<int>(y0, x1) - o.sum.at<int>(y1, x0) + o.sum.at<int>(y0, x0);
      if (count == 0) return Kind::kEmpty;  // background under the whole tile's rays: vetoed
      all_full &= count == (x1 - x0) * (y1 - y0);
    }
    return all_full ? Kind::kFull : Kind::kMixed;
  }
};

}  // namespace

Reprojection ReprojectHullExact(const VolumeQuery& q, size_t index, int threads) {
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
  std::vector<SilhouetteWalker> walkers;
  for (int c : others) walkers.emplace_back(q.views()[size_t(c)].camera, q.views()[size_t(c)].map);
  const Eigen::Vector3d O = camera.Center();
  struct Piece {
    double s0, s1;
    int object, unseen;
  };
  TileClassifier tiles;
  tiles.camera = &camera;
  tiles.margin_ = std::any_of(camera.distortion.begin(), camera.distortion.end(), [](double d) { return d != 0; });
  tiles.workspace = q.workspace();
  tiles.hull_box = box;
  tiles.z_near = 1e300;
  tiles.z_far = 0;
  for (const auto& corner : box.Corners()) {
    const double z = (camera.cam_from_world * corner).z();
    tiles.z_near = std::min(tiles.z_near, z);
    tiles.z_far = std::max(tiles.z_far, z);
  }
  const bool tiled = tiles.z_near > 1e-3 && q.options().out_of_view != OutOfView::kOutside;
  for (int c : others) {
    cv::Mat sum;
    cv::integral(q.views()[size_t(c)].map != 0, sum, CV_32S);
    const Camera& oc = q.views()[size_t(c)].camera;
    const bool distorted = std::any_of(oc.distortion.begin(), oc.distortion.end(), [](double d) { return d != 0; });
    tiles.others.push_back({&oc, sum / 255, &walkers[tiles.others.size()], distorted});
    tiles.any_distorted_ |= distorted;
  }
  // One pixel: its ray walked across every other camera.
  // `first`: the camera that emptied the last ray walked, tried first (a
  // neighbouring ray is usually emptied by the same camera).
  auto pixel = [&](int r, int col, std::vector<Piece>& pieces, std::vector<Piece>& next,
                   std::vector<VoteSegment>& segs, size_t& first) {
    {
      {
        const Eigen::Vector3d D = camera.PixelRayWorld({col + 0.5, r + 0.5});
        double s0 = 0, s1 = 1e9;
        if (!box.ClipRay(O, D, &s0, &s1) || !(s1 > s0)) return;
        if (!q.workspace().ClipRay(O, D, &s0, &s1) || !(s1 > s0)) return;
        pieces.assign(1, {s0, s1, 0, 0});
        for (size_t n = 0; n < walkers.size(); ++n) {
          const size_t wi = n == 0 ? first : (n <= first ? n - 1 : n);
          const SilhouetteWalker& w = walkers[wi];
          // This camera's votes over the span still alive; each piece is cut by them.
          w.Walk(O, D, pieces.front().s0, pieces.back().s1, &segs);
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
          if (pieces.empty()) {
            first = wi;
            break;
          }
        }
        if (pieces.empty()) return;
        bool in_loo = false;
        for (const Piece& p : pieces) in_loo |= loo.Accepts(p.object, p.unseen);
        if (in_loo) out.leave_one_out.at<uint8_t>(r, col) = 255;
        // Camera `index` sees its own ray as one pixel: its map's.
        const Vote own = own_map.at<uint8_t>(r, col) ? Vote::kObject : Vote::kBackground;
        if (q.Vetoes(own)) return;
        bool in_all = false;
        for (const Piece& p : pieces) in_all |= q.Accepts(p.object + 1, p.unseen);
        if (in_all) out.all.at<uint8_t>(r, col) = 255;
      }
    }
  };
  // Cells of camera `index`'s frustum (a tile of pixels times a depth range),
  // from 32-px tiles over the hull box's depths, split until each is empty, full
  // or one pixel wide: the tile in four where it is wider than the depth range is
  // deep, else the depth range in two. Only pixels that no full cell decided and
  // whose one-pixel cells stayed mixed are walked, once each, after the rest.
  constexpr int kTile = 32;
  const int tiles_x = (camera.width + kTile - 1) / kTile, tiles_y = (camera.height + kTile - 1) / kTile;
  cv::Mat decided(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  cv::Mat need(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  struct Cell {
    cv::Rect rect;
    double z0, z1;
  };
  auto tile_rows = [&](int ty0, int ty1) {
    std::vector<Piece> pieces, next;
    std::vector<VoteSegment> segs;
    std::vector<Cell> stack;
    size_t first = 0;
    for (int ty = ty0; ty < ty1; ++ty)
      for (int tx = 0; tx < tiles_x; ++tx) {
        stack.assign(1, {cv::Rect(tx * kTile, ty * kTile, std::min(kTile, camera.width - tx * kTile),
                                  std::min(kTile, camera.height - ty * kTile)),
                         tiles.z_near, tiles.z_far});
        while (!stack.empty()) {
          const Cell cell = stack.back();
          stack.pop_back();
          const cv::Rect& t = cell.rect;
          if (cv::countNonZero(decided(t)) == t.area()) continue;
          if (t.width <= 1 && t.height <= 1) {
            need.at<uint8_t>(t.y, t.x) = 1;  // walked below, unless a full cell decides it first
            continue;
          }
          const auto kind = !tiled ? TileClassifier::Kind::kMixed
                                   : tiles.Classify(t.x, t.y, t.x + t.width, t.y + t.height, cell.z0, cell.z1);
          if (kind == TileClassifier::Kind::kEmpty) continue;
          if (kind == TileClassifier::Kind::kFull) {
            out.leave_one_out(t).setTo(255);
            out.all(t).setTo(255, own_map(t));
            decided(t).setTo(1);
            continue;
          }
          // Split the depth where the cell is deeper than it is wide (in metres at its near depth).
          const double width_m = std::max(t.width, t.height) * cell.z0 / camera.fx;
          if (tiled && cell.z1 - cell.z0 > 2 * width_m) {
            const double zm = 0.5 * (cell.z0 + cell.z1);
            stack.push_back({t, zm, cell.z1});
            stack.push_back({t, cell.z0, zm});
            continue;
          }
          const int hw = std::max(1, t.width / 2), hh = std::max(1, t.height / 2);
          for (const cv::Rect& sub : {cv::Rect(t.x, t.y, hw, hh), cv::Rect(t.x + hw, t.y, t.width - hw, hh),
                                      cv::Rect(t.x, t.y + hh, hw, t.height - hh),
                                      cv::Rect(t.x + hw, t.y + hh, t.width - hw, t.height - hh)})
            if (sub.area() > 0) stack.push_back({sub, cell.z0, cell.z1});
        }
      }
    for (int r = ty0 * kTile; r < std::min(camera.height, ty1 * kTile); ++r)
      for (int col = 0; col < camera.width; ++col)
        if (need.at<uint8_t>(r, col) && !decided.at<uint8_t>(r, col)) pixel(r, col, pieces, next, segs, first);
  };
  ForEachRowBand(tiles_y, threads, [&](int r0, int r1, int) { tile_rows(r0, r1); });
  return out;
}

double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  CV_Assert(a.size() == b.size() && a.type() == CV_8UC1 && b.type() == CV_8UC1);
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni == 0 ? 1.0 : double(inter) / double(uni);
}

}  // namespace hullpipe
