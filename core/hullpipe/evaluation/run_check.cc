#include "hullpipe/evaluation/run_check.h"

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/reconstruction/exact_hull.h"

namespace hullpipe {

namespace {

constexpr const char* kViewsHeader =
    "frame_seq,path_time_s,width,height,fx,fy,cx,cy,r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz";

}  // namespace

std::vector<RunView> ReadRunViews(const std::string& csv_path) {
  std::ifstream in(csv_path);
  if (!in) throw std::runtime_error(csv_path + ": cannot be read (render_node writes it with --save-depth)");
  std::string line;
  if (!std::getline(in, line) || line != kViewsHeader)
    throw std::runtime_error(csv_path + ": line 1 is not render_node's views.csv header");
  std::vector<RunView> rows;
  for (int n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::string where = csv_path + " line " + std::to_string(n);
    std::vector<double> v;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) {
      size_t used = 0;
      double x = 0;
      try {
        x = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != cell.size() || !std::isfinite(x))
        throw std::runtime_error(where + ": '" + cell + "' is not a finite number");
      v.push_back(x);
    }
    if (v.size() != 20) throw std::runtime_error(where + ": " + std::to_string(v.size()) + " fields, 20 expected");
    RunView r;
    if (v[0] < 1 || v[0] > 9e15 || v[0] != std::floor(v[0]))
      throw std::runtime_error(where + ": frame_seq must be a positive integer");
    r.frame_seq = uint64_t(v[0]);
    r.path_time_s = v[1];
    if (v[2] != std::floor(v[2]) || v[3] != std::floor(v[3]) || v[2] < 1 || v[3] < 1 || v[2] > 16384 || v[3] > 16384)
      throw std::runtime_error(where + ": width and height must be integers in [1, 16384]");
    r.view.width = int(v[2]), r.view.height = int(v[3]);
    r.view.fx = v[4], r.view.fy = v[5], r.view.cx = v[6], r.view.cy = v[7];
    Eigen::Matrix3d R;
    R << v[8], v[9], v[10], v[11], v[12], v[13], v[14], v[15], v[16];
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0)
      throw std::runtime_error(where + ": r00..r22 are not a rotation");
    r.view.world_from_eye.rotation = R;
    r.view.world_from_eye.translation = {v[17], v[18], v[19]};
    try {
      r.view.Check();
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error(where + ": " + e.what());
    }
    rows.push_back(r);
  }
  return rows;
}

std::string RunDepthPath(const std::string& run_dir, uint64_t frame_seq, bool right) {
  char name[64];
  std::snprintf(name, sizeof name, right ? "/frame_%05llu_right_depth.tiff" : "/frame_%05llu_depth.tiff",
                (unsigned long long)frame_seq);
  return run_dir + name;
}

void RunCheckOptions::Check() const {
  sweep.Check();
  if (refine < 0 || refine > 30) throw std::invalid_argument("refine must be in [0, 30]");
  if (exact_stride < 1 || exact_stride > 4096) throw std::invalid_argument("exact_stride must be in [1, 4096]");
  if (threads < 1 || threads > 256) throw std::invalid_argument("threads must be in [1, 256]");
}

RunFrameCheck CheckRunFrame(const VolumeQuery& query, const NovelView& view, const cv::Mat& depth,
                            const RunCheckOptions& o) {
  o.Check();
  view.Check();
  if (depth.type() != CV_32FC1 || depth.cols != view.width || depth.rows != view.height)
    throw std::invalid_argument("CheckRunFrame: the depth must be CV_32FC1 of the view's size");
  const auto t0 = std::chrono::steady_clock::now();
  RunFrameCheck c;
  c.pixels = int64_t(depth.total());
  // 1. The direct sweep, as a recon node runs it (its tiles assembled equal
  // the whole view's sweep: the plane depths are the view's).
  const cv::Rect all(0, 0, view.width, view.height);
  const cv::Mat sweep =
      PlaneSweepCpu(query, view, SweepPlaneDepths(query, view, o.sweep), all, nullptr, o.threads, o.refine);
  for (int r = 0; r < depth.rows; ++r) {
    const float* g = depth.ptr<float>(r);
    const float* s = sweep.ptr<float>(r);
    for (int k = 0; k < depth.cols; ++k) {
      c.hull_pixels += std::isfinite(g[k]);
      c.equal_to_sweep += g[k] == s[k] || (std::isnan(g[k]) && std::isnan(s[k]));  // +inf == +inf
    }
  }
  // 2. The exact hull at every stride-th pixel: a view whose pixel (r, k) has
  // the centre of the run's pixel (r s, k s), so ExactHullDepth's rays are the
  // run's own.
  const int s = o.exact_stride;
  NovelView sampled = view;
  sampled.width = (view.width + s - 1) / s;
  sampled.height = (view.height + s - 1) / s;
  sampled.fx = view.fx / s, sampled.fy = view.fy / s;
  sampled.cx = (view.cx - 0.5) / s + 0.5, sampled.cy = (view.cy - 0.5) / s + 0.5;
  const cv::Mat exact = ExactHullDepth(query, sampled, cv::Rect(0, 0, sampled.width, sampled.height), o.threads);
  cv::Mat got(sampled.height, sampled.width, CV_32FC1);
  for (int r = 0; r < sampled.height; ++r)
    for (int k = 0; k < sampled.width; ++k) got.at<float>(r, k) = depth.at<float>(r * s, k * s);
  c.exact = CompareDepth(got, exact);
  c.exact_pixels = int64_t(got.total());
  c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

}  // namespace hullpipe
