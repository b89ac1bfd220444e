// vh_eval collision: collision detection and the §4.2 response against exact
// ground truth (paper §4; docs/benchmarks.md). Real objects: synthetic shapes seen by exact maps.
// Virtual objects: boxes tessellated into ~2 cm triangles (the paper's size),
// randomly turned, pushed 0.5-3 cm into the hull at random places.
//
// Ground truth per case, from the maps (the hull as the cameras define it):
//  - the exact contact region of every triangle (ExactContactSegments, lines
//    `reference_spacing` apart, exact along each line);
//  - the exact CP_obj (the region's point farthest from RP_obj, the box centre),
//    V_rec, CP_hull (exact ray–hull intervals) and D_rec;
//  - N_hull: the smooth visual hull's normal at the exact CP_hull
//    (SmoothHullNormal), the surface the maps sample.
// A case whose CP_obj is ill-conditioned (another exact point 5 mm away is
// within 0.2 mm as far from RP_obj) has no single right answer: it counts as
// "ambiguous" and is left out of the response errors.
//
// The hull surface's velocity at contacts (hull_motion.h): each scene
// translating at a known speed along a random direction, filmed by the same
// cameras with per-camera capture offsets and jitter (so they do not shoot
// together), two consecutive framesets; at random surface points of the
// current hull the estimated normal speed against the exact one, v . N with N
// the smooth hull's normal there (for a translating body the cone surface
// through a point moves along its normal by the body's displacement along it).
#include "vh_eval_collision.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "hullpipe/util/percentile.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/collision_response.h"
#include "hullpipe/collision/contact_region.h"
#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/gl/egl_context.h"
#include "hullpipe/gl/gl_plane_sweep.h"
#include "hullpipe/gl/gl_triangle_query.h"
#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/util/logging.h"

namespace hullpipe {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
}

// Nearest-rank percentile; null when empty.
nlohmann::json Pct(std::vector<double> v, double p, double scale = 1.0) {
  if (v.empty()) return nullptr;
  const double x = Percentile(std::move(v), p) * scale;
  if (!std::isfinite(x)) return "inf";
  return std::round(x * 1e4) / 1e4;
}

struct Scene {
  std::string name;
  SyntheticScene shapes;
  std::vector<Eigen::Vector3d> centres;
  std::optional<VolumeQuery> query;
};

// The collision-point error (a Hausdorff distance) is measured on the contact
// region cut by lines this far apart and sampled this finely along them, so it is
// low by at most half a diagonal of that spacing (0.14 mm).
constexpr double kCoverSpacing = 2e-4;

struct Case {
  TriangleMesh mesh;
  Eigen::Vector3d rp;
  std::vector<int> tri_ids;                          // triangles whose box meets the hull box
  std::vector<std::vector<ContactSegment>> region;   // exact contact region of each
  std::vector<std::vector<ContactSegment>> coarse;   // the same on lines kCoverSpacing apart
  bool contact = false;
  bool ambiguous = false;
  bool has_truth = false;
  Eigen::Vector3d cp_obj, v_rec, cp_hull, n_hull;
  double d_rec = 0;
  bool edge = false;
  size_t scene = 0;
};

struct EvalConfig {
  std::string backend;  // cpu | gl
  std::string viewport; // 10x10 | 4mm | ...
  TriangleQueryOptions options;
  int threads = 1;
};

Scene MakeScene(const std::string& name, const CollisionEvalOptions& o) {
  Scene s;
  s.name = name;
  s.shapes = NamedScene(name, 0.5);
  const Eigen::Vector3d target(0, 0, -1.0);
  const auto cams = DomeCameras(o.cameras, 3.0, target, o.camera_width, o.camera_height, 0.9);
  std::vector<CameraMap> views;
  for (const auto& c : cams) {
    views.push_back({c, RenderExactMap(c, s.shapes)});
    s.centres.push_back(c.Center());
  }
  Aabb ws;
  ws.min = target - Eigen::Vector3d::Constant(1.2);
  ws.max = target + Eigen::Vector3d::Constant(1.2);
  s.query.emplace(views, ws);
  return s;
}

// A box pushed into the hull near where a random ray from outside meets it.
std::optional<Case> MakeCase(const Scene& s, std::mt19937& rng, double spacing) {
  const VolumeQuery& q = *s.query;
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> uni(0, 1);
  const Eigen::Vector3d target(0, 0, -1.0);
  Eigen::Vector3d dir(gauss(rng), gauss(rng), gauss(rng));
  dir.normalize();
  if (dir.z() > 0.6) dir.z() = -dir.z();  // not from under the floor
  const Eigen::Vector3d from = target + 1.0 * dir;
  const auto surface = FirstHullPointAlong(q, from, -dir, 1.0);
  if (!surface) return std::nullopt;
  Case c;
  const Eigen::Vector3d half(0.06, 0.04, 0.03);
  Eigen::Quaterniond rot(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
  rot.normalize();
  Rigid3d pose;
  pose.rotation = rot.toRotationMatrix();
  const Eigen::Vector3d local = pose.rotation.transpose() * dir;
  const double support = half.dot(local.cwiseAbs());  // box extent along dir from its centre
  const double depth = 0.005 + 0.025 * uni(rng);
  pose.translation = *surface + dir * (support - depth);
  c.mesh = TriangleMesh::Box(half, 0.02).Transformed(pose);
  c.rp = pose.translation;
  // Ground truth: the exact contact region of every triangle the box test keeps.
  const TriangleQueryOptions frame_only;
  double far = -1;
  std::vector<Eigen::Vector3d> ends;
  for (size_t t = 0; t < c.mesh.triangles.size(); ++t) {
    const auto& ti = c.mesh.triangles[t];
    const Triangle tri{c.mesh.vertices[size_t(ti[0])], c.mesh.vertices[size_t(ti[1])], c.mesh.vertices[size_t(ti[2])]};
    Aabb tb;
    tb.Extend(tri.a), tb.Extend(tri.b), tb.Extend(tri.c);
    if (!tb.Intersects(q.hull_box())) continue;
    c.tri_ids.push_back(int(t));
    const TriangleViewport vp = MakeTriangleViewport(tri.a, tri.b, tri.c, frame_only);
    c.region.push_back(ExactContactSegments(q, vp, spacing));
    c.coarse.push_back(ExactContactSegments(q, vp, std::max(spacing, kCoverSpacing)));
    // A contact thinner than the coverage lines: measure it on the fine ones.
    if (c.coarse.back().empty()) c.coarse.back() = c.region.back();
    for (const auto& seg : c.region.back()) {
      for (const auto* e : {&seg.p, &seg.q}) {
        ends.push_back(*e);
        const double d = (*e - c.rp).norm();
        if (d > far) far = d, c.cp_obj = *e;
      }
    }
  }
  c.contact = far >= 0;
  if (!c.contact) return c;
  for (const auto& e : ends)
    if ((e - c.rp).norm() >= far - 2e-4 && (e - c.cp_obj).norm() > 5e-3) c.ambiguous = true;
  const auto exact = ComputeResponse(q, {c.cp_obj}, c.rp);
  if (!exact) return c;
  c.has_truth = true;
  c.v_rec = exact->v_rec;
  c.cp_hull = exact->cp_hull;
  c.d_rec = exact->d_rec;
  c.n_hull = SmoothHullNormal(s.shapes, s.centres, c.cp_hull, 5e-4, &c.edge);
  return c;
}

// A copy of `scene` translated by t (metres).
SyntheticScene Translated(SyntheticScene scene, const Eigen::Vector3d& t) {
  for (Shape& sh : scene.shapes) sh.a += t, sh.b += t;
  return scene;
}

// Per-camera capture offsets and a jitter alternating sign frame to frame
// (seconds): cameras that do not shoot together.
constexpr double kViewOffsetS[4] = {0.0, 0.003, -0.004, 0.005}, kViewJitterS[4] = {0.002, -0.002, 0.0015, -0.0015};

// One velocity row: a scene moving at `speed` m/s, framesets at `fps`.
nlohmann::json VelocityRow(const std::string& name, double speed, double fps, const CollisionEvalOptions& o,
                           std::mt19937& rng) {
  const Eigen::Vector3d target(0, 0, -1.0);
  const auto cams = DomeCameras(o.cameras, 3.0, target, o.camera_width, o.camera_height, 0.9);
  std::vector<Eigen::Vector3d> centres;
  for (const auto& c : cams) centres.push_back(c.Center());
  std::normal_distribution<double> gauss;
  Eigen::Vector3d dir(gauss(rng), gauss(rng), gauss(rng));
  dir.normalize();
  const Eigen::Vector3d v = speed * dir;
  const SyntheticScene base = NamedScene(name, 0.5);
  Aabb ws;
  ws.min = target - Eigen::Vector3d::Constant(1.2);
  ws.max = target + Eigen::Vector3d::Constant(1.2);
  struct Shot {
    std::unique_ptr<VolumeQuery> query;
    TimedHull timed;
  };
  auto shoot = [&](int k) {
    std::vector<CameraMap> views;
    std::vector<int64_t> skew_ns;
    for (size_t i = 0; i < cams.size(); ++i) {
      const double skew = kViewOffsetS[i % 4] + (k % 2 ? 1 : -1) * kViewJitterS[i % 4];
      views.push_back({cams[i], RenderExactMap(cams[i], Translated(base, (k / fps + skew) * v))});
      skew_ns.push_back(int64_t(std::llround(skew * 1e9)));
    }
    Shot s;
    s.query = std::make_unique<VolumeQuery>(views, ws);
    s.timed = TimedHull::Of(*s.query, 1'000'000'000 + int64_t(std::llround(k / fps * 1e9)), skew_ns);
    return s;
  };
  const Shot prev = shoot(1), cur = shoot(2);
  const HullMotion motion(cur.timed, prev.timed);
  const SyntheticScene now = Translated(base, (2 / fps) * v);
  std::vector<double> err, rel_bound, us;
  std::map<std::string, int> status;
  int edges = 0;
  const int points = o.smoke ? 6 : 24;
  for (int attempt = 0, made = 0; made < points && attempt < 20 * points; ++attempt) {
    Eigen::Vector3d d(gauss(rng), gauss(rng), gauss(rng));
    d.normalize();
    const auto cp = FirstHullPointAlong(*cur.query, target + 1.0 * d, -d, 1.0);
    if (!cp) continue;
    const auto n = HullSurfaceNormal(*cur.query, *cp);
    if (!n) continue;
    ++made;
    const auto t0 = Clock::now();
    const HullVelocity est = motion.At(*cp, n->normal);
    us.push_back(Seconds(t0) * 1e6);
    ++status[ToString(est.status)];
    if (!est.valid()) continue;
    bool on_edge = false;
    const Eigen::Vector3d n_true = SmoothHullNormal(now, centres, *cp, 5e-4, &on_edge);
    if (on_edge) {
      ++edges;  // the normal, and so the normal speed, is undefined there
      continue;
    }
    err.push_back(std::abs(est.normal_speed - v.dot(n_true)));
    // What the quantization allows (hull_motion_test.cc): 1.42 px at the
    // point's depth over the interval, plus 5% of |v|.
    double footprint = 0;
    for (const auto& c : cams) footprint = std::max(footprint, (*cp - c.Center()).norm() / c.fx);
    rel_bound.push_back(err.back() / (1.42 * footprint / est.interval_s + 0.05 * speed));
  }
  return {{"scene", name},         {"speed_mps", speed},
          {"fps", fps},            {"points", us.size()},
          {"statuses", status},    {"on_hull_edge", edges},
          {"err_mps_median", Pct(err, 50)},
          {"err_mps_p95", Pct(err, 95)},
          {"err_over_bound_max", Pct(rel_bound, 100)},
          {"us_median", Pct(us, 50)}};
}

struct MethodStats {
  std::vector<double> cp_obj, cp_hull, cp_hull_search, d_rec, n_hull, n_hull_faces, response, response_us;
  int responses = 0, no_response = 0, n_fallback = 0, edges = 0;
};

}  // namespace

int RunCollisionEval(const CollisionEvalOptions& o_in) {
  CollisionEvalOptions o = o_in;
  if (o.smoke) {
    o.scenes = {"sphere"};
    o.cases_per_scene = 3;
    o.camera_width = 320, o.camera_height = 240;
    o.repeats = 1;
    o.gl = false;
    o.reference_spacing = std::max(o.reference_spacing, 2e-4);
  }
  // Scenes and cases (ground truth).
  const auto t_ref = Clock::now();
  std::vector<Scene> scenes;
  std::vector<Case> cases;
  int skipped = 0;
  std::mt19937 rng(o.seed);
  for (const auto& name : o.scenes) {
    scenes.push_back(MakeScene(name, o));
    int made = 0;
    for (int attempt = 0; made < o.cases_per_scene && attempt < 20 * o.cases_per_scene; ++attempt) {
      auto c = MakeCase(scenes.back(), rng, o.reference_spacing);
      if (!c || !c->contact) {
        ++skipped;
        continue;
      }
      c->scene = scenes.size() - 1;
      cases.push_back(std::move(*c));
      ++made;
    }
  }
  const double ref_seconds = Seconds(t_ref);

  // Detection configurations.
  auto px = [](double m) { return TriangleQueryOptions{m, 0, 64}; };
  std::vector<EvalConfig> configs = {{"cpu", "10x10", {0.002, 10, 64}, 1}, {"cpu", "4mm", px(0.004), 1},
                                 {"cpu", "2mm", px(0.002), 1},       {"cpu", "1mm", px(0.001), 1},
                                 {"cpu", "0.5mm", px(0.0005), 1},    {"cpu", "0.25mm", {0.00025, 0, 128}, 1},
                                 {"cpu", "10x10", {0.002, 10, 64}, 2}, {"cpu", "2mm", px(0.002), 2},
                                 {"cpu", "0.25mm", {0.00025, 0, 128}, 2}};
  if (o.smoke) configs = {configs[0], configs[2]};
  std::optional<gl::EglContext> ctx;
  std::unique_ptr<gl::GlTriangleQuery> gl_tri;
  std::string gl_note;
  if (o.gl) {
    ctx = gl::EglContext::TryCreate(&gl_note);
    if (ctx) {
      gl_tri = std::make_unique<gl::GlTriangleQuery>();
      configs.push_back({"gl", "10x10", {0.002, 10, 64}, 1});
      configs.push_back({"gl", "2mm", px(0.002), 1});
      gl_note = ctx->renderer();
    }
  }

  ResponseOptions response_options;
  if (o.normal_fit_radius_px > 0) response_options.normal.fit_radius_px = o.normal_fit_radius_px;
  nlohmann::json rows = nlohmann::json::array();
  for (const EvalConfig& cfg : configs) {
    double detect_s = 0;
    long tris = 0;
    std::vector<double> cp_err, pixel_mm;
    int missed = 0;
    MethodStats exact, paper;
    for (const Case& c : cases) {
      const VolumeQuery& q = *scenes[c.scene].query;
      TriangleBatchQuery batch;
      if (cfg.backend == "gl") batch = [&](const std::vector<Triangle>& t) { return gl_tri->Query(q, t, cfg.options); };
      CollisionResult hit;
      std::vector<double> times;
      for (int r = 0; r < std::max(1, o.repeats); ++r) {
        const auto t0 = Clock::now();
        hit = DetectCollisions(q, c.mesh, cfg.options, batch, cfg.threads);
        times.push_back(Seconds(t0));
      }
      detect_s += Median(times);
      tris += hit.triangles_queried;
      // Collision-point error per triangle: its own points against its own exact
      // region, and its region against the object's points (a neighbour's point
      // covers contact as well as its own).
      const std::vector<double> uncovered =
          UncoveredDistances(hit.collision_points, c.coarse, std::max(o.reference_spacing, kCoverSpacing));
      for (size_t k = 0; k < c.tri_ids.size(); ++k) {
        std::vector<Eigen::Vector3d> own;
        for (size_t i = 0; i < hit.collision_points.size(); ++i)
          if (hit.point_triangles[i] == c.tri_ids[k]) own.push_back(hit.collision_points[i]);
        if (own.empty() && c.region[k].empty()) continue;
        const ContactError to_region = CollisionPointError(own, c.region[k], kCoverSpacing);
        const double e = std::max(own.empty() ? 0.0 : to_region.points_to_region, uncovered[k]);
        cp_err.push_back(e);
        if (own.empty() && !c.region[k].empty()) ++missed;
        const auto& ti = c.mesh.triangles[size_t(c.tri_ids[k])];
        const TriangleViewport vp = MakeTriangleViewport(c.mesh.vertices[size_t(ti[0])], c.mesh.vertices[size_t(ti[1])],
                                                         c.mesh.vertices[size_t(ti[2])], cfg.options);
        pixel_mm.push_back(std::max(vp.u_step.norm(), vp.v_step.norm()) * 1e3);
      }
      if (!hit.colliding() || !c.has_truth) {
        if (c.has_truth) ++exact.no_response, ++paper.no_response;
        continue;
      }
      // The two §4.2 methods on the same collision points.
      for (int m = 0; m < 2; ++m) {
        MethodStats& st = m == 0 ? exact : paper;
        const auto t0 = Clock::now();
        std::optional<CollisionResponse> r;
        if (m == 0) {
          CollisionResult refined = hit;
          RefineFarthestCollisionPoint(q, c.mesh, c.rp, cfg.options, &refined);
          r = ComputeResponse(q, refined.collision_points, c.rp, std::nullopt, response_options);
        } else {
          r = ComputeResponsePaper(q, hit.collision_points, c.rp);
        }
        st.response_us.push_back(Seconds(t0) * 1e6);
        if (!r) {
          ++st.no_response;
          continue;
        }
        ++st.responses;
        if (c.ambiguous) continue;
        st.cp_obj.push_back((r->cp_obj - c.cp_obj).norm());
        st.cp_hull.push_back((r->cp_hull - c.cp_hull).norm());
        // The search alone: the exact first hull point along the method's own line.
        const auto own_line = ComputeResponse(q, {r->cp_obj}, c.rp);
        if (own_line) st.cp_hull_search.push_back((r->cp_hull - own_line->cp_hull).norm());
        st.d_rec.push_back(std::abs(r->d_rec - c.d_rec));
        st.response.push_back((r->d_rec * r->v_rec - c.d_rec * c.v_rec).norm());
        st.n_fallback += r->n_hull_fallback;
        if (c.edge) {
          ++st.edges;
          continue;
        }
        st.n_hull.push_back(AngleDeg(r->n_hull, c.n_hull));
        // Where the method itself finds a second camera's border within a pixel it
        // returns the documented edge blend: also reported without those.
        if (!r->n_hull_edge) st.n_hull_faces.push_back(st.n_hull.back());
      }
    }
    for (int m = 0; m < 2; ++m) {
      const MethodStats& st = m == 0 ? exact : paper;
      nlohmann::json row = {
          {"method", m == 0 ? "exact" : "paper"},
          {"backend", cfg.backend},
          {"viewport", cfg.viewport},
          {"threads", cfg.threads},
          {"pixel_mm_median", Pct(pixel_mm, 50)},
          {"triangles", tris},
          {"tris_per_s", detect_s > 0 ? std::round(double(tris) / detect_s) : 0.0},
          {"cp_err_mm_median", Pct(cp_err, 50, 1e3)},
          {"cp_err_mm_p95", Pct(cp_err, 95, 1e3)},
          {"missed_triangles", missed},
          {"cp_obj_err_mm_p95", Pct(st.cp_obj, 95, 1e3)},
          {"cp_hull_err_mm_p95", Pct(st.cp_hull, 95, 1e3)},
          {"cp_hull_search_err_mm_p95", Pct(st.cp_hull_search, 95, 1e3)},
          {"d_rec_err_mm_median", Pct(st.d_rec, 50, 1e3)},
          {"d_rec_err_mm_p95", Pct(st.d_rec, 95, 1e3)},
          {"response_err_mm_p95", Pct(st.response, 95, 1e3)},
          {"n_hull_err_deg_median", Pct(st.n_hull, 50)},
          {"n_hull_err_deg_p95", Pct(st.n_hull, 95)},
          {"n_hull_err_deg_p95_off_edges", Pct(st.n_hull_faces, 95)},
          {"response_us_median", Pct(st.response_us, 50)},
          {"responses", st.responses},
          {"no_response", st.no_response},
          {"n_hull_fallbacks", st.n_fallback},
          {"n_hull_edges_excluded", st.edges}};
      rows.push_back(row);
    }
  }

  // The hull surface's velocity (hull_motion.h) against the exact one.
  nlohmann::json velocity_rows = nlohmann::json::array();
  const std::vector<double> speeds = o.smoke ? std::vector<double>{1.0} : std::vector<double>{0.2, 1.0, 3.0};
  const std::vector<double> rates = o.smoke ? std::vector<double>{25} : std::vector<double>{25, 50};
  std::mt19937 vrng(o.seed + 7);
  for (const auto& name : o.scenes)
    for (const double fps : rates)
      for (const double speed : speeds) velocity_rows.push_back(VelocityRow(name, speed, fps, o, vrng));

  int ambiguous = 0, edges = 0;
  for (const auto& c : cases) ambiguous += c.ambiguous, edges += c.edge;
  nlohmann::json out = {
      {"scenes", o.scenes},
      {"cameras", o.cameras},
      {"camera_size", {o.camera_width, o.camera_height}},
      {"virtual_object", "box 12x8x6 cm, ~2 cm triangles (216), turned at random, 0.5-3 cm into the hull"},
      {"reference",
       {{"line_spacing_mm", o.reference_spacing * 1e3},
        {"cases", cases.size()},
        {"ambiguous_cp_obj", ambiguous},
        {"on_hull_edge", edges},
        {"skipped_no_contact", skipped},
        {"seconds", std::round(ref_seconds * 100) / 100}}},
      {"paper", {{"tris_per_s", 13000}, {"cp_err_mm", 2.0}, {"cp_hull_err_mm", 0.125}, {"response_err_mm", 7.5}}},
      {"normal_fit_radius_px", response_options.normal.fit_radius_px},
      {"gl", gl_tri ? nlohmann::json(gl_note) : nlohmann::json(nullptr)},
      {"rows", rows},
      {"velocity",
       {{"what", "hull surface normal speed at random surface points, scene translating, per-camera capture "
                 "offsets 0/+3/-4/+5 ms and jitter +-2 ms (hull_motion.h)"},
        {"rows", velocity_rows}}}};
  if (!o.tsv.empty()) {
    std::ofstream f(o.tsv);
    f << "method\tbackend\tviewport\tthreads\ttris_per_s\tcp_err_mm_p95\tcp_obj_err_mm_p95\td_rec_err_mm_p95\tn_hull_err_deg_p95\n";
    for (const auto& r : rows)
      f << r["method"].get<std::string>() << '\t' << r["backend"].get<std::string>() << '\t'
        << r["viewport"].get<std::string>() << '\t' << r["threads"] << '\t' << r["tris_per_s"] << '\t'
        << r["cp_err_mm_p95"] << '\t' << r["cp_obj_err_mm_p95"] << '\t' << r["d_rec_err_mm_p95"] << '\t'
        << r["n_hull_err_deg_p95"] << '\n';
  }
  if (o.json) {
    out["command"] = CommandLine();
    std::cout << out.dump(1) << std::endl;
    return 0;
  }
  std::printf("%zu cases (%d ambiguous CP_obj, %d on hull edges), reference %.1f s\n", cases.size(), ambiguous, edges,
              ref_seconds);
  std::printf(
      "| method | backend | viewport | thr | tris/s | cp p95 mm | CP_obj p95 | CP_hull p95 | D_rec p95 | N_hull p95 deg | resp us |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : rows)
    std::printf("| %s | %s | %s | %d | %.0f | %s | %s | %s | %s | %s | %s |\n", r["method"].get<std::string>().c_str(),
                r["backend"].get<std::string>().c_str(), r["viewport"].get<std::string>().c_str(),
                r["threads"].get<int>(), r["tris_per_s"].get<double>(), r["cp_err_mm_p95"].dump().c_str(),
                r["cp_obj_err_mm_p95"].dump().c_str(), r["cp_hull_err_mm_p95"].dump().c_str(),
                r["d_rec_err_mm_p95"].dump().c_str(), r["n_hull_err_deg_p95"].dump().c_str(),
                r["response_us_median"].dump().c_str());
  std::printf("\nHull surface velocity at contacts (exact truth v . N; cameras with capture skew)\n");
  std::printf("| scene | fps | speed m/s | points | measured | err median m/s | err p95 m/s | err/bound max | us |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : velocity_rows)
    std::printf("| %s | %.0f | %.1f | %d | %d | %s | %s | %s | %s |\n", r["scene"].get<std::string>().c_str(),
                r["fps"].get<double>(), r["speed_mps"].get<double>(), r["points"].get<int>(),
                r["statuses"].value("measured", 0), r["err_mps_median"].dump().c_str(),
                r["err_mps_p95"].dump().c_str(), r["err_over_bound_max"].dump().c_str(),
                r["us_median"].dump().c_str());
  return 0;
}

}  // namespace hullpipe
