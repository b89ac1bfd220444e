// model_bench: collision and clearance of CAD models against real hulls
// (docs/models.md; paper §4.1 at the size of real models, §4.5 proximity).
// Frames of the rig (every --stride-th from --first) give the hulls; the
// model is the Debian engine placed as scenes/engine.yaml places it, and a
// model of about a million triangles the bench makes from it (each triangle
// cut in four, twice: 1.77 M). Prints a Markdown table: per frameset, every
// triangle queried (brute force, §4.1 as the paper did it) against the
// hierarchy (part_bvh.h), on one thread, and the clearance of every part;
// medians over the frames. "scene tris/s/core" is the model's triangles over
// the one-thread time: the rate at which a scene of that size is handled.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <limits>
#include <random>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/models/mesh_distance.h"
#include "hullpipe/models/part_bvh.h"
#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/scenes/model_scene.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/percentile.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

using namespace hullpipe;

namespace {

double Ms(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Each triangle cut into four at its edges' midpoints.
TriangleMesh Subdivide(const TriangleMesh& m) {
  TriangleMesh out;
  out.vertices = m.vertices;
  for (const auto& t : m.triangles) {
    const int a = t[0], b = t[1], c = t[2];
    const int ab = int(out.vertices.size());
    out.vertices.push_back(0.5 * (m.vertices[size_t(a)] + m.vertices[size_t(b)]));
    out.vertices.push_back(0.5 * (m.vertices[size_t(b)] + m.vertices[size_t(c)]));
    out.vertices.push_back(0.5 * (m.vertices[size_t(c)] + m.vertices[size_t(a)]));
    const int bc = ab + 1, ca = ab + 2;
    out.triangles.emplace_back(a, ab, ca);
    out.triangles.emplace_back(ab, b, bc);
    out.triangles.emplace_back(ca, bc, c);
    out.triangles.emplace_back(ab, bc, ca);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("model_bench");  // stdout carries only what a user asked for
  hullpipe::KeepFreedMemory();  // as the nodes do (util/memory.h): no page faults per frameset
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"model_bench: CAD model collision and clearance against the rig's hulls"};
  std::string rig = HULLPIPE_RIG_DIR, scene = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/engine.yaml";
  int frames = 12, first = 100, stride = 20;
  app.add_option("--rig", rig, "Rig directory")->capture_default_str();
  app.add_option("--scene", scene, "Scene file with one model")->capture_default_str();
  app.add_option("--frames", frames, "Framesets timed")->check(CLI::Range(1, 1000))->capture_default_str();
  app.add_option("--first", first, "First rig frame")->check(CLI::Range(0, 100000))->capture_default_str();
  app.add_option("--stride", stride, "Rig frames between framesets")->check(CLI::Range(1, 1000))->capture_default_str();
  int element_only = 0;
  app.add_option("--element-only", element_only,
                 "Only time the sim step, this many rounds over the framesets (profiling)")
      ->check(CLI::Range(0, 1000));
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::warn);
  try {
    const SceneConfig config = LoadSceneConfig(scene);
    const auto* models = config.Find<ModelsConfig>();
    if (!models || models->models.empty()) throw std::runtime_error(scene + ": no models");
    const ModelEntry& entry = models->models[0];
    const Eigen::Vector3d up = -config.gravity.normalized();
    // The model as one world mesh (the engine's parts together), then 16x finer.
    TriangleMesh engine;
    for (const ScenePart& p : PlaceModel(*entry.imported, entry, up)) {
      const int base = int(engine.vertices.size());
      engine.vertices.insert(engine.vertices.end(), p.mesh.vertices.begin(), p.mesh.vertices.end());
      for (const auto& t : p.mesh.triangles) engine.triangles.push_back(t + Eigen::Vector3i::Constant(base));
    }
    const TriangleMesh fine = Subdivide(Subdivide(engine));
    auto src = OpenVideoRig(rig, {});
    std::vector<VolumeQuery> hulls;
    RigFrame f;
    for (int k = 0; hulls.size() < size_t(frames); ++k) {
      if (!src->Next(&f)) break;
      if (k < first || (k - first) % stride != 0) continue;
      std::vector<CameraMap> views;
      for (size_t i = 0; i < src->cameras().size(); ++i) views.push_back({src->cameras()[i], f.maps[i]});
      hulls.emplace_back(views, src->workspace());
    }
    if (hulls.empty()) throw std::runtime_error(rig + ": no frames");
    const TriangleQueryOptions options{entry.max_pixel_size, 0, 32};
    if (element_only > 0) {
      auto element = models->Make(config);
      std::vector<double> ms;
      for (int r = 0; r < element_only; ++r)
        for (const auto& q : hulls) ms.push_back(Ms([&] { element->Step({.dt = 0.04, .hull = &q}); }));
      std::printf("sim step p50 %.2f ms over %zu steps\n", Median(ms), ms.size());
      return 0;
    }
    std::printf("model: %s, %d framesets of %s (frames %d + k * %d)\n\n", entry.file.c_str(), int(hulls.size()),
                rig.c_str(), first, stride);
    std::printf(
        "| model | triangles | method | ms/frameset p50 | scene tris/s/core | tris queried | boxes tested | colliding tris |\n");
    std::printf("|---|---:|---|---:|---:|---:|---:|---:|\n");
    for (const auto& [name, mesh] : {std::pair<std::string, const TriangleMesh*>{"engine", &engine},
                                     std::pair<std::string, const TriangleMesh*>{"engine x16", &fine}}) {
      TriangleBvh bvh;
      const double build_ms = Ms([&] { bvh = TriangleBvh(*mesh); });
      std::vector<double> brute_ms, bvh_ms, clear_ms;
      double queried_brute = 0, queried = 0, boxes = 0, colliding = 0;
      bool equal = true;
      for (const auto& q : hulls) {
        CollisionResult a, b;
        BvhQueryStats st;
        brute_ms.push_back(Ms([&] { a = DetectCollisions(q, *mesh, options); }));
        bvh_ms.push_back(Ms([&] { b = DetectCollisionsBvh(q, *mesh, bvh, Rigid3d{}, options, {}, 1, &st); }));
        equal = equal && a.triangle_ids == b.triangle_ids && a.collision_points == b.collision_points;
        queried_brute += a.triangles_queried, queried += b.triangles_queried, boxes += double(st.boxes_tested);
        colliding += double(b.triangle_ids.size());
        clear_ms.push_back(Ms([&] {
          Aabb region = mesh->Bounds();
          region.min -= Eigen::Vector3d::Constant(entry.max_clearance);
          region.max += Eigen::Vector3d::Constant(entry.max_clearance);
          const HullSamples s = SampleHull(q, region);
          (void)HullToPartClearance(q, *mesh, bvh, Rigid3d{}, entry.max_clearance, s);
        }));
      }
      const double n = double(hulls.size()), tris = double(mesh->triangles.size());
      auto row = [&](const char* method, double ms, double tq, double bx) {
        std::printf("| %s | %.0f | %s | %.2f | %.3g | %.0f | %.0f | %.0f |\n", name.c_str(), tris, method, ms,
                    tris / ms * 1e3, tq, bx, colliding / n);
      };
      row("every triangle (§4.1 as in the paper)", Median(brute_ms), queried_brute / n, 0);
      row("hierarchy", Median(bvh_ms), queried / n, boxes / n);
      std::printf("| %s | %.0f | clearance (one mesh, 2 cm grid + 6 refinements) | %.2f | | | | |\n", name.c_str(),
                  tris, Median(clear_ms));
      std::printf("| %s | %.0f | hierarchy build (once, at load) | %.1f | | | | |\n", name.c_str(), tris, build_ms);
      if (!equal) std::printf("\nMISMATCH: the hierarchy's result differs from brute force on %s\n", name.c_str());
    }
    // The scene element as sim_node runs it: per part, threads across parts.
    std::vector<double> step_ms;
    auto element = models->Make(config);
    for (const auto& q : hulls) step_ms.push_back(Ms([&] { element->Step({.dt = 0.04, .hull = &q}); }));
    std::printf("\nsim step of the engine scene (%d parts, collision + clearance, %d thread(s), as sim_node's "
                "--model-threads): p50 %.2f ms, max %.2f ms\n",
                int(entry.imported->parts.size()), models->threads, Median(step_ms),
                *std::max_element(step_ms.begin(), step_ms.end()));
    // render_node's CPU compositing of the model (no hull in the view), at the
    // demo's 320x240 from 3 m, as the orbit sees it.
    {
      std::vector<VirtualMeshDraw> draws;
      for (const ScenePart& p : PlaceModel(*entry.imported, entry, up)) {
        VirtualMeshDraw d;
        d.vertices = p.mesh.vertices;
        d.triangles = p.mesh.triangles;
        d.colour = p.colour;
        draws.push_back(std::move(d));
      }
      MeshDraws draw_ptrs;
      for (const auto& d : draws) draw_ptrs.push_back(&d);
      const Eigen::Vector3d centre(0.32, 0.02, -0.88);
      const NovelView view =
          NovelView::FromFov(320, 240, 50 * M_PI / 180, LookAt(centre + Eigen::Vector3d(0, 3, -0.5), centre, up));
      const cv::Mat depth(240, 320, CV_32FC1, cv::Scalar(kNoDepth)), colour(240, 320, CV_8UC3, cv::Scalar(0, 0, 0));
      std::vector<double> ms;
      for (int r = 0; r < 9; ++r)
        ms.push_back(Ms([&] { (void)Composite(view, depth, colour, {}, {}, nullptr, draw_ptrs); }));
      std::vector<double> empty_ms;
      for (int r = 0; r < 9; ++r) empty_ms.push_back(Ms([&] { (void)Composite(view, depth, colour, {}); }));
      std::printf("render composite at 320x240 (CPU): with the model %.2f ms p50, without %.2f ms\n", Median(ms),
                  Median(empty_ms));
    }
    // The exact signed distance (models/mesh_distance.h) on each closed part
    // of the engine, against its reference (every triangle for the distance,
    // the winding number for the sign), at points spread over the part's box
    // grown by 5 cm; then the payload task's sim step with the engine's block
    // as the PMT (scenes/payload_engine.yaml) against the boxes
    // (scenes/payload.yaml), on the same hulls.
    {
      std::mt19937 rng(11);
      std::uniform_real_distribution<double> u(0, 1);
      double hierarchy_ns = 0, brute_ns = 0, max_error = 0;
      int64_t queries = 0, sign_errors = 0, closed = 0, parts = 0, tris = 0;
      for (const ScenePart& p : PlaceModel(*entry.imported, entry, up)) {
        ++parts;
        const MeshSignedDistance sdf(p.mesh);
        if (!sdf.closed() || p.mesh.triangles.size() < 100) continue;
        ++closed;
        tris += int64_t(p.mesh.triangles.size());
        Aabb box = sdf.bounds();
        box.min -= Eigen::Vector3d::Constant(0.05);
        box.max += Eigen::Vector3d::Constant(0.05);
        std::vector<Eigen::Vector3d> points(200);
        for (auto& q : points)
          q = box.min + (box.max - box.min).cwiseProduct(Eigen::Vector3d(u(rng), u(rng), u(rng)));
        std::vector<double> fast(points.size()), slow(points.size());
        hierarchy_ns += 1e6 * Ms([&] {
          for (size_t i = 0; i < points.size(); ++i) fast[i] = sdf.Signed(points[i]);
        });
        brute_ns += 1e6 * Ms([&] {
          for (size_t i = 0; i < points.size(); ++i) {
            double d = std::numeric_limits<double>::infinity();
            for (const auto& t : p.mesh.triangles)
              d = std::min(d, (ClosestPointOnTriangle(points[i], p.mesh.vertices[size_t(t[0])],
                                                      p.mesh.vertices[size_t(t[1])], p.mesh.vertices[size_t(t[2])]) -
                               points[i])
                                  .norm());
            slow[i] = WindingNumber(p.mesh, points[i]) > 0.5 ? -d : d;
          }
        });
        for (size_t i = 0; i < points.size(); ++i) {
          max_error = std::max(max_error, std::abs(std::abs(fast[i]) - std::abs(slow[i])));
          sign_errors += (fast[i] < 0) != (slow[i] < 0);
        }
        queries += int64_t(points.size());
      }
      std::printf(
          "\nsigned distance (mesh_distance.h) on the engine's %lld closed parts of %lld (100+ triangles, "
          "%lld triangles): %.1f us/query through the hierarchy, %.1f us by every triangle + winding "
          "number; %lld queries, largest distance difference %.3g m, %lld sign disagreements\n",
          (long long)closed, (long long)parts, (long long)tris,
          hierarchy_ns / 1e3 / double(std::max<int64_t>(queries, 1)),
          brute_ns / 1e3 / double(std::max<int64_t>(queries, 1)), (long long)queries, max_error,
          (long long)sign_errors);
      for (const char* name : {"payload", "payload_engine"}) {
        const SceneConfig pc = LoadSceneConfig(std::string(HULLPIPE_SOURCE_DIR) + "/scenes/" + name + ".yaml");
        const PayloadConfig& payload = *pc.Find<PayloadConfig>();
        std::vector<double> ms;
        for (const auto& q : hulls) ms.push_back(Ms([&] { (void)EvaluatePayload(payload, &q); }));
        std::printf("payload task step (%s.yaml: %s): p50 %.2f ms, max %.2f ms\n", name,
                    payload.pmt_model ? "the engine's block as the PMT" : "boxes and a cylinder", Median(ms),
                    *std::max_element(ms.begin(), ms.end()));
      }
    }
    std::printf("GL triangle query: not measured (no GPU machine in this run)\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "model_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
