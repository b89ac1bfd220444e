// scaling_bench: how the per-frameset costs that depend on the number of
// cameras grow from 4 to 8, 16 and 20 cameras (docs/benchmarks.md "Many
// cameras"). A dome of n distorted cameras (k1 -0.04, k2 0.06, as a published
// 20-camera dome) around the synthetic figure, exact object-pixel maps, at
// 644x486 and 1024x768; per row the median of --repeats runs of:
//   query     VolumeQuery set-up: per-map rectangles, the hull box search (recon,
//             sim and render each build one per frameset)
//   sweep     recon's plane sweep of a 320x240 view (48 planes, 6 refinements)
//   vis       recon's visibility maps: one 80-px sweep from every camera, each
//             voting in every camera (n sweeps over n cameras)
//   collide   sim's collision of five balls (icospheres, subdivision 2) touching
//             the figure: the hierarchy, each triangle volume-queried
// and each column's growth from the first row of its size (time / time at 4).
// The process keeps the memory it frees as the nodes do (util/memory.h): the
// runs after a row's first fault no fresh pages in, and the median of three is
// one of them.
//   scaling_bench [--cameras 4,8,16,20] [--sizes 644x486,1024x768] [--repeats 3]
//                 [--out-of-view unknown|outside]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/collision/collision.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

namespace {

using hullpipe::Camera;
using hullpipe::CameraMap;

double Ms(const std::chrono::steady_clock::time_point& t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("scaling_bench");
  hullpipe::KeepFreedMemory();  // as the nodes do (util/memory.h): no page faults per frameset
  CLI::App app{"scaling_bench: per-frameset costs against the number of cameras"};
  std::vector<int> counts = {4, 8, 16, 20};
  std::vector<std::string> sizes = {"644x486", "1024x768"};
  int repeats = 3, threads = 1;
  std::string rule = "unknown";
  app.add_option("--cameras", counts, "Camera counts")->delimiter(',')->capture_default_str();
  app.add_option("--sizes", sizes, "Image sizes WxH")->delimiter(',')->capture_default_str();
  app.add_option("--repeats", repeats, "Runs per row (median)")->check(CLI::Range(1, 100))->capture_default_str();
  app.add_option("--threads", threads, "Threads of the sweeps")->check(CLI::Range(1, 64))->capture_default_str();
  app.add_option("--out-of-view", rule, "unknown (the nodes' default, at least 2 cameras) | outside")
      ->check(CLI::IsMember({"unknown", "outside"}))
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  hullpipe::VolumeQueryOptions qo;
  qo.out_of_view = rule == "outside" ? hullpipe::OutOfView::kOutside : hullpipe::OutOfView::kUnknown;
  for (const int n : counts)
    if (n < 2 || n > 64) {
      std::fprintf(stderr, "scaling_bench: --cameras: each count must be in [2, 64], not %d\n", n);
      return 2;
    }

  const hullpipe::SyntheticScene scene = hullpipe::AnimatedFigure(0.7);
  const Eigen::Vector3d target(0, 0, -0.9);
  hullpipe::Aabb workspace;
  workspace.min = Eigen::Vector3d(-1.5, -1.5, -2.2);
  workspace.max = Eigen::Vector3d(1.5, 1.5, 0.02);
  const hullpipe::NovelView view = hullpipe::NovelView::FromFov(
      320, 240, 0.9, hullpipe::LookAt(Eigen::Vector3d(2.6, 1.4, -1.6), target, Eigen::Vector3d(0, 0, -1)));
  std::printf("%-10s %4s %9s %9s %9s %9s   growth from the first row: query sweep vis collide\n", "size",
              "cams", "query ms", "sweep ms", "vis ms", "collide ms");
  for (const std::string& size : sizes) {
    int w = 0, h = 0;
    if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2 || w < 16 || h < 16 || w > 4096 || h > 4096) {
      std::fprintf(stderr, "scaling_bench: --sizes: '%s' is not WxH within [16, 4096]\n", size.c_str());
      return 2;
    }
    double base[4] = {0, 0, 0, 0};
    for (const int n : counts) {
      const auto cams = hullpipe::DomeCameras(n, 3.2, target, w, h, 1.1,
                                              hullpipe::Distortion{-0.04, 0.06, 0, 0, 0});
      std::vector<CameraMap> views;
      for (const Camera& c : cams) views.push_back({c, hullpipe::RenderExactMap(c, scene)});
      std::vector<double> tq, ts, tv, tc;
      for (int r = 0; r < repeats; ++r) {
        auto t0 = std::chrono::steady_clock::now();
        const hullpipe::VolumeQuery q(views, workspace, qo);
        tq.push_back(Ms(t0));
        hullpipe::PlaneSweepOptions o;
        o.num_planes = 48;
        t0 = std::chrono::steady_clock::now();
        const auto depths = hullpipe::SweepPlaneDepths(q, view, o);
        hullpipe::PlaneSweepCpu(q, view, depths, {0, 0, view.width, view.height}, nullptr, threads, 6);
        ts.push_back(Ms(t0));
        t0 = std::chrono::steady_clock::now();
        hullpipe::ComputeHullVisibility(q, cams, 80, o, 4, threads);
        tv.push_back(Ms(t0));
        t0 = std::chrono::steady_clock::now();
        const Eigen::Vector3d c = q.hull_box().Center();
        for (int b = 0; b < 5; ++b) {
          hullpipe::Rigid3d pose;
          pose.translation = c + Eigen::Vector3d(0.15 * (b - 2), 0.1, -0.2 + 0.1 * b);
          const auto mesh = hullpipe::TriangleMesh::Icosphere(0.1, 2).Transformed(pose);
          hullpipe::DetectCollisions(q, mesh);
        }
        tc.push_back(Ms(t0));
        if (r == 0) {  // once per run in render and sim: not in the table's medians
          t0 = std::chrono::steady_clock::now();
          HullExtentAlong(q, Eigen::Vector3d(0, 0, 1));
          const double floor_ms = Ms(t0);
          t0 = std::chrono::steady_clock::now();
          SampledHullBox(q);
          std::fprintf(stderr, "%s, %d cameras: first hull's floor %.0f ms, its box %.0f ms\n", size.c_str(), n,
                       floor_ms, Ms(t0));
        }
      }
      const double m[4] = {Median(tq), Median(ts), Median(tv), Median(tc)};
      if (base[0] == 0)
        for (int k = 0; k < 4; ++k) base[k] = m[k];
      std::printf("%-10s %4d %9.1f %9.1f %9.1f %9.1f   x%.1f x%.1f x%.1f x%.1f\n", size.c_str(), n, m[0], m[1], m[2],
                  m[3], m[0] / base[0], m[1] / base[1], m[2] / base[2], m[3] / base[3]);
      std::fflush(stdout);
    }
  }
  return 0;
}
