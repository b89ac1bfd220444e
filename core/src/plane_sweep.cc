#include "hullpipe/plane_sweep.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

#include "hullpipe/conventions.h"

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
  if (num_planes < 2) throw std::invalid_argument("PlaneSweepOptions: num_planes must be >= 2");
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
  RayQuery(const VolumeQuery& q, const NovelView& view)
      : q_(q), cams_(q.fast()), n_(cams_.size()), unknown_(q.options().out_of_view == OutOfView::kUnknown),
        view_(view), A_(n_), B_(n_), order_(n_) {
    const Eigen::Vector3d O = view.world_from_eye.translation;
    for (size_t c = 0; c < n_; ++c) {
      A_[c] = (q.views()[c].camera.cam_from_world * O).cast<float>();
      order_[c] = c;
    }
  }
  // Aims at pixel (u, v) of the view; returns the ray's part [*s0, *s1] in the
  // hull box (false if it misses).
  bool Aim(double u, double v, double* s0, double* s1) {
    const Eigen::Vector3d D = view_.world_from_eye.rotation * view_.EyeRay(u, v);
    if (!q_.hull_box().ClipRay(view_.world_from_eye.translation, D, s0, s1)) return false;
    for (size_t c = 0; c < n_; ++c) B_[c] = (q_.views()[c].camera.cam_from_world.rotation * D).cast<float>();
    return true;
  }
  // Is the point at eye depth d on the aimed ray inside the hull?
  bool InsideAt(float d) {
    int object = 0, unseen = 0;
    for (size_t j = 0; j < n_; ++j) {
      const size_t c = order_[j];
      ++projections;
      const Eigen::Vector3f X = A_[c] + d * B_[c];
      const Vote vote = VolumeQuery::VoteFast(cams_[c], X.x(), X.y(), X.z());
      if (vote == Vote::kObject) {
        ++object;
      } else if (vote == Vote::kBackground || !unknown_) {
        // The camera that rejected goes first next time: neighbouring points are
        // usually rejected by the same camera.
        if (j > 0) std::rotate(order_.begin(), order_.begin() + long(j), order_.begin() + long(j) + 1);
        return false;
      } else {
        ++unseen;
      }
    }
    return q_.Accepts(object, unseen);
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
  int64_t projections = 0;

 private:
  const VolumeQuery& q_;
  const std::vector<detail::FastCamera>& cams_;
  size_t n_;
  bool unknown_;
  const NovelView& view_;
  std::vector<Eigen::Vector3f> A_, B_;
  std::vector<size_t> order_;
};

// The bracket below plane k for refinement: the previous plane or the hull box
// entry, whichever is deeper. The near plane (k == 0) is not refined: in front of
// it the frustum is cut.
bool RefineBracket(const std::vector<double>& depths, size_t k, double s0, float* lo) {
  if (k == 0) return false;
  *lo = float(std::max(depths[k - 1], s0));
  return true;
}

void SweepRows(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
               const cv::Rect& tile, int row_begin, int row_end, cv::Mat& out, SweepStats* stats,
               int refine_iterations) {
  RayQuery ray(query, view);
  const std::vector<float> d(depths.begin(), depths.end());
  SweepStats local;
  for (int r = row_begin; r < row_end; ++r) {
    float* out_row = out.ptr<float>(r);
    for (int col = 0; col < tile.width; ++col) {
      out_row[col] = kNoDepth;
      double s0 = depths.front(), s1 = depths.back();
      if (!ray.Aim(tile.x + col + 0.5, tile.y + r + 0.5, &s0, &s1)) continue;
      ++local.rays;
      // First plane at or beyond s0 (the box entry), last at or before s1.
      const size_t first = size_t(std::lower_bound(depths.begin(), depths.end(), s0) - depths.begin());
      for (size_t k = first; k < d.size() && depths[k] <= s1; ++k) {
        ++local.plane_points;
        if (!ray.InsideAt(d[k])) continue;
        float lo = 0;
        out_row[col] = refine_iterations > 0 && RefineBracket(depths, k, s0, &lo)
                           ? ray.Bisect(lo, d[k], refine_iterations)
                           : d[k];
        break;
      }
    }
  }
  local.projections = ray.projections;
  if (stats) {
    stats->rays += local.rays;
    stats->plane_points += local.plane_points;
    stats->projections += local.projections;
  }
}

// Runs rows(r0, r1, stats) over `threads` bands of [0, height).
template <class Rows>
void ForRowBands(int height, int threads, SweepStats* stats, Rows rows) {
  threads = std::clamp(threads, 1, std::max(1, height));
  std::vector<SweepStats> per(static_cast<size_t>(threads));
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t)
    pool.emplace_back([&, t] { rows(height * t / threads, height * (t + 1) / threads, &per[size_t(t)]); });
  rows(0, height / threads, &per[0]);
  for (auto& th : pool) th.join();
  if (stats)
    for (const auto& st : per) {
      stats->rays += st.rays;
      stats->plane_points += st.plane_points;
      stats->projections += st.projections;
    }
}

}  // namespace

void RefineSweepDepth(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
                      const cv::Rect& tile, int iterations, cv::Mat* depth, int threads) {
  view.Check();
  if (depth == nullptr || depth->type() != CV_32FC1 || depth->size() != tile.size())
    throw std::invalid_argument("RefineSweepDepth: depth must be CV_32FC1 of the tile's size");
  if (iterations <= 0 || depths.empty() || query.hull_box().empty()) return;
  ForRowBands(tile.height, threads, nullptr, [&](int r0, int r1, SweepStats*) {
    RayQuery ray(query, view);
    for (int r = r0; r < r1; ++r) {
      float* row = depth->ptr<float>(r);
      for (int col = 0; col < tile.width; ++col) {
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
}

cv::Mat PlaneSweepCpu(const VolumeQuery& query, const NovelView& view,
                      const std::vector<double>& depths, const cv::Rect& tile, SweepStats* stats,
                      int threads, int refine_iterations) {
  view.Check();
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(kNoDepth));
  if (depths.empty() || tile.area() == 0 || query.hull_box().empty()) return out;
  ForRowBands(tile.height, threads, stats, [&](int r0, int r1, SweepStats* st) {
    SweepRows(query, view, depths, tile, r0, r1, out, st, refine_iterations);
  });
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
