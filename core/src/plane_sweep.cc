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

void SweepRows(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
               const cv::Rect& tile, int row_begin, int row_end, cv::Mat& out, SweepStats* stats,
               int refine_iterations) {
  const auto& cams = query.fast();
  const size_t n = cams.size();
  const bool unknown = query.options().out_of_view == OutOfView::kUnknown;
  const Aabb& box = query.hull_box();
  const Eigen::Matrix3d& R_we = view.world_from_eye.rotation;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  // Camera-frame point at eye depth d along a pixel ray: A_c + d * B_c.
  std::vector<Eigen::Vector3f> A(n), B(n);
  for (size_t c = 0; c < n; ++c) {
    const Eigen::Matrix3d& R = query.views()[c].camera.cam_from_world.rotation;
    A[c] = (R * O + query.views()[c].camera.cam_from_world.translation).cast<float>();
  }
  std::vector<float> d(depths.begin(), depths.end());
  std::vector<size_t> order(n);
  for (size_t c = 0; c < n; ++c) order[c] = c;
  SweepStats local;
  for (int r = row_begin; r < row_end; ++r) {
    float* out_row = out.ptr<float>(r);
    const double v = tile.y + r + 0.5;
    for (int col = 0; col < tile.width; ++col) {
      out_row[col] = kNoDepth;
      const double u = tile.x + col + 0.5;
      const Eigen::Vector3d D = R_we * view.EyeRay(u, v);
      double s0 = depths.front(), s1 = depths.back();
      if (!box.ClipRay(O, D, &s0, &s1)) continue;
      ++local.rays;
      for (size_t c = 0; c < n; ++c) {
        const Eigen::Matrix3d& R = query.views()[c].camera.cam_from_world.rotation;
        B[c] = (R * D).cast<float>();
      }
      // First plane at or beyond s0 (the box entry), last at or before s1.
      auto inside_at = [&](float dk) {
        int object = 0, unseen = 0;
        for (size_t j = 0; j < n; ++j) {
          const size_t c = order[j];
          ++local.projections;
          const Eigen::Vector3f X = A[c] + dk * B[c];
          const Vote vote = VolumeQuery::VoteFast(cams[c], X.x(), X.y(), X.z());
          if (vote == Vote::kObject) {
            ++object;
          } else if (vote == Vote::kBackground || !unknown) {
            // The camera that rejected goes first next time: neighbouring points
            // are usually rejected by the same camera.
            if (j > 0) std::rotate(order.begin(), order.begin() + long(j), order.begin() + long(j) + 1);
            return false;
          } else {
            ++unseen;
          }
        }
        return query.Accepts(object, unseen);
      };
      const size_t first = size_t(std::lower_bound(depths.begin(), depths.end(), s0) - depths.begin());
      for (size_t k = first; k < d.size() && depths[k] <= s1; ++k) {
        ++local.plane_points;
        if (!inside_at(d[k])) continue;
        float hi = d[k];
        // The near plane itself is not refined: in front of it the frustum is cut.
        if (refine_iterations > 0 && k > 0) {
          float lo = k > first ? d[k - 1] : float(s0);
          for (int it = 0; it < refine_iterations; ++it) {
            const float mid = 0.5f * (lo + hi);
            (inside_at(mid) ? hi : lo) = mid;
          }
        }
        out_row[col] = hi;
        break;
      }
    }
  }
  if (stats) {
    stats->rays += local.rays;
    stats->plane_points += local.plane_points;
    stats->projections += local.projections;
  }
}

}  // namespace

cv::Mat PlaneSweepCpu(const VolumeQuery& query, const NovelView& view,
                      const std::vector<double>& depths, const cv::Rect& tile, SweepStats* stats,
                      int threads, int refine_iterations) {
  view.Check();
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(kNoDepth));
  if (depths.empty() || tile.area() == 0 || query.hull_box().empty()) return out;
  threads = std::clamp(threads, 1, std::max(1, tile.height));
  if (threads == 1) {
    SweepRows(query, view, depths, tile, 0, tile.height, out, stats, refine_iterations);
    return out;
  }
  std::vector<SweepStats> per(static_cast<size_t>(threads));
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const int r0 = tile.height * t / threads, r1 = tile.height * (t + 1) / threads;
    pool.emplace_back([&, t, r0, r1] { SweepRows(query, view, depths, tile, r0, r1, out, &per[size_t(t)], refine_iterations); });
  }
  for (auto& th : pool) th.join();
  if (stats)
    for (const auto& s : per) {
      stats->rays += s.rays;
      stats->plane_points += s.plane_points;
      stats->projections += s.projections;
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
