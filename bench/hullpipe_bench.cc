// hullpipe_bench: times the per-frame algorithms on frame 200 of the real rig
// (or the synthetic scene with --synthetic) and prints a Markdown table:
// segmentation, CPU and GL plane sweeps at 320x240 and 640x480 with 50/100/200
// planes, texturing, and the triangle query (the paper's case: 720 triangles in
// 10x10 viewports). Each figure is the median of --repeats runs.
// With --backend cpu|gl|both it prints instead the backend table (docs/gpu.md):
// a whole recon frame (upload, visibility maps, sweep with refinement, texture)
// at three view sizes with 4, 8 and 16 cameras and 50/100/200 planes, and the
// triangle query at 720, 10,000 and 100,000 triangles, on one synthetic input
// for both backends, ratios beside times.
#include <algorithm>
#include <cstring>
#include <cstdio>
#include <functional>
#include <thread>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/util/percentile.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/gl/backend.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_ray_sweep.h"
#include "hullpipe/gl/gl_texture.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/geometry/mesh.h"
#include "hullpipe/reconstruction/empty_space.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/segmentation/segmentation.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

using namespace hullpipe;

namespace {

// Milliseconds of one-eye and two-eye frames (frame(n_eyes), wall ms) and
// their ratios, `repeats` rounds after a warm-up of each. The two alternate,
// the order swapped each round, so the machine's drift falls on both; the
// ratio is the median of each round's.
struct EyeFrames {
  std::vector<double> ones, twos, ratios;
};
EyeFrames AlternateEyes(int repeats, const std::function<double(int)>& frame) {
  (void)frame(1), (void)frame(2);  // warm-up
  EyeFrames f;
  for (int r = 0; r < repeats; ++r) {
    double t1 = 0, t2 = 0;
    if (r % 2 == 0) {
      t1 = frame(1), t2 = frame(2);
    } else {
      t2 = frame(2), t1 = frame(1);
    }
    f.ones.push_back(t1), f.twos.push_back(t2), f.ratios.push_back(t2 / t1);
  }
  return f;
}

double MedianMs(int repeats, const std::function<void()>& f) {
  std::vector<double> t;
  f();  // warm-up
  for (int i = 0; i < repeats; ++i) {
    const double t0 = MonotonicSeconds();
    f();
    t.push_back((MonotonicSeconds() - t0) * 1e3);
  }
  return Median(std::move(t));
}

// One eye's CPU sweep (refine 6, one thread) under two queries of the same
// input, interleaved after a warm-up: the medians' samples, the last runs'
// counters, and whether the depth images are the same to the bit (+inf ==
// +inf where no hull).
struct SweepPair {
  std::vector<double> ms_a, ms_b;
  SweepStats stats_a, stats_b;
  bool same = false;
};
SweepPair CompareSweeps(const VolumeQuery& qa, const VolumeQuery& qb, const NovelView& v,
                        const std::vector<double>& depths, const cv::Rect& all, int repeats) {
  SweepPair p;
  cv::Mat da, db;
  for (int r = 0; r <= repeats; ++r) {
    SweepStats a, b;
    da = PlaneSweepCpu(qa, v, depths, all, &a, 1, 6);
    db = PlaneSweepCpu(qb, v, depths, all, &b, 1, 6);
    if (r == 0) continue;  // warm-up
    p.ms_a.push_back(a.sweep_ms + a.refine_ms);
    p.ms_b.push_back(b.sweep_ms + b.refine_ms);
    p.stats_a = a;
    p.stats_b = b;
  }
  p.same = cv::countNonZero(da != db) == 0;
  return p;
}

std::string Ms2(double ms) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", ms);
  return b;
}

void Row(const std::string& what, const std::string& config, double ms, const std::string& extra = "") {
  std::printf("| %-28s | %-34s | %9.2f | %-28s |\n", what.c_str(), config.c_str(), ms, extra.c_str());
  std::fflush(stdout);
}

// The backend table's input: a seated-person-sized figure (head, torso, arms,
// legs as spheres and capsules, 1.3 m tall) seen by n cameras on a ring, exact
// object-pixel maps at the rig's 644x486 and half-size colour images with a
// pattern per camera.
struct BackendInput {
  std::vector<CameraMap> views;
  std::vector<Camera> cameras;  // the views' cameras (also the images')
  std::vector<CameraImage> images;
  Eigen::Vector3d centre{0, 0, -0.8};
};

BackendInput MakeBackendInput(int cameras) {
  BackendInput in;
  const Eigen::Vector3d c = in.centre;
  SyntheticScene scene;
  scene.shapes.push_back(Shape::Sphere(c + Eigen::Vector3d(0, 0, -0.55), 0.11));
  scene.shapes.push_back(Shape::Capsule(c + Eigen::Vector3d(0, 0, -0.35), c + Eigen::Vector3d(0, 0, 0.1), 0.16));
  scene.shapes.push_back(
      Shape::Capsule(c + Eigen::Vector3d(0.2, 0, -0.3), c + Eigen::Vector3d(0.45, 0.25, 0.0), 0.045));
  scene.shapes.push_back(
      Shape::Capsule(c + Eigen::Vector3d(-0.2, 0, -0.3), c + Eigen::Vector3d(-0.4, 0.3, -0.1), 0.045));
  scene.shapes.push_back(Shape::Capsule(c + Eigen::Vector3d(0.1, 0, 0.15), c + Eigen::Vector3d(0.12, 0.45, 0.6), 0.07));
  scene.shapes.push_back(
      Shape::Capsule(c + Eigen::Vector3d(-0.1, 0, 0.15), c + Eigen::Vector3d(-0.12, 0.45, 0.6), 0.07));
  for (const Camera& cam : RingCameras(cameras, 3.0, 1.8, c, 644, 486, 1.0)) {
    // With its object rectangle, as recon's maps arrive (the map's decoded runs give it).
    const cv::Mat map = RenderExactMap(cam, scene);
    in.views.push_back({cam, map, cv::boundingRect(map)});
    in.cameras.push_back(cam);
    cv::Mat img(243, 322, CV_8UC3);
    for (int r = 0; r < img.rows; ++r)
      for (int k = 0; k < img.cols; ++k)
        img.at<cv::Vec3b>(r, k) = cv::Vec3b(uint8_t((k * 3 + 40 * cam.id) % 256), uint8_t((r * 5) % 256),
                                            uint8_t(((r + k) * 2) % 256));
    in.images.push_back({cam, img});
  }
  return in;
}

// One recon_node frame of a stereo frameset, as recon makes it: the
// frameset's query (hull box included, its search on query_threads), upload
// and visibility maps (recon's default width, 80 px; 48 planes), made once,
// then for each of the first n_eyes eyes its plane depths (`planes`) and its
// tile's sweep and texture. Wall ms of the whole and of its parts; on the CPU
// backend (cpu_backend) also the empty-space grid's, which its first sweep
// (a visibility map's) makes.
struct ReconFrameMs {
  double total = 0;
  double shared = 0;  // query, upload and visibility maps
  double query = 0;
  double grid = 0;  // the CPU's empty-space grid
  std::vector<SweepStats> eye_stats;
  std::vector<double> eye_texture;
};
ReconFrameMs ReconFrame(SweepBackend& b, const BackendInput& in, const StereoViews& eyes, int n_eyes,
                        const cv::Rect& tile, int planes, int query_threads, bool cpu_backend) {
  ReconFrameMs ms;
  const double t0 = MonotonicSeconds();
  VolumeQueryOptions qo;
  qo.threads = query_threads;
  const VolumeQuery q(in.views, DefaultWorkspace(in.cameras), qo);
  const double t1 = MonotonicSeconds();
  b.BeginFrameset(q, in.images);
  PlaneSweepOptions vo;
  vo.num_planes = 48;
  b.ComputeVisibility(q, in.cameras, 80, vo);
  ms.query = (t1 - t0) * 1e3;
  ms.shared = (MonotonicSeconds() - t0) * 1e3;
  for (int e = 0; e < n_eyes; ++e) {
    PlaneSweepOptions o;
    o.num_planes = planes;
    const NovelView& v = eyes.eye[size_t(e)];
    SweepStats st;
    const TexturedTile t = b.SweepTextured(q, v, SweepPlaneDepths(q, v, o), tile, in.images, true, &st);
    ms.eye_stats.push_back(st);
    ms.eye_texture.push_back(t.texture_ms);
  }
  ms.total = (MonotonicSeconds() - t0) * 1e3;
  if (cpu_backend) ms.grid = q.empty_space().build_ms();
  return ms;
}

// Which rows of the backend table to run (--cameras, --sizes, --planes,
// --triangles): all by default.
struct TableRows {
  std::vector<int> cameras{4, 8, 16};
  std::vector<std::string> sizes{"320x240", "640x480", "1280x720"};
  std::vector<int> planes{50, 100, 200};
  std::vector<int> triangles{720, 10000, 100000};
  int cpu_threads = 1;  // the CPU backend's threads (recon_node --threads)
};

int BackendTable(const std::string& which, int repeats, int gl_device, const TableRows& rows) {
  std::unique_ptr<SweepBackend> cpu, gpu;
  if (which != "gl") cpu = gl::MakeSweepBackend("cpu", rows.cpu_threads, 6);
  std::optional<gl::EglContext> tri_ctx;
  if (which != "cpu") {
    BackendOptions o;
    o.name = "gl";
    o.refine = 6;
    o.gl_device = gl_device;
    try {
      gpu = gl::MakeSweepBackend(o);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 1;
    }
  }
  std::printf("backend table: %u hardware threads, CPU backend %d thread(s); GL: %s\n",
              std::thread::hardware_concurrency(), rows.cpu_threads, gpu ? gpu->GlSummary().c_str() : "not run");
  std::printf(
      "frame = upload + visibility maps (4..16 x 80 px, 48 planes) + sweep (refine 6) + texture; median of %d\n\n",
      repeats);
  std::printf(
      "| view      | cams | planes | CPU sweep ms | CPU frame ms | GL sweep ms | GL frame ms | GL two waits ms | frame CPU/GL |\n");
  std::printf(
      "|-----------|------|--------|--------------|--------------|-------------|-------------|-------------------|--------------|\n");
  // The frame as recon_node renders it (SweepTextured: on GL one wait for the
  // GPU per tile); *two_waits_ms the same with Sweep and Texture called apart
  // (a read-back each), as recon did before.
  auto frame = [&](SweepBackend& b, const BackendInput& in, const VolumeQuery& q, const NovelView& view,
                   const std::vector<double>& depths, double* sweep_ms, double* two_waits_ms) {
    const std::vector<Camera>& cams = in.cameras;
    PlaneSweepOptions vo;
    vo.num_planes = 48;
    const cv::Rect all(0, 0, view.width, view.height);
    *sweep_ms = MedianMs(repeats, [&] { (void)b.Sweep(q, view, depths, all); });
    *two_waits_ms = MedianMs(repeats, [&] {
      b.BeginFrameset(q, in.images);
      b.ComputeVisibility(q, cams, 80, vo);
      const cv::Mat d = b.Sweep(q, view, depths, all);
      (void)b.Texture(d, all, view, in.images, true);
    });
    return MedianMs(repeats, [&] {
      b.BeginFrameset(q, in.images);
      b.ComputeVisibility(q, cams, 80, vo);
      (void)b.SweepTextured(q, view, depths, all, in.images, true);
    });
  };
  // The same frame stage by stage, each waited for (SweepBackend::Finish):
  // where a frame's time goes (the frame above overlaps them on a GPU).
  std::vector<std::string> stage_rows, narrow_rows;
  auto stages = [&](SweepBackend& b, const BackendInput& in, const VolumeQuery& q, const NovelView& view,
                    const std::vector<double>& depths) {
    const std::vector<Camera>& cams = in.cameras;
    PlaneSweepOptions vo;
    vo.num_planes = 48;
    const cv::Rect all(0, 0, view.width, view.height);
    std::vector<double> t[4];
    for (int r = 0; r <= repeats; ++r) {  // the first a warm-up
      double mark = MonotonicSeconds();
      auto lap = [&](int k) {
        b.Finish();
        const double now = MonotonicSeconds();
        if (r > 0) t[k].push_back((now - mark) * 1e3);
        mark = now;
      };
      b.BeginFrameset(q, in.images);
      lap(0);
      b.ComputeVisibility(q, cams, 80, vo);
      lap(1);
      const cv::Mat d = b.Sweep(q, view, depths, all);
      lap(2);
      (void)b.Texture(d, all, view, in.images, true);
      lap(3);
    }
    // The GPU's own timeline of the frame as recon renders it, nothing waited
    // for between stages (GL timestamps after each call; the last call's
    // read-back waits): what each stage adds to the GPU's span, and the span
    // itself against the frame's wall time (the rest is the CPU's and the
    // driver's: waits, set-up, copies).
    std::vector<double> g[3], span, wall;
    b.Finish();  // makes the backend's context current here
    gl::Query stamp[4] = {gl::MakeQuery(GL_TIMESTAMP), gl::MakeQuery(GL_TIMESTAMP), gl::MakeQuery(GL_TIMESTAMP),
                          gl::MakeQuery(GL_TIMESTAMP)};
    for (int r = 0; r <= repeats; ++r) {
      b.Finish();
      const double w0 = MonotonicSeconds();
      glQueryCounter(stamp[0].get(), GL_TIMESTAMP);
      b.BeginFrameset(q, in.images);
      glQueryCounter(stamp[1].get(), GL_TIMESTAMP);
      b.ComputeVisibility(q, cams, 80, vo);
      glQueryCounter(stamp[2].get(), GL_TIMESTAMP);
      (void)b.SweepTextured(q, view, depths, all, in.images, true);
      glQueryCounter(stamp[3].get(), GL_TIMESTAMP);
      const double w1 = MonotonicSeconds();
      GLuint64 ns[4];
      for (int k = 0; k < 4; ++k) glGetQueryObjectui64v(stamp[k].get(), GL_QUERY_RESULT, &ns[k]);
      if (r == 0) continue;  // warm-up
      for (int k = 0; k < 3; ++k) g[k].push_back(double(ns[k + 1] - ns[k]) * 1e-6);
      span.push_back(double(ns[3] - ns[0]) * 1e-6);
      wall.push_back((w1 - w0) * 1e3);
    }
    // The bytes the backend's uploads send, as its uploaders count them (a
    // probe of each in the backend's context, current since the Finish above):
    // the colour images around their cameras' object pixels
    // (GlTexture::ObjectImageRects) against the whole images, and the maps
    // (their object rectangles, as bits) against a byte a pixel.
    double part_kb = 0, whole_kb = 0, map_bits_kb = 0, map_bytes_kb = 0;
    {
      gl::GlTexture images;
      const std::vector<cv::Rect> parts = gl::GlTexture::ObjectImageRects(q, in.images);
      images.UploadImages(in.images, &parts);
      part_kb = double(images.uploaded_bytes()) * 1e-3;
      images.UploadImages(in.images);
      whole_kb = double(images.uploaded_bytes()) * 1e-3;
      gl::GlRaySweep maps;
      maps.Upload(q);
      map_bits_kb = double(maps.last_upload_bytes()) * 1e-3;
      for (size_t c = 0; c < q.size(); ++c) map_bytes_kb += q.object_rect(c).area() * 1e-3;
    }
    // The march alone with and without its narrowing to the object rectangles
    // (GlRaySweep::set_narrowing), alternated: the view's sweep with refine 6,
    // read back, and the plane points it asked the cameras about.
    {
      gl::GlRaySweep m;
      m.Upload(q);
      std::vector<double> ms[2];
      cv::Mat d[2];
      for (int r = 0; r <= repeats; ++r)
        for (const int on : {0, 1}) {
          m.set_narrowing(on == 1);
          const double t0 = MonotonicSeconds();
          d[on] = m.Sweep(q, view, depths, all, 6);
          if (r > 0) ms[on].push_back((MonotonicSeconds() - t0) * 1e3);
        }
      uint64_t asked[2];
      m.set_counting(true);
      for (const int on : {0, 1}) {
        m.set_narrowing(on == 1);
        (void)m.Sweep(q, view, depths, all, 6);
        asked[on] = m.points_asked();
      }
      const bool same = d[0].size() == d[1].size() &&
                        std::memcmp(d[0].data, d[1].data, d[0].total() * sizeof(float)) == 0;
      char nrow[200];
      std::snprintf(nrow, sizeof nrow, "| %dx%d | %d | %zu | %llu / %llu | %.2f / %.2f | %.2f | %s |", view.width,
                    view.height, int(in.images.size()), depths.size(), (unsigned long long)asked[0],
                    (unsigned long long)asked[1], Median(ms[0]), Median(ms[1]), Median(ms[0]) / Median(ms[1]),
                    same ? "yes" : "NO");
      narrow_rows.push_back(nrow);
    }
    char row[320];
    std::snprintf(
        row, sizeof row,
        "| %dx%d | %d | %zu | %.0f / %.0f | %.0f / %.0f | %.2f | %.2f | %.2f | %.2f | %.2f / %.2f / %.2f | %.2f | %.2f |",
        view.width, view.height, int(in.images.size()), depths.size(), part_kb, whole_kb, map_bits_kb, map_bytes_kb,
        Median(t[0]), Median(t[1]), Median(t[2]), Median(t[3]), Median(g[0]), Median(g[1]), Median(g[2]), Median(span),
        Median(wall));
    stage_rows.push_back(row);
  };
  for (const int ncam : rows.cameras) {
    const BackendInput in = MakeBackendInput(ncam);
    const VolumeQuery q(in.views, DefaultWorkspace(in.cameras));
    OrbitPath orbit;
    orbit.centre = in.centre;
    for (const std::string& size : rows.sizes) {
      int w = 0, h = 0;
      if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2 || w < 8 || h < 8 || w > 8192 || h > 8192) {
        std::fprintf(stderr, "--sizes: '%s' is not WxH within [8, 8192]\n", size.c_str());
        return 2;
      }
      const NovelView view = NovelView::FromFov(w, h, 50 * M_PI / 180, orbit.WorldFromEye(1.0));
      for (const int planes : rows.planes) {
        PlaneSweepOptions o;
        o.num_planes = planes;
        const auto depths = SweepPlaneDepths(q, view, o);
        double cs = 0, cf = 0, gs = 0, gf = 0, c2 = 0, g2 = 0;
        if (cpu) {
          cpu->BeginFrameset(q, in.images);
          cf = frame(*cpu, in, q, view, depths, &cs, &c2);
        }
        if (gpu) {
          gpu->BeginFrameset(q, in.images);
          gf = frame(*gpu, in, q, view, depths, &gs, &g2);
          stages(*gpu, in, q, view, depths);
        }
        auto cell = [](double v) {
          return v > 0 ? std::to_string(v).substr(0, std::to_string(v).find('.') + 3) : std::string("-");
        };
        std::printf("| %4dx%-4d | %4d | %6d | %12s | %12s | %11s | %11s | %17s | %12s |\n", w, h, ncam, planes,
                    cell(cs).c_str(), cell(cf).c_str(), cell(gs).c_str(), cell(gf).c_str(), cell(g2).c_str(),
                    cpu && gpu ? cell(cf / gf).c_str() : "-");
        std::fflush(stdout);
      }
    }
  }
  // Calls row(ncam, input, w, h, eyes) for every camera count and view size of
  // the table: the input's figure seen by ncam cameras, and the two eyes of a
  // head pose on its orbit (the default ipd and fields of view, w x h each).
  auto for_each_eye_row = [&](const std::function<void(int, const BackendInput&, int, int, const StereoViews&)>& row) {
    for (const int ncam : rows.cameras) {
      const BackendInput in = MakeBackendInput(ncam);
      OrbitPath orbit;
      orbit.centre = in.centre;
      for (const std::string& size : rows.sizes) {
        int w = 0, h = 0;
        if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2) continue;  // checked above
        StereoOptions so;
        so.width = w, so.height = h;
        row(ncam, in, w, h, MakeStereoViews(orbit.WorldFromEye(1.0), so));
      }
    }
  };
  // A head-mounted display's frame (render_node --stereo): both eyes of one
  // frameset against one eye, the same eye's view in both (the default ipd and
  // fields of view, each eye the table's size): the maps, hull box, upload and
  // visibility are the frameset's, made once; each eye adds its plane depths,
  // sweep and texture. Same input, same planes, measured in one run.
  {
    std::printf(
        "\nStereo frame (two eyes of one frameset, render_node --stereo) against one eye, alternated, median of %d:\n\n"
        "| backend | cams | eye view | planes | one eye ms | two eyes ms | two / one | shared ms: query + maps + visibility | of which query / grid (CPU) | each eye ms: sweep / refine / texture |\n"
        "|---|---|---|---|---|---|---|---|---|---|\n",
        repeats);
    for_each_eye_row([&](int ncam, const BackendInput& in, int w, int h, const StereoViews& eyes) {
        const int planes = rows.planes.front();
        for (SweepBackend* b : {cpu.get(), gpu.get()}) {
          if (!b) continue;
          // Where the two-eye frame's time goes (CPU: the sweep's own clocks;
          // GL: queued work, so the shared part holds what the GPU has not done).
          // The shared part's query (hull box included) and, on the CPU, the
          // empty-space grid its first sweep (a visibility map's) makes.
          std::vector<double> shared, query, grid, sweep, refine, texture;
          // One frame of n_eyes eyes, wall ms. The query's search runs on
          // recon's threads, as the CPU sweep's.
          auto eyes_frame = [&](int n_eyes) {
            const bool on_cpu = b == cpu.get();
            const ReconFrameMs ms =
                ReconFrame(*b, in, eyes, n_eyes, cv::Rect(0, 0, w, h), planes, on_cpu ? rows.cpu_threads : 1, on_cpu);
            if (n_eyes == 2) {
              shared.push_back(ms.shared);
              query.push_back(ms.query);
              if (on_cpu) grid.push_back(ms.grid);
              for (int e = 0; e < n_eyes; ++e) {
                sweep.push_back(ms.eye_stats[size_t(e)].sweep_ms);
                refine.push_back(ms.eye_stats[size_t(e)].refine_ms);
                texture.push_back(ms.eye_texture[size_t(e)]);
              }
            }
            return ms.total;
          };
          const EyeFrames f = AlternateEyes(repeats, eyes_frame);
          const double one = Median(f.ones), two = Median(f.twos);
          const std::string grid_ms = grid.empty() ? "-" : Ms2(Median(grid));
          std::printf("| %s | %d | %dx%d | %d | %.2f | %.2f | %.2f | %.2f | %.2f / %s | %.2f / %.2f / %.2f |\n",
                      b == cpu.get() ? "cpu" : "gl", ncam, w, h, planes, one, two, Median(f.ratios), Median(shared),
                      Median(query), grid_ms.c_str(), Median(sweep), Median(refine), Median(texture));
          std::fflush(stdout);
        }
    });
  }
  // The stereo frame of each recon node as the demo runs them (hullpipe_launch:
  // two recon nodes on one host, --threads 0 giving each one of its two
  // cores): each node makes the frameset's query, grid and visibility maps
  // itself and sweeps and textures its tile of the view (--tile i/2, rows),
  // in stereo its tile of each eye. One-eye and two-eye frames alternated
  // (AlternateEyes), on one thread.
  if (cpu) {
    std::printf(
        "\nStereo frame of each of two recon nodes (each its half of each eye's rows, one thread; alternated, median "
        "of %d):\n\n"
        "| cams | eye view | planes | recon node (tile) | one eye ms | two eyes ms | two / one |\n"
        "|---|---|---|---|---|---|---|\n",
        repeats);
    const std::unique_ptr<SweepBackend> node = gl::MakeSweepBackend("cpu", 1, 6);
    for_each_eye_row([&](int ncam, const BackendInput& in, int w, int h, const StereoViews& eyes) {
      for (int tile = 0; tile < 2; ++tile) {
        const cv::Rect rect = TileRect(tile, 2, w, h);
        auto eyes_frame = [&](int n_eyes) {
          return ReconFrame(*node, in, eyes, n_eyes, rect, rows.planes.front(), 1, true).total;
        };
        const EyeFrames f = AlternateEyes(repeats, eyes_frame);
        std::printf("| %d | %dx%d | %d | recon%d (%d/2) | %.2f | %.2f | %.2f |\n", ncam, w, h, rows.planes.front(),
                    tile, tile, Median(f.ones), Median(f.twos), Median(f.ratios));
        std::fflush(stdout);
      }
    });
  }
  // Empty-space skipping (EmptySpace) in the CPU sweep: one eye's sweep (refine
  // 6, one thread) with the frameset's grid and without it, same input, runs
  // interleaved, and the grid's own cost (made once per frameset). The depth
  // images are compared: skipping must not change one pixel.
  if (cpu) {
    std::printf(
        "\nCPU sweep with and without empty-space skipping (one eye, the stereo table's view, refine 6, 1 thread; "
        "interleaved, median of %d):\n\n"
        "| cams | eye view | planes | grid cubes | grid ms | cubes vetoed once / twice | points skipped | sweep ms without | "
        "sweep ms with | without / with | same depth | one-eye frame ms without / with |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        repeats);
    for_each_eye_row([&](int ncam, const BackendInput& in, int w, int h, const StereoViews& eyes) {
        const NovelView& v = eyes.eye[0];
        VolumeQueryOptions with_grid, without_grid;
        without_grid.empty_space_cells = 0;
        const VolumeQuery qw(in.views, DefaultWorkspace(in.cameras), with_grid);
        const VolumeQuery qn(in.views, DefaultWorkspace(in.cameras), without_grid);
        PlaneSweepOptions o;
        o.num_planes = rows.planes.front();
        const auto depths = SweepPlaneDepths(qw, v, o);
        const cv::Rect all(0, 0, w, h);
        std::vector<double> grid_ms;
        for (int r = 0; r < repeats; ++r) {
          const VolumeQuery q(in.views, DefaultWorkspace(in.cameras), with_grid);
          grid_ms.push_back(q.empty_space(1).build_ms());
        }
        const EmptySpace& grid = qw.empty_space(1);
        const SweepPair ab = CompareSweeps(qn, qw, v, depths, all, repeats);
        const std::vector<double>&tn = ab.ms_a, &tw = ab.ms_b;
        const SweepStats& sw = ab.stats_b;
        const bool same = ab.same;
        // The whole one-eye frame as recon makes it (the query with its hull
        // box, the grid where made, visibility maps, sweep, texture): whether
        // the grid pays for itself within one frameset.
        std::vector<double> fn, fw;
        for (int r = 0; r <= repeats; ++r)
          for (const VolumeQueryOptions* qo : {&without_grid, &with_grid}) {
            const double t0 = MonotonicSeconds();
            const VolumeQuery q(in.views, DefaultWorkspace(in.cameras), *qo);
            cpu->BeginFrameset(q, in.images);
            PlaneSweepOptions vo;
            vo.num_planes = 48;
            cpu->ComputeVisibility(q, in.cameras, 80, vo);
            (void)cpu->SweepTextured(q, v, SweepPlaneDepths(q, v, o), all, in.images, true);
            if (r > 0) (qo == &with_grid ? fw : fn).push_back((MonotonicSeconds() - t0) * 1e3);
          }
        std::printf(
            "| %d | %dx%d | %d | %dx%dx%d | %.2f | %lld / %lld | %.0f%% | %.2f | %.2f | %.2f | %s | %.2f / %.2f |\n",
            ncam, w, h, o.num_planes, grid.dims().x(), grid.dims().y(), grid.dims().z(), Median(grid_ms),
            (long long)grid.vetoed_once(), (long long)grid.vetoed_twice(),
            sw.plane_points ? 100.0 * double(sw.skipped) / double(sw.plane_points) : 0.0, Median(tn), Median(tw),
            Median(tn) / Median(tw), same ? "yes" : "NO", Median(fn), Median(fw));
        std::fflush(stdout);
    });
  }
  // A sweep option's table: one eye's sweep (refine 6, one thread) with the
  // option and without, same input, interleaved; the depth images compared bit
  // for bit. `off` turns the option off; `count` is the column it fills.
  const auto option_table = [&](const char* title, const char* column, void (*off)(VolumeQueryOptions*),
                                std::string (*count)(const SweepStats&)) {
    std::printf("\nCPU sweep with and without %s (one eye, the stereo table's view, refine 6, 1 thread; "
                "interleaved, median of %d):\n\n"
                "| cams | eye view | planes | %s | sweep ms without | sweep ms with | "
                "without / with | projections without / with | same depth |\n"
                "|---|---|---|---|---|---|---|---|---|\n",
                title, repeats, column);
    for_each_eye_row([&](int ncam, const BackendInput& in, int w, int h, const StereoViews& eyes) {
        const NovelView& v = eyes.eye[0];
        VolumeQueryOptions with, without;
        off(&without);
        const VolumeQuery qw(in.views, DefaultWorkspace(in.cameras), with);
        const VolumeQuery qn(in.views, DefaultWorkspace(in.cameras), without);
        PlaneSweepOptions o;
        o.num_planes = rows.planes.front();
        const auto depths = SweepPlaneDepths(qw, v, o);
        const SweepPair ab = CompareSweeps(qn, qw, v, depths, cv::Rect(0, 0, w, h), repeats);
        std::printf("| %d | %dx%d | %d | %s | %.2f | %.2f | %.2f | %lld / %lld | %s |\n", ncam, w, h, o.num_planes,
                    count(ab.stats_b).c_str(), Median(ab.ms_a), Median(ab.ms_b), Median(ab.ms_a) / Median(ab.ms_b),
                    (long long)ab.stats_a.projections, (long long)ab.stats_b.projections, ab.same ? "yes" : "NO");
        std::fflush(stdout);
    });
  };
  if (cpu) {
    // Near-miss pruning (VolumeQueryOptions::prune_near_misses; the summed-area
    // tables are the hull box search's).
    option_table(
        "near-miss pruning", "near misses pruned", [](VolumeQueryOptions* q) { q->prune_near_misses = false; },
        [](const SweepStats& st) { return std::to_string(st.pruned); });
    // Runs of background skipped (VolumeQueryOptions::skip_background_runs).
    option_table(
        "background runs skipped", "points skipped in runs",
        [](VolumeQueryOptions* q) { q->skip_background_runs = false; },
        [](const SweepStats& st) { return std::to_string(st.run_skipped) + " of " + std::to_string(st.plane_points); });
  }
  // A node's first frameset on a fresh backend (a new context: programs built,
  // nothing allocated at the frameset's sizes), with and without the backend's
  // warm-up frame at creation; then its second. One run each: a first is once.
  if (gpu) {
    std::printf(
        "\nGL backend's first framesets (16 cameras 640x480 in the view, 100 planes; one fresh backend each):\n\n"
        "| warm-up at creation | creation ms | first frame ms | second frame ms |\n|---|---|---|---|\n");
    const BackendInput in = MakeBackendInput(16);
    const std::vector<Camera>& cams = in.cameras;
    const VolumeQuery q(in.views, DefaultWorkspace(cams));
    OrbitPath orbit;
    orbit.centre = in.centre;
    const NovelView view = NovelView::FromFov(640, 480, 50 * M_PI / 180, orbit.WorldFromEye(1.0));
    PlaneSweepOptions o;
    o.num_planes = 100;
    const auto depths = SweepPlaneDepths(q, view, o);
    PlaneSweepOptions vo;
    vo.num_planes = 48;
    for (const bool warm : {false, true}) {
      BackendOptions bo;
      bo.name = "gl";
      bo.refine = 6;
      bo.gl_device = gl_device;
      bo.warm_up = warm;
      const double c0 = MonotonicSeconds();
      auto b = gl::MakeSweepBackend(bo);
      const double c1 = MonotonicSeconds();
      double ms[2];
      for (double& m : ms) {
        const double t0 = MonotonicSeconds();
        b->BeginFrameset(q, in.images);
        b->ComputeVisibility(q, cams, 80, vo);
        (void)b->SweepTextured(q, view, depths, cv::Rect(0, 0, view.width, view.height), in.images, true);
        m = (MonotonicSeconds() - t0) * 1e3;
      }
      std::printf("| %s | %.1f | %.2f | %.2f |\n", warm ? "yes" : "no", (c1 - c0) * 1e3, ms[0], ms[1]);
    }
  }
  if (!stage_rows.empty()) {
    std::printf(
        "\nGL frame stage by stage, each waited for (median ms):\n\n"
        "| view | cams | planes | image kB up / whole | map kB up (bits) / as bytes | upload | visibility maps | "
        "sweep (read back) | texture (read back) | GPU timeline, not waited: upload / visibility / sweep + "
        "texture | GPU span | frame wall |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const auto& r : stage_rows) std::printf("%s\n", r.c_str());
    std::printf("\nThe GL march with and without narrowing to the maps' object rectangles (refine 6, read back; "
                "median ms):\n\n"
                "| view | cams | planes | plane points asked: whole / narrowed | sweep ms: whole / narrowed | "
                "whole / narrowed | same depths |\n|---|---|---|---|---|---|---|\n");
    for (const auto& r : narrow_rows) std::printf("%s\n", r.c_str());
  }
  if (rows.triangles.empty()) return 0;
  // Triangle query: triangles of ~8 mm across the figure's torso plane, some
  // inside the hull and some out, each in a 10x10 viewport (the paper's setting).
  {
    const BackendInput in = MakeBackendInput(4);
    const std::vector<Camera>& cams = in.cameras;
    const VolumeQuery q(in.views, DefaultWorkspace(cams));
    const TriangleQueryOptions o{0.002, 10, 64};
    std::unique_ptr<gl::GlTriangleQuery> gl_tri;
    if (gpu) {
      tri_ctx = gl::EglContext::TryCreate(gl::EglOptions{gl_device});
      if (tri_ctx) gl_tri = std::make_unique<gl::GlTriangleQuery>();
    }
    // GL batch: the query's one pass with its counts and inside-pixel masks
    // read back (TriangleBatchResult); GL + points: every collision point made
    // on the CPU as well (the QueryTrianglesCpu contract sim_node takes).
    std::vector<std::string> part_rows;
    std::printf("\n| triangles (10x10 viewports) | colliding | CPU ms | CPU tris/s | GL batch ms | GL batch tris/s | "
                "GL + points ms | GL + points tris/s | CPU/GL batch |\n");
    std::printf("|---|---|---|---|---|---|---|---|---|\n");
    for (const int count : rows.triangles) {
      std::vector<Triangle> tris;
      const int side = int(std::ceil(std::sqrt(count)));
      const double s = 0.9 / side;
      for (int i = 0; int(tris.size()) < count; ++i) {
        const Eigen::Vector3d p = in.centre + Eigen::Vector3d((i % side) * s - 0.45, 0.0, (i / side) * s - 0.6);
        tris.push_back({p, p + Eigen::Vector3d(s, 0, 0), p + Eigen::Vector3d(0, 0.002, s)});
      }
      const int reps = count >= 100000 ? std::max(1, repeats / 3) : repeats;
      size_t colliding = 0;
      const double cms = cpu ? MedianMs(reps, [&] {
        colliding = 0;
        for (const auto& r : QueryTrianglesCpu(q, tris, o, 1)) colliding += !r.collision_points.empty();
      }) : 0;
      gl::TriangleBatchResult::Timing parts;
      const double gms = gl_tri ? MedianMs(reps, [&] {
        const gl::TriangleBatchResult b = gl_tri->QueryBatch(q, tris, o);
        parts = b.timing();
        if (!cpu) {
          colliding = 0;
          for (size_t i = 0; i < b.size(); ++i) colliding += b.inside(i) > 0;
        }
      }) : 0;
      const double pms = gl_tri ? MedianMs(reps, [&] { (void)gl_tri->Query(q, tris, o); }) : 0;
      auto rate = [&](double ms) { return ms > 0 ? count / ms * 1e3 : 0.0; };
      std::printf("| %d | %zu | %.1f | %.0f | %.2f | %.0f | %.2f | %.0f | %s |\n", count, colliding, cms, rate(cms),
                  gms, rate(gms), pms, rate(pms),
                  cms > 0 && gms > 0 ? std::to_string(cms / gms).substr(0, 6).c_str() : "-");
      if (gl_tri)
        part_rows.push_back("| " + std::to_string(count) + " | " + Ms2(parts.prepare_ms) + " | " + Ms2(parts.pass_ms) +
                            " | " + Ms2(parts.read_ms) + " | " + Ms2(parts.cpu_ms) + " |");
      std::fflush(stdout);
    }
    if (!part_rows.empty()) {
      std::printf("\nGL batch, one run's parts (ms):\n\n| triangles | pack + upload | pass | read back | CPU |\n"
                  "|---|---|---|---|---|\n");
      for (const auto& r : part_rows) std::printf("%s\n", r.c_str());
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("hullpipe_bench");  // stdout carries only what a user asked for
  hullpipe::KeepFreedMemory();  // as the nodes do (util/memory.h): no page faults per frameset
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe_bench: per-frame algorithm timings"};
  std::string rig = HULLPIPE_RIG_DIR;
  bool synthetic = false, no_gl = false;
  int repeats = 7, frame = 200;
  app.add_option("--rig", rig, "Rig directory")->capture_default_str();
  app.add_flag("--synthetic", synthetic, "Use the synthetic scene instead of the rig");
  app.add_flag("--no-gl", no_gl, "Skip the GL rows");
  app.add_option("--repeats", repeats, "Runs per row (median)")->capture_default_str();
  app.add_option("--frame", frame, "Rig frame")->capture_default_str();
  std::string backend;
  int gl_device = -1;
  app.add_option("--backend", backend,
                 "Print the backend table instead (synthetic input): cpu, gl or both (ratios)")
      ->check(CLI::IsMember({"cpu", "gl", "both"}));
  app.add_option("--gl-device", gl_device, "EGL device for GL (-1: the first hardware device)")
      ->check(CLI::Range(-1, 64))->capture_default_str();
  TableRows rows;
  app.add_option("--cameras", rows.cameras, "Backend table: camera counts")
      ->delimiter(',')->check(CLI::Range(2, 64))->capture_default_str();
  app.add_option("--sizes", rows.sizes, "Backend table: view sizes WxH")->delimiter(',')->capture_default_str();
  app.add_option("--planes", rows.planes, "Backend table: plane counts")
      ->delimiter(',')->check(CLI::Range(2, PlaneSweepOptions::kMaxPlanes))->capture_default_str();
  app.add_option("--triangles", rows.triangles, "Backend table: triangle counts (0 alone: none)")
      ->delimiter(',')->check(CLI::Range(0, 10000000))->capture_default_str();
  app.add_option("--cpu-threads", rows.cpu_threads,
                 "Backend table: the CPU backend's threads (recon_node --threads; the sweep tables' own stay at 1)")
      ->check(CLI::Range(1, 256))->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);
  if (!(repeats >= 1 && repeats <= 1000)) {
    std::fprintf(stderr, "--repeats must be in [1, 1000]\n");
    return 2;
  }
  std::erase(rows.triangles, 0);
  if (!backend.empty()) return BackendTable(backend, repeats, gl_device, rows);

  std::unique_ptr<RigSource> src;
  if (synthetic) {
    src = OpenSyntheticRig({});
    frame = 10;
  } else {
    src = OpenVideoRig(rig, {});
  }
  RigFrame f;
  for (int k = 0; k <= frame; ++k)
    if (!src->Next(&f)) {
      std::fprintf(stderr, "input too short\n");
      return 1;
    }
  std::vector<CameraMap> views;
  std::vector<CameraImage> images;
  for (size_t i = 0; i < src->cameras().size(); ++i) {
    views.push_back({src->cameras()[i], f.maps[i]});
    cv::Mat small;
    cv::resize(f.images[i], small, {}, 0.5, 0.5, cv::INTER_AREA);
    images.push_back({src->cameras()[i], small});
  }
  const VolumeQuery q(views, src->workspace());
  const Eigen::Vector3d centre = q.hull_box().Center();
  OrbitPath orbit;
  orbit.centre = centre;

  std::printf("| %-28s | %-34s | %9s | %-28s |\n", "stage", "configuration", "ms/frame", "notes");
  std::printf("|%s|%s|%s|%s|\n", std::string(30, '-').c_str(), std::string(36, '-').c_str(),
              std::string(11, '-').c_str(), std::string(30, '-').c_str());

  {
    // The volume query's set-up, which finds the hull's box (the pyramids'
    // box, then tightened by the octree search), against the pyramids alone.
    std::vector<Camera> cams;
    std::vector<cv::Mat> maps;
    for (const auto& v : views) cams.push_back(v.camera), maps.push_back(v.map);
    const Aabb pyramids = HullBoundingBox(cams, maps, src->workspace());
    auto size_note = [](const Aabb& b) {
      char note[64];
      const Eigen::Vector3d s = b.max - b.min;
      std::snprintf(note, sizeof note, "box %.2f x %.2f x %.2f m", s.x(), s.y(), s.z());
      return std::string(note);
    };
    const std::string cfg = std::to_string(cams.size()) + " cameras";
    Row("hull box: pyramids only", cfg,
        MedianMs(repeats * 3, [&] { (void)HullBoundingBox(cams, maps, src->workspace()); }), size_note(pyramids));
    Row("volume query set-up + box", cfg, MedianMs(repeats * 3, [&] { (void)VolumeQuery(views, src->workspace()); }),
        size_note(q.hull_box()));
    // On the threads recon_node gives it (--threads 0: the host's cores shared
    // by the recon nodes on it; 8 each on a 16-core machine with two).
    for (const int threads : {2, 6, 8}) {
      VolumeQueryOptions qo;
      qo.threads = threads;
      Row("volume query set-up + box", cfg + ", " + std::to_string(threads) + " threads",
          MedianMs(repeats * 3, [&] { (void)VolumeQuery(views, src->workspace(), qo); }), size_note(q.hull_box()));
    }
    // The frameset's empty-space grid (EmptySpace), made by the first CPU
    // sweep of a frameset (recon: the visibility maps), one thread.
    {
      std::vector<double> ms;
      int64_t twice = 0, cubes = 0, tests = 0;
      for (int r = 0; r < repeats * 3; ++r) {
        const VolumeQuery fresh(views, src->workspace());
        const EmptySpace& g = fresh.empty_space(1);
        ms.push_back(g.build_ms());
        twice = g.vetoed_twice(), cubes = g.dims().prod(), tests = g.tests();
      }
      char note[96];
      std::snprintf(note, sizeof note, "%lld of %lld cubes vetoed twice, %lld blocks tested", (long long)twice,
                    (long long)cubes, (long long)tests);
      Row("empty-space grid", cfg, Median(ms), note);
    }
  }

  if (!synthetic) {
    // Segmentation of one camera frame (the capture node does one per camera
    // per frame), where the rig gives a background to learn; a rig of
    // ready-made maps (masks) has none, and its maps are not segmented.
    const Rig r = LoadRig(rig);
    std::vector<cv::Mat> bg;
    if (!r.cameras[0].background.empty()) {
      cv::VideoCapture bgcap(r.cameras[0].background);
      cv::Mat img;
      while (bg.size() < 60 && bgcap.read(img)) bg.push_back(img.clone());
    }
    if (bg.empty()) {
      std::fprintf(stderr, "no segmentation rows: %s: camera %d has no background %s\n", rig.c_str(),
                   r.cameras[0].camera.id,
                   r.cameras[0].background.empty() ? "(its maps are given)"
                                                   : ("frames in " + r.cameras[0].background).c_str());
    } else {
      const BackgroundModel model(bg);
      const std::string size = std::to_string(f.images[0].cols) + "x" + std::to_string(f.images[0].rows);
      // Learning it: capture_node's start-up, once per camera (a 20-camera rig's
      // cameras on its cores).
      Row("background learnt (1 camera)", size + ", " + std::to_string(bg.size()) + " frames",
          MedianMs(repeats, [&] { (void)BackgroundModel(bg); }));
      Row("segmentation (1 camera)", size, MedianMs(repeats * 3, [&] { (void)model.Segment(f.images[0]); }));
      // Its parts: the per-pixel test (HSV conversion included) and the cleaning.
      Row("  object-pixel test", size + ", before cleaning",
          MedianMs(repeats * 3, [&] { (void)model.ObjectPixels(f.images[0]); }));
      const cv::Mat raw = model.ObjectPixels(f.images[0]);
      Row("  cleaning", size, MedianMs(repeats * 3, [&] {
            cv::Mat m = raw.clone();
            CleanObjectPixelMap(m, SegmentationOptions{});
          }));
    }
  }

  std::optional<gl::EglContext> ctx;
  std::unique_ptr<gl::GlPlaneSweep> gl_sweep;
  std::unique_ptr<gl::GlTriangleQuery> gl_tri;
  if (!no_gl) {
    std::string why;
    ctx = gl::EglContext::TryCreate(&why);
    if (ctx) {
      // The paper's GL plane sweep binds one texture unit a map (at most
      // kMaxGlCameras); recon's GL backend marches more (--backend gl's table).
      if (views.size() <= size_t(gl::kMaxGlCameras))
        gl_sweep = std::make_unique<gl::GlPlaneSweep>();
      else
        std::fprintf(stderr, "no GL plane sweep rows: the rig has %zu cameras, GlPlaneSweep takes at most %d\n",
                     views.size(), gl::kMaxGlCameras);
      gl_tri = std::make_unique<gl::GlTriangleQuery>();
    } else {
      std::fprintf(stderr, "no GL rows: %s\n", why.c_str());
    }
  }
  const std::string gl_name = ctx ? "GL (" + ctx->renderer().substr(0, ctx->renderer().find(' ')) + ")" : "";
  if (ctx) std::fprintf(stderr, "GL: %s\n", ctx->info().Summary().c_str());

  for (const auto& [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
    const NovelView view = NovelView::FromFov(w, h, 50 * M_PI / 180, orbit.WorldFromEye(1.0));
    const cv::Rect full(0, 0, w, h);
    for (int planes : {50, 100, 200}) {
      PlaneSweepOptions o;
      o.num_planes = planes;
      const auto depths = SweepPlaneDepths(q, view, o);
      const std::string cfg = std::to_string(w) + "x" + std::to_string(h) + ", " + std::to_string(planes) + " planes";
      SweepStats st;
      PlaneSweepCpu(q, view, depths, full, &st);
      char note[64];
      std::snprintf(note, sizeof note, "%.1fk rays, %.0f planes/ray", st.rays / 1e3,
                    double(st.plane_points) / double(std::max<int64_t>(1, st.rays)));
      Row("plane sweep CPU, 1 thread", cfg, MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, full); }),
          note);
      Row("plane sweep CPU, half view", cfg + " (one recon tile)",
          MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, TileRect(0, 2, w, h)); }));
      Row("plane sweep CPU + refine 6", cfg + " (one recon tile)",
          MedianMs(repeats, [&] { (void)PlaneSweepCpu(q, view, depths, TileRect(0, 2, w, h), nullptr, 1, 6); }));
      if (gl_sweep)
        Row("plane sweep " + gl_name, cfg,
            MedianMs(std::max(3, repeats / 2), [&] { (void)gl_sweep->Sweep(q, view, depths, full); }));
    }
    const auto depths = SweepPlaneDepths(q, view, {});
    const cv::Mat d = PlaneSweepCpu(q, view, depths, full);
    Row("texture (2 best cameras)", std::to_string(w) + "x" + std::to_string(h),
        MedianMs(repeats, [&] { (void)TextureHull(d, full, view, images); }));
    if (w == 320) {
      std::vector<Camera> cams;
      for (const auto& im : images) cams.push_back(im.camera);
      PlaneSweepOptions vo;
      vo.num_planes = 48;
      const std::string vis_name = "visibility maps (" + std::to_string(cams.size()) + " cameras)";
      Row(vis_name, "80 px across, 48 planes, refine 6",
          MedianMs(repeats, [&] { (void)ComputeHullVisibility(q, cams, 80, vo, 6); }));
      Row(vis_name, "80 px across, 48 planes, refine 0",
          MedianMs(repeats, [&] { (void)ComputeHullVisibility(q, cams, 80, vo, 0); }));
      // A frameset's first sweep, as recon's: the query made, then the maps
      // (which make the empty-space grid), without the grid and with it.
      VolumeQueryOptions no_grid;
      no_grid.empty_space_cells = 0;
      for (const VolumeQueryOptions& qo : {no_grid, VolumeQueryOptions{}})
        Row("query + visibility maps",
            std::string("refine 6, ") + (qo.empty_space_cells ? "with" : "without") + " the grid",
            MedianMs(repeats, [&] {
              const VolumeQuery fresh(views, src->workspace(), qo);
              (void)ComputeHullVisibility(fresh, cams, 80, vo, 6);
            }));
      const HullVisibility vis = ComputeHullVisibility(q, cams, 80, vo, 0);
      Row("texture with visibility", std::to_string(w) + "x" + std::to_string(h),
          MedianMs(repeats, [&] { (void)TextureHull(d, full, view, images, {}, &vis); }));
    }
    const cv::Mat colour(h, w, CV_8UC3, cv::Scalar(0));
    Row("composite", std::to_string(w) + "x" + std::to_string(h),
        MedianMs(repeats, [&] { (void)Composite(view, d, colour, {{centre, 0.12, false}}); }));
  }

  // Triangle query: the paper's curtain case, 720 triangles of ~2 cm at the hull,
  // each in a 10x10 viewport; and our default sizing (4 mm pixels).
  {
    std::vector<Triangle> tris;
    const double s = 0.02;
    for (int i = 0; tris.size() < 720; ++i) {
      const Eigen::Vector3d o = centre + Eigen::Vector3d((i % 24) * s - 0.24, 0.0, (i / 24) * s - 0.3);
      tris.push_back({o, o + Eigen::Vector3d(s, 0, 0), o + Eigen::Vector3d(0, 0, s)});
    }
    for (const TriangleQueryOptions& o : {TriangleQueryOptions{0.002, 10, 64}, TriangleQueryOptions{0.004, 0, 32}}) {
      const std::string cfg = o.fixed_viewport ? "720 tris, 10x10 viewports (paper)" : "720 tris, 4 mm pixels";
      size_t points = 0;
      const double ms = MedianMs(repeats, [&] {
        points = 0;
        for (const auto& t : tris) points += QueryTriangleCpu(q, t.a, t.b, t.c, o).collision_points.size();
      });
      char note[64];
      std::snprintf(note, sizeof note, "%.0f tris/s, %zu points", 720.0 / ms * 1e3, points);
      Row("triangle query CPU", cfg, ms, note);
      if (gl_tri) {
        const double gms = MedianMs(std::max(3, repeats / 2), [&] { (void)gl_tri->Query(q, tris, o); });
        std::snprintf(note, sizeof note, "%.0f tris/s", 720.0 / gms * 1e3);
        Row("triangle query " + gl_name, cfg, gms, note);
      }
    }
  }
  return 0;
}
