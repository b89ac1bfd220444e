#include "hullpipe/reconstruction/plane_sweep.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/empty_space.h"
#include "hullpipe/reconstruction/plane_index.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {

void NovelView::Check() const {
  if (width <= 0 || height <= 0) throw std::invalid_argument("NovelView: size must be positive");
  if (!(fx > 0) || !(fy > 0)) throw std::invalid_argument("NovelView: focal lengths must be > 0");
  if (!std::isfinite(cx) || !std::isfinite(cy) || !world_from_eye.rotation.allFinite() ||
      !world_from_eye.translation.allFinite())
    throw std::invalid_argument("NovelView: non-finite principal point or pose");
}

NovelView NovelView::FromFov(int width, int height, double hfov_rad, const Rigid3d& pose) {
  NovelView v;
  v.width = width;
  v.height = height;
  v.fx = v.fy = 0.5 * width / std::tan(0.5 * hfov_rad);
  v.cx = 0.5 * width;
  v.cy = 0.5 * height;
  v.world_from_eye = pose;
  return v;
}

void PlaneSweepOptions::Check() const {
  if (num_planes < 2 || num_planes > kMaxPlanes)
    throw std::invalid_argument("--planes (num_planes) must be in [2, " + std::to_string(kMaxPlanes) + "]");
  if (!(near > 0) || !(far > near))
    throw std::invalid_argument("PlaneSweepOptions: need 0 < near < far");
}

std::vector<double> SweepPlaneDepths(const VolumeQuery& query, const NovelView& view,
                                     const PlaneSweepOptions& o) {
  o.Check();
  double near = o.near, far = o.far;
  if (o.fit_planes_to_hull_box) {
    const Aabb& box = query.hull_box();
    if (box.empty()) return {};
    const Rigid3d eye_from_world = view.world_from_eye.Inverse();
    double zmin = 1e300, zmax = -1e300;
    for (const auto& c : box.Corners()) {
      const double z = (eye_from_world * c).z();
      zmin = std::min(zmin, z);
      zmax = std::max(zmax, z);
    }
    near = std::max(near, zmin);
    far = std::min(far, zmax);
    if (!(far > near)) return {};
  }
  std::vector<double> depths(size_t(o.num_planes));
  for (int k = 0; k < o.num_planes; ++k) {
    const double s = double(k) / (o.num_planes - 1);
    depths[size_t(k)] = o.spacing == PlaneSpacing::kUniformDepth
                            ? near + s * (far - near)
                            : 1.0 / (1.0 / near + s * (1.0 / far - 1.0 / near));
  }
  return depths;
}

namespace {

// The points of one view's pixel rays in every camera's frame, for hot loops: the
// point at eye depth d along the current pixel's ray is A_c + d * B_c in camera c.
class RayQuery {
 public:
  // `empty` (may be null or skip nothing): the frameset's empty space, whose
  // points InsideAt answers without asking the cameras (exactly as they would).
  RayQuery(const VolumeQuery& q, const NovelView& view, const EmptySpace* empty = nullptr)
      : q_(q), cams_(q.fast()), n_(cams_.size()), view_(view), A_(n_), B_(n_), order_(n_),
        empty_(empty && !empty->knows_nothing() ? empty : nullptr), cam_from_eye_(n_), row_B_(n_) {
    if (empty_) gO_ = empty_->GridFromWorld(view.world_from_eye.translation).cast<float>();
    const Eigen::Vector3d O = view.world_from_eye.translation;
    for (size_t c = 0; c < n_; ++c) {
      A_[c] = (q.views()[c].camera.cam_from_world * O).cast<float>();
      cam_from_eye_[c] = q.views()[c].camera.cam_from_world.rotation * view.world_from_eye.rotation;
      order_[c] = c;
    }
  }
  // Aims at pixel (u, v) of the view; returns the ray's part [*s0, *s1] in the
  // hull box (false if it misses). The ray's direction is linear in u along a
  // row (NovelView::EyeRay), so each pixel's direction is its row's part
  // (made once a row) plus u's: three multiply-adds a pixel, not a rotation.
  bool Aim(double u, double v, double* s0, double* s1) {
    if (v != row_v_) AimRow(v);
    const double x = (u - view_.cx) / view_.fx;
    const Eigen::Vector3d D = view_.world_from_eye.rotation.col(0) * x + row_D_;
    if (!q_.hull_box().ClipRay(view_.world_from_eye.translation, D, s0, s1)) return false;
    for (size_t c = 0; c < n_; ++c) B_[c] = (cam_from_eye_[c].col(0) * x + row_B_[c]).cast<float>();
    if (empty_) gD_ = empty_->GridFromWorldDirection(D).cast<float>();
    return true;
  }
  // Is the point at eye depth d on the aimed ray inside the hull?
  // *near_miss (if given) is set when exactly one camera vetoes the point: the
  // stencil count was n - 1, the hull is probably very close. (Whatever order the
  // cameras are asked in, so the GPU march, which asks in index order, agrees.)
  bool InsideAt(float d, bool* near_miss = nullptr) {
    if (near_miss) *near_miss = false;
    // In a cube one camera puts on background: outside; two: no near miss either.
    if (empty_ && empty_->Vetoes(gO_.x() + d * gD_.x(), gO_.y() + d * gD_.y(), gO_.z() + d * gD_.z()) >=
                      (near_miss ? 2 : 1)) {
      ++skipped;
      vetoer_saw_background = false;
      return false;
    }
    return AskCameras(d, near_miss);
  }
  // True when camera c vetoes every point of the aimed ray between eye depths
  // a and b (a near miss's scan bracket): VolumeQuery::SegmentOnBackground.
  bool CannotHit(size_t c, float a, float b) const {
    return q_.SegmentOnBackground(c, A_[c] + a * B_[c], A_[c] + b * B_[c]);
  }
  // InsideAt's questions to the cameras.
  bool AskCameras(float d, bool* near_miss) {
    vetoer_saw_background = false;
    int object = 0, unseen = 0;
    for (size_t j = 0; j < n_; ++j) {
      const size_t c = order_[j];
      ++projections;
      const Vote vote = VoteAt(c, d);
      if (vote == Vote::kObject) {
        ++object;
      } else if (q_.Vetoes(vote)) {
        // The camera that rejected goes first next time: neighbouring points are
        // usually rejected by the same camera.
        if (j > 0) std::rotate(order_.begin(), order_.begin() + long(j), order_.begin() + long(j) + 1);
        vetoer = c;
        vetoer_saw_background = vote == Vote::kBackground;
        if (near_miss) {
          // A near miss needs every other camera's vote: the search for a second
          // veto ends at the first. The camera that gave it goes second next time
          // (empty space is mostly vetoed by the same two), so a point far from
          // the hull costs two projections, not n.
          *near_miss = true;
          for (size_t i = j + 1; i < n_; ++i) {
            ++projections;
            if (q_.Vetoes(VoteAt(order_[i], d))) {
              *near_miss = false;
              if (i > 1) std::rotate(order_.begin() + 1, order_.begin() + long(i), order_.begin() + long(i) + 1);
              break;
            }
          }
        }
        return false;
      } else {
        ++unseen;
      }
    }
    return q_.Accepts(object, unseen);
  }
  // Which of the points at eye depths t[0], ..., t[n - 1] (n <= 32) camera c
  // does not veto: bit i set where it does not (where InsideAt may be true).
  // One tight loop over the camera's projections, for the refinement's scans,
  // whose points are mostly vetoed by the camera that vetoed their near miss.
  uint32_t NotVetoedBy(size_t c, const float* t, int n) {
    uint32_t open = 0;
    const detail::FastCamera& cam = cams_[c];
    const Eigen::Vector3f A = A_[c], B = B_[c];
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3f X = A + t[i] * B;
      if (!q_.Vetoes(VolumeQuery::VoteFast(cam, X.x(), X.y(), X.z()))) open |= 1u << i;
    }
    projections += n;
    return open;
  }
  Vote VoteAt(size_t c, float d) const {
    const Eigen::Vector3f X = A_[c] + d * B_[c];
    return VolumeQuery::VoteFast(cams_[c], X.x(), X.y(), X.z());
  }
  // Bisects between an outside depth lo and an inside depth hi; returns the final
  // inside end.
  float Bisect(float lo, float hi, int iterations) {
    for (int it = 0; it < iterations; ++it) {
      const float mid = 0.5f * (lo + hi);
      (InsideAt(mid) ? hi : lo) = mid;
    }
    return hi;
  }
  int64_t projections = 0, skipped = 0;
  // The camera whose veto answered the last AskCameras that returned outside,
  // and whether its vote was a background pixel (not a point out of view).
  size_t vetoer = 0;
  bool vetoer_saw_background = false;

 private:
  const VolumeQuery& q_;
  const std::vector<detail::FastCamera>& cams_;
  size_t n_;
  const NovelView& view_;
  std::vector<Eigen::Vector3f> A_, B_;
  std::vector<size_t> order_;
  const EmptySpace* empty_;
  // Each camera's rotation from the eye frame, and the row being aimed along:
  // its v and the parts of its rays' directions (world, each camera's) that
  // do not depend on u.
  std::vector<Eigen::Matrix3d> cam_from_eye_;
  std::vector<Eigen::Vector3d> row_B_;
  Eigen::Vector3d row_D_ = Eigen::Vector3d::Zero();
  double row_v_ = std::numeric_limits<double>::quiet_NaN();
  void AimRow(double v) {
    row_v_ = v;
    const double y = (v - view_.cy) / view_.fy;
    const Eigen::Matrix3d& R = view_.world_from_eye.rotation;
    row_D_ = R.col(1) * y + R.col(2);
    for (size_t c = 0; c < n_; ++c) row_B_[c] = cam_from_eye_[c].col(1) * y + cam_from_eye_[c].col(2);
  }
  // The ray in grid units: the point at eye depth d is gO_ + d * gD_ (float
  // like VoteFast's; the cubes were proven grown by 0.1 mm and a pixel).
  Eigen::Vector3f gO_ = Eigen::Vector3f::Zero(), gD_ = Eigen::Vector3f::Zero();
};

constexpr size_t kMaxNearMisses = 8;
constexpr size_t kNoCamera = std::numeric_limits<size_t>::max();
// Plane points a run skip tries at once: doubled after each skip, back to the
// least after a failed try (docs/benchmarks.md, "Runs of background skipped in
// the CPU sweep").
constexpr size_t kMinRunSpan = 4, kMaxRunSpan = 32;
constexpr int kMaxEdgeSteps = 256;

// The brackets of the points at planes first .. last: from the plane before
// the first to the plane after the last, within the ray's part [s0, s1] in the
// hull box: [*a, *b]. A near miss at plane k (first = last = k) is scanned
// across it; a run of points skipped whole holds all of theirs.
void NearMissBracket(const std::vector<double>& depths, size_t first, size_t last, double s0, double s1, double* a,
                     double* b) {
  *a = std::max(s0, first > 0 ? depths[first - 1] : depths[first]);
  *b = std::min(s1, last + 1 < depths.size() ? depths[last + 1] : depths[last]);
}

// The bracket below plane k for refinement: the previous plane or the hull box
// entry, whichever is deeper. The near plane (k == 0) is not refined: in front of
// it the frustum is cut.
bool RefineBracket(const std::vector<double>& depths, size_t k, double s0, float* lo) {
  if (k == 0) return false;
  *lo = float(std::max(depths[k - 1], s0));
  return true;
}

// Planes per slab of TightenBounds.
constexpr size_t kSlabPlanes = 2;

// The float at or below x, and at or above it.
float FloatDown(double x) {
  const float f = float(x);
  return double(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity()) : f;
}
float FloatUp(double x) {
  const float f = float(x);
  return double(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

// Narrows each block's bounds (SweepBounds) to the view's own frustum: the rays
// of a block of pixels between two eye depths fill a convex piece of the
// frustum (its 8 vertices: the block's corner rays at both depths), and a
// camera that puts all of it on background (VolumeQuery::CountWholeBackground)
// vetoes every point of those rays there. The grid's cubes are the world's and
// coarse (a cube straddling a silhouette cone is vetoed by no camera, and a
// block meets many), a block's pieces thin across its rays. Slab by slab
// (kSlabPlanes planes each):
//   - the hit bounds: pieces one camera vetoes hold no inside point; those
//     from the front and from the back are cut off, and a block whose pieces
//     all are has no hit;
//   - the near bound, where near misses may start: pieces two cameras veto
//     hold no near miss either; those from the front are cut off (the sweep
//     then neither visits nor counts their points).
// Valid bounds still, so the sweep's depths are unchanged (SweepRows visits
// fewer points); rounded outward to floats.
void TightenBounds(const VolumeQuery& query, const NovelView& view, const cv::Rect& region,
                   const std::vector<double>& depths, bool near_misses, SweepBounds* bounds, StopFlag stop,
                   int threads) {
  const int B = EmptySpace::kBoundsBlock;
  const Rigid3d& world_from_eye = view.world_from_eye;
  // Rows of blocks handed out one at a time: the open blocks gather about the
  // hull's image.
  ForEachRowDynamic(bounds->hit_near.rows, threads, [&](int i, int) {
    if (Stopped(stop)) return;
    size_t hint = 0;
    std::vector<double> cuts;
    VolumeQuery::RayBundle rays;
    // The slabs' depths between a and b: a, every kSlabPlanes-th plane between, b.
    auto slabs_between = [&](double a, double b) {
      cuts.clear();
      cuts.push_back(a);
      const auto lo = std::upper_bound(depths.begin(), depths.end(), a);
      const auto hi = std::lower_bound(lo, depths.end(), b);
      for (auto it = lo; it < hi; it += long(std::min<size_t>(kSlabPlanes, size_t(hi - it)))) cuts.push_back(*it);
      cuts.push_back(b);
      return cuts.size() - 1;
    };
    for (int j = 0; j < bounds->hit_near.cols; ++j) {
      float& hit_near = bounds->hit_near.at<float>(i, j);
      float& hit_far = bounds->hit_far.at<float>(i, j);
      if (!(hit_near <= hit_far) || !(hit_near > 0)) continue;
      // The block's pixel edges, and its corner rays (eye z = 1) in each camera.
      const double x0 = region.x + j * B, x1 = region.x + std::min((j + 1) * B, region.width);
      const double y0 = region.y + i * B, y1 = region.y + std::min((i + 1) * B, region.height);
      const Eigen::Matrix3d& R = world_from_eye.rotation;
      query.BundleOf(world_from_eye.translation,
                     {R * view.EyeRay(x0, y0), R * view.EyeRay(x1, y0), R * view.EyeRay(x0, y1),
                      R * view.EyeRay(x1, y1)},
                     &rays);
      // Whether `need` cameras veto all of slabs a .. b - 1 (one piece).
      auto vetoed = [&](size_t a, size_t b, int need) {
        return query.CountWholeBackground(rays, cuts[a], cuts[b], need, &hint) >= need;
      };
      size_t slabs = slabs_between(hit_near, hit_far);
      size_t front = 0;
      while (front < slabs && vetoed(front, front + 1, 1)) ++front;
      if (front == slabs) {
        hit_near = std::numeric_limits<float>::infinity();
        hit_far = -std::numeric_limits<float>::infinity();
        continue;
      }
      size_t back = slabs;
      while (back > front + 1 && vetoed(back - 1, back, 1)) --back;
      const double first_hit = cuts[front];
      hit_near = FloatDown(cuts[front]);
      hit_far = FloatUp(cuts[back]);
      // The near bound, up to the first piece that may hold a hit.
      float& near = bounds->near.at<float>(i, j);
      if (!near_misses || !(near > 0) || !(near < first_hit)) continue;
      slabs = slabs_between(near, first_hit);
      // Pieces of doubling length while two cameras veto them, halved after
      // one they do not (the front's pieces are mostly far from the hull).
      size_t twice = 0;
      for (size_t span = 1; twice < slabs;) {
        const size_t m = std::min(span, slabs - twice);
        if (vetoed(twice, twice + m, 2)) {
          twice += m, span = 2 * m;
        } else if (m == 1) {
          break;
        } else {
          span = m / 2;
        }
      }
      near = FloatDown(cuts[twice]);
    }
  });
  ThrowIfStopped(stop, "the plane sweep's hit bounds");
}

// kRefine: refine_iterations > 0 (a loop of its own: the sweep without
// refinement looks for no near misses and skips no runs).
template <bool kRefine>
void SweepRows(const VolumeQuery& query, const EmptySpace& empty, const SweepBounds& bounds, const NovelView& view,
               const PlaneIndex& planes, const cv::Rect& tile, int row_begin, int row_end, cv::Mat& out,
               SweepStats* stats, int refine_iterations, StopFlag stop) {
  const std::vector<double>& depths = planes.depths();
  RayQuery ray(query, view, &empty);
  const bool prune = kRefine && query.options().prune_near_misses;
  // Without refinement a point costs about one projection (the camera that
  // vetoed the last point is asked first): a run's test, two, does not pay.
  const bool skip_runs = kRefine && query.options().skip_background_runs;
  const std::vector<float> d(depths.begin(), depths.end());
  SweepStats local;
  // The runs of plane points skipped on the ray being swept whose near misses
  // are not counted yet: (first plane, count).
  std::vector<std::pair<size_t, size_t>> uncounted;
  const bool bounded = !bounds.near.empty();
  for (int r = row_begin; r < row_end && !Stopped(stop); ++r) {
    float* out_row = out.ptr<float>(r);
    for (int col = 0; col < tile.width; ++col) {
      out_row[col] = kNoDepth;
      // A ray can take 4096 planes x n cameras of tests: poll per pixel.
      if (Stopped(stop)) break;
      // The ray's bounds in the empty space: outside [from, to] its points are
      // neither inside nor near misses; outside [hit_from, hit_to] none is
      // inside, so no near miss's scan wholly outside them finds one.
      double from = -std::numeric_limits<double>::infinity(), to = std::numeric_limits<double>::infinity();
      double hit_from = from, hit_to = to;
      if (bounded) {
        const int br = r / EmptySpace::kBoundsBlock, bc = col / EmptySpace::kBoundsBlock;
        from = bounds.near.at<float>(br, bc);
        to = bounds.far.at<float>(br, bc);
        hit_from = bounds.hit_near.at<float>(br, bc);
        hit_to = bounds.hit_far.at<float>(br, bc);
        // No point of the ray is inside: no depth, near misses or not.
        if (!(from <= to) || !(hit_from <= hit_to)) continue;
      }
      double s0 = depths.front(), s1 = depths.back();
      if (!ray.Aim(tile.x + col + 0.5, tile.y + r + 0.5, &s0, &s1)) continue;
      ++local.rays;
      // First plane at or beyond s0 (the box entry), last at or before s1,
      // within the bounds (the refinement still brackets with s0 and s1).
      from = std::max(from, s0);
      to = std::min(to, s1);
      const size_t first = planes.FirstNotBelow(from);
      size_t end = std::max(first, planes.FirstAbove(to));
      if (bounded) {
        // Past hit_to none is inside either; the first plane beyond it is
        // still visited with refinement: its near miss's scan may reach back.
        const size_t past_hits = planes.FirstAbove(hit_to);
        const size_t bounded_end = end;
        end = std::max(first, std::min(end, kRefine ? past_hits + 1 : past_hits));
        local.hit_skipped += int64_t(bounded_end - end);
      }
      // Refinement remembers the planes where the stencil count was n - 1 before the
      // first inside plane: a piece of hull thinner than the spacing may lie
      // between them and their neighbours. The first kMaxNearMisses near misses
      // are kept (n_near counts them), and of those, the ones whose scan could
      // find a hit are scanned (near_misses, near_vetoer; n_scan of them).
      size_t near_misses[kMaxNearMisses], near_vetoer[kMaxNearMisses];
      size_t n_near = 0, n_scan = 0;
      // Runs of points one camera puts on background, brackets included, are
      // skipped whole (VolumeQueryOptions::skip_background_runs): their near
      // misses, if any, would not be scanned, and are counted (`uncounted`,
      // `n_uncounted` points) only when whether a near miss to scan is within
      // the first kMaxNearMisses depends on them. A failed try waits 1, 2, 4,
      // then 8 points before the next.
      uncounted.clear();
      size_t n_uncounted = 0;
      size_t run_camera = kNoCamera, span = kMinRunSpan, next_try = 0, backoff = 1;
      size_t hit = d.size();
      // The points in front of hit_from hold no inside point. With
      // refinement, the first plane whose bracket reaches it is visited (its
      // scan may), and the points before it are skipped as a run is: they
      // hold no near miss with anything to scan, but count against the kept
      // ones, so they are counted if that matters.
      size_t k_begin = first;
      if (bounded) {
        const size_t hp = planes.FirstNotBelow(hit_from);
        const size_t kh = kRefine && hp > 0 ? hp - 1 : hp;
        const size_t m = std::min(kh, end) - std::min(kh, first);
        if (m > 0) {
          if (kRefine) {
            uncounted.emplace_back(first, m);
            n_uncounted += m;
          }
          k_begin = first + m;
          local.hit_skipped += int64_t(m);
        }
      }
      for (size_t k = k_begin; k < end; ++k) {
        if (run_camera != kNoCamera && k >= next_try) {
          // The run's points k .. k + m - 1 with their brackets.
          const size_t m = std::min(span, end - k);
          if (m >= 2) {
            double a = 0, b = 0;
            NearMissBracket(depths, k, k + m - 1, s0, s1, &a, &b);
            if (ray.CannotHit(run_camera, float(a), float(b))) {
              local.plane_points += int64_t(m);
              local.run_skipped += int64_t(m);
              if (n_near < kMaxNearMisses) {
                uncounted.emplace_back(k, m);
                n_uncounted += m;
              }
              k += m - 1;
              span = std::min(2 * span, kMaxRunSpan);
              backoff = 1;
              continue;
            }
          }
          run_camera = kNoCamera;
          span = kMinRunSpan;
          next_try = k + backoff;
          backoff = std::min<size_t>(2 * backoff, 8);
        }
        ++local.plane_points;
        bool near = false;
        // Past kMaxNearMisses no more are kept: nor looked for.
        if (ray.InsideAt(d[k], kRefine && n_near < kMaxNearMisses ? &near : nullptr)) {
          hit = k;
          break;
        }
        // A run is tried after a camera's background veto, not after the grid's
        // (whose points cost less than a run's test).
        if (skip_runs) run_camera = ray.vetoer_saw_background ? ray.vetoer : kNoCamera;
        if (!kRefine || !near || n_near >= kMaxNearMisses) continue;
        const size_t vetoer = ray.vetoer;
        // A near miss whose bracket (the scan's, below) its camera vetoes
        // whole has nothing to scan; it still counts against the kept ones.
        bool pruned = false;
        if (prune && ray.vetoer_saw_background) {
          double a = 0, b = 0;
          NearMissBracket(depths, k, k, s0, s1, &a, &b);
          pruned = ray.CannotHit(vetoer, float(a), float(b));
        }
        local.pruned += pruned;
        if (!pruned && n_near + n_uncounted >= kMaxNearMisses) {
          // Is this near miss among the first kMaxNearMisses? Count the
          // skipped runs' (every point of them outside, so only the count changes).
          for (const auto& [k0, m] : uncounted)
            for (size_t j = k0; j < k0 + m && n_near < kMaxNearMisses; ++j) {
              bool skipped_near = false;
              ray.InsideAt(d[j], &skipped_near);
              n_near += skipped_near;
            }
          uncounted.clear();
          n_uncounted = 0;
          if (n_near >= kMaxNearMisses) continue;
        }
        if (!pruned) {
          near_misses[n_scan] = k;
          near_vetoer[n_scan++] = vetoer;
        }
        ++n_near;
      }
      if (kRefine) {
        // Scan around each near miss, front to back, at 1/8 of the spacing: the
        // points the near miss's one vetoing camera vetoes are outside, so only
        // the others are asked (the first inside one is the same).
        for (size_t m = 0; m < n_scan; ++m) {
          const size_t k = near_misses[m];
          double a = 0, b = 0;
          NearMissBracket(depths, k, k, s0, s1, &a, &b);
          const double step = (b - a) / 16;
          if (!(step > 0)) continue;
          float t[16];
          int n = 0;
          t[n++] = float(a);  // the bracket's start, before the first point
          for (int i = 1; i < 16; ++i) {
            const double ti = a + i * step;
            if (!(ti < b)) break;
            t[n++] = float(ti);
          }
          for (uint32_t open = ray.NotVetoedBy(near_vetoer[m], t + 1, n - 1); open != 0; open &= open - 1) {
            const int i = 1 + std::countr_zero(open);
            if (ray.InsideAt(t[i])) {
              out_row[col] = ray.Bisect(t[i - 1], t[i], refine_iterations);
              break;
            }
          }
          if (std::isfinite(out_row[col])) break;
        }
        if (std::isfinite(out_row[col])) continue;
      }
      if (hit == d.size()) continue;
      float lo = 0;
      out_row[col] = kRefine && RefineBracket(depths, hit, s0, &lo)
                         ? ray.Bisect(lo, d[hit], refine_iterations)
                         : d[hit];
    }
  }
  local.projections = ray.projections;
  local.skipped = ray.skipped;
  if (stats) {
    stats->rays += local.rays;
    stats->plane_points += local.plane_points;
    stats->projections += local.projections;
    stats->skipped += local.skipped;
    stats->pruned += local.pruned;
    stats->run_skipped += local.run_skipped;
    stats->hit_skipped += local.hit_skipped;
  }
}

// Rows a worker of a threaded sweep takes at a time: a block row of the
// bounds. A view's cost lies in the rows about the hull's image, so fixed
// bands left a worker idle (docs/benchmarks.md, "Rows handed out in chunks").
constexpr int kRowChunk = EmptySpace::kBoundsBlock;

// Runs rows(r0, r1, stats) over chunks of [0, height) on `threads` workers
// (ForEachRowChunk), summing each worker's counters into *stats.
template <class Rows>
void ForRowChunks(int height, int threads, SweepStats* stats, Rows rows) {
  std::vector<SweepStats> per(size_t(std::max(1, threads)));  // a worker's index is below threads
  ForEachRowChunk(height, kRowChunk, threads, [&](int r0, int r1, int t) { rows(r0, r1, &per[size_t(t)]); });
  if (stats)
    for (const auto& st : per) {
      stats->rays += st.rays;
      stats->plane_points += st.plane_points;
      stats->projections += st.projections;
      stats->skipped += st.skipped;
      stats->pruned += st.pruned;
      stats->run_skipped += st.run_skipped;
      stats->hit_skipped += st.hit_skipped;
    }
}

// Spacing of the planes around eye depth d (the gap below the plane at or after d).
double SpacingAt(const std::vector<double>& depths, double d) {
  if (depths.size() < 2) return 0;
  size_t k = size_t(std::lower_bound(depths.begin(), depths.end(), d) - depths.begin());
  k = std::clamp<size_t>(k, 1, depths.size() - 1);
  return depths[k] - depths[k - 1];
}

// The silhouette pass of the refinement. The sweep misses a piece of hull shorter
// than the plane spacing along a ray: that happens where a ray grazes the hull, at
// its silhouette or at an occluding rim as seen from the eye, where neighbouring
// pixels differ in depth by more than a plane or one has no hull. For such a pixel
// the hull is most likely near its neighbour's depth, so the ray is scanned there
// at an eighth of the plane spacing and a hit is bisected. Reads `swept`, writes
// `out` (both the region's size); updates pixels of `inner` (region coordinates).
// One pass: a pixel depends on the sweep within one pixel of it, so a tile swept
// with a one-pixel margin refines exactly as in a whole-view render. (Passes
// repeated over the pixels next to moved ones changed nothing on the synthetic
// scenes of `vh_eval sweep`.)
void RefineEdges(const VolumeQuery& query, const EmptySpace& empty, const NovelView& view,
                 const std::vector<double>& depths, const cv::Rect& region, const cv::Rect& inner, int iterations,
                 const cv::Mat& swept, cv::Mat& out, int threads, StopFlag stop) {
  // Most pixels have no window: no depth and no neighbour with one, or a
  // neighbour not 1.5 spacings in front. The smallest spacing settles the
  // latter without SpacingAt's search (1.5 * sp >= 1.5 * least: rounding is
  // monotone, so a neighbour it passes passes with its own spacing too).
  double least = std::numeric_limits<double>::infinity();
  for (size_t k = 1; k < depths.size(); ++k) least = std::min(least, depths[k] - depths[k - 1]);
  // Rows of the sweep with a depth: a row whose neighbours and itself have
  // none has no window.
  std::vector<uint8_t> row_has_depth(size_t(swept.rows), 0);
  for (int y = 0; y < swept.rows; ++y) {
    const float* row = swept.ptr<float>(y);
    row_has_depth[size_t(y)] = std::any_of(row, row + swept.cols, [](float x) { return std::isfinite(x); });
  }
  ForRowChunks(inner.height, threads, nullptr, [&](int r0, int r1, SweepStats*) {
    RayQuery ray(query, view, &empty);
    std::vector<std::pair<double, double>> windows;
    for (int rr = r0; rr < r1 && !Stopped(stop); ++rr) {
      const int r = inner.y + rr;
      const bool above = r > 0 && row_has_depth[size_t(r - 1)];
      const bool below = r + 1 < swept.rows && row_has_depth[size_t(r + 1)];
      if (!above && !below && !row_has_depth[size_t(r)]) continue;
      const float* mid = swept.ptr<float>(r);
      const float* up = above ? swept.ptr<float>(r - 1) : nullptr;
      const float* down = below ? swept.ptr<float>(r + 1) : nullptr;
      for (int c = inner.x; c < inner.x + inner.width && !Stopped(stop); ++c) {
        const float dp = mid[c];
        // The four neighbours (above, below, left, right) where inside the sweep.
        const float nb[4] = {up ? up[c] : kNoDepth, down ? down[c] : kNoDepth, c > 0 ? mid[c - 1] : kNoDepth,
                             c + 1 < swept.cols ? mid[c + 1] : kNoDepth};
        windows.clear();
        for (const float dq : nb) {
          if (!std::isfinite(dq)) continue;
          if (std::isfinite(dp) && dq >= dp - 1.5 * least) continue;
          const double sp = SpacingAt(depths, dq);
          if (std::isfinite(dp) && dq >= dp - 1.5 * sp) continue;
          windows.emplace_back(dq - 2 * sp, dq + 2 * sp);
        }
        if (windows.empty()) continue;
        double s0 = depths.front(), s1 = depths.back();
        if (!ray.Aim(region.x + c + 0.5, region.y + r + 0.5, &s0, &s1)) continue;
        const double limit = std::isfinite(dp) ? std::min(double(dp), s1) : s1;
        std::sort(windows.begin(), windows.end());
        double best = std::isfinite(dp) ? double(dp) : std::numeric_limits<double>::infinity();
        for (const auto& [w0, w1] : windows) {
          const double a = std::max({w0, s0, depths.front()}), b = std::min(w1, limit);
          if (!(b > a) || a >= best) continue;
          const double step = SpacingAt(depths, a) / 8;
          if (!(step > 0)) continue;
          double prev = a;
          // At most kMaxEdgeSteps steps (the window is 4 spacings; 8 steps each).
          for (int i = 0; i < kMaxEdgeSteps; ++i) {
            const double t = a + i * step;
            if (!(t <= b && t < best)) break;
            if (ray.InsideAt(float(t))) {
              if (i == 0) {
                // Inside at the window's start: the entry lies in front, after the
                // last plane before it (which the sweep found outside) or the box entry.
                const auto k = std::lower_bound(depths.begin(), depths.end(), a);
                prev = std::max(s0, k == depths.begin() ? s0 : *(k - 1));
                if (!(prev < a)) {
                  best = a;
                  break;
                }
              }
              best = double(ray.Bisect(float(prev), float(t), iterations));
              break;
            }
            prev = t;
          }
        }
        if (best < double(dp) || (!std::isfinite(dp) && std::isfinite(best))) out.at<float>(r, c) = float(best);
      }
    }
  });
  ThrowIfStopped(stop, "the sweep's silhouette refinement");
}

}  // namespace

bool SweepDepthBounds(const VolumeQuery& query, const NovelView& view, const cv::Rect& region,
                      const std::vector<double>& plane_depths, bool near_misses, SweepBounds* out, StopFlag stop,
                      int threads) {
  *out = {};
  if (plane_depths.empty() || query.hull_box().empty()) return false;
  const EmptySpace& grid = query.empty_space();
  if (!grid.DepthBounds(view, region, &out->near, &out->far, stop, &out->hit_near, &out->hit_far)) return false;
  TightenBounds(query, view, region, plane_depths, near_misses, out, stop, threads);
  return true;
}

void RefineSweepDepth(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
                      const cv::Rect& tile, int iterations, cv::Mat* depth, int threads, StopFlag stop) {
  view.Check();
  if (depth == nullptr || depth->type() != CV_32FC1 || depth->size() != tile.size())
    throw std::invalid_argument("RefineSweepDepth: depth must be CV_32FC1 of the tile's size");
  if (iterations <= 0 || depths.empty() || query.hull_box().empty()) return;
  const EmptySpace& empty = query.empty_space(threads);
  ForRowChunks(tile.height, threads, nullptr, [&](int r0, int r1, SweepStats*) {
    RayQuery ray(query, view, &empty);
    for (int r = r0; r < r1 && !Stopped(stop); ++r) {
      float* row = depth->ptr<float>(r);
      for (int col = 0; col < tile.width && !Stopped(stop); ++col) {
        if (!std::isfinite(row[col])) continue;
        double s0 = depths.front(), s1 = depths.back();
        if (!ray.Aim(tile.x + col + 0.5, tile.y + r + 0.5, &s0, &s1)) continue;
        // The plane the sweep found: the nearest plane depth to the value.
        const auto it = std::lower_bound(depths.begin(), depths.end(), double(row[col]) - 1e-6);
        if (it == depths.end()) continue;
        float lo = 0;
        if (RefineBracket(depths, size_t(it - depths.begin()), s0, &lo) && lo < row[col])
          row[col] = ray.Bisect(lo, row[col], iterations);
      }
    }
  });
  // The silhouette pass sees only this tile's pixels: at a tile's border it has
  // fewer neighbours than in a whole-view render (PlaneSweepCpu has no such seam).
  ThrowIfStopped(stop, "the sweep's depth refinement");
  const cv::Mat swept = depth->clone();
  RefineEdges(query, empty, view, depths, tile, {0, 0, tile.width, tile.height}, iterations, swept, *depth,
              threads, stop);
}

cv::Mat PlaneSweepCpu(const VolumeQuery& query, const NovelView& view,
                      const std::vector<double>& depths, const cv::Rect& tile, SweepStats* stats,
                      int threads, int refine_iterations, StopFlag stop) {
  view.Check();
  // Not filled here: SweepRows writes every pixel of its rows, polling the stop
  // flag as it goes. Filling an 8192x8192 view up front faults in 256 MB at
  // once (0.72 s on a shared 2-core VM) before the first poll.
  cv::Mat out(tile.height, tile.width, CV_32FC1);
  if (depths.empty() || tile.area() == 0 || query.hull_box().empty()) {
    out.setTo(kNoDepth);
    return out;
  }
  // The frameset's empty space: made by the first sweep of this query (recon's
  // visibility maps), its time counted in that sweep's.
  const double t_grid = MonotonicSeconds();
  const EmptySpace& empty = query.empty_space(threads);
  SweepBounds bounds;
  if (refine_iterations <= 0) {
    const double t0 = t_grid;
    SweepDepthBounds(query, view, tile, depths, false, &bounds, stop, threads);
    const PlaneIndex planes(depths);
    ForRowChunks(tile.height, threads, stats, [&](int r0, int r1, SweepStats* st) {
      SweepRows<false>(query, empty, bounds, view, planes, tile, r0, r1, out, st, 0, stop);
    });
    ThrowIfStopped(stop, "the plane sweep");
    if (stats) stats->sweep_ms += (MonotonicSeconds() - t0) * 1e3;
    return out;
  }
  // Refinement: sweep with a one-pixel margin inside the view, so the silhouette
  // pass sees the same neighbours as a whole-view render and tiles meet without
  // seams; refine only the tile's own pixels.
  const cv::Rect region = cv::Rect(tile.x - 1, tile.y - 1, tile.width + 2, tile.height + 2) &
                          cv::Rect(0, 0, view.width, view.height);
  const double t0 = t_grid;
  cv::Mat swept(region.height, region.width, CV_32FC1);  // every pixel written by SweepRows
  SweepDepthBounds(query, view, region, depths, true, &bounds, stop, threads);
  const PlaneIndex planes(depths);
  ForRowChunks(region.height, threads, stats, [&](int r0, int r1, SweepStats* st) {
    SweepRows<true>(query, empty, bounds, view, planes, region, r0, r1, swept, st, refine_iterations, stop);
  });
  ThrowIfStopped(stop, "the plane sweep");
  const double t1 = MonotonicSeconds();
  const cv::Rect inner(tile.x - region.x, tile.y - region.y, tile.width, tile.height);
  cv::Mat refined = swept.clone();
  RefineEdges(query, empty, view, depths, region, inner, refine_iterations, swept, refined, threads, stop);
  refined(inner).copyTo(out);
  if (stats) {
    stats->sweep_ms += (t1 - t0) * 1e3;
    stats->refine_ms += (MonotonicSeconds() - t1) * 1e3;
  }
  return out;
}

cv::Rect TileRect(int i, int n, int width, int height) {
  if (n < 1 || i < 0 || i >= n || n > height)
    throw std::invalid_argument("TileRect: tile " + std::to_string(i) + "/" + std::to_string(n) +
                                " is not valid for height " + std::to_string(height));
  const int y0 = height * i / n, y1 = height * (i + 1) / n;
  return {0, y0, width, y1 - y0};
}

}  // namespace hullpipe
