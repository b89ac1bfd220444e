#include "hullpipe/nodes/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>

#include <spdlog/spdlog.h>

#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/util/percentile.h"
#include "hullpipe/util/run_id.h"

namespace hullpipe::nodes {

bool RunReport::OnNodeStats(const NodeStatsSample& m) {
  // Per-node state is bounded: a peer flooding reports under distinct names
  // (render grew to 594 MB and wrote a 0.5-GB stats.json) is ignored past
  // kMaxNodes names, counted and said once.
  if (node_stats_.size() >= kMaxNodes && !node_stats_.count(m.name)) {
    if (node_stats_over_limit_++ == 0)
      spdlog::warn("NodeStats from more than {} node names (the latest '{}'): the rest are ignored and counted "
                   "(a peer on this domain publishes reports of nodes that are not a run's)",
                   kMaxNodes, m.name.substr(0, 64));
    return false;
  }
  node_stats_[m.name] = m;
  return true;
}

void RunReport::OnCollisionReport(bool has_points, uint8_t hull_velocity_status, double hull_normal_speed) {
  if (has_points) ++collision_reports_;
  using S = HullVelocityStatus;
  if (hull_velocity_status == uint8_t(S::kNone) || hull_velocity_status > uint8_t(S::kAppeared))
    return;  // none, or unknown
  ++hull_velocity_statuses_[hull_velocity_status];
  if ((hull_velocity_status == uint8_t(S::kMeasured) || hull_velocity_status == uint8_t(S::kClamped)) &&
      std::isfinite(hull_normal_speed)) {
    hull_speed_max_ = std::max(hull_speed_max_, std::abs(hull_normal_speed));
    hull_speed_sum_ += std::abs(hull_normal_speed);
  }
}

void RunReport::OnFrameDrawn(uint64_t spheres_colliding, uint64_t meshes, bool lit, double hull_fraction) {
  collisions_drawn_ += spheres_colliding;
  meshes_drawn_ += meshes;
  lit_frames_ += lit;
  hull_fraction_sum_ += hull_fraction;
}

void RunReport::OnModelFrameset(const ModelStateSample& state) {
  ModelStats& stats = model_stats_[state.model_id];
  ++stats.framesets;
  stats.boxes_tested += state.boxes_tested;
  stats.triangles_queried += state.triangles_queried;
  stats.triangles = state.triangles;
  if (stats.query_ms.size() < kMaxSamples) stats.query_ms.push_back(float(state.query_ms));
}

void RunReport::OnModelPart(const ModelPartSample& part) {
  PartStats& p = parts_[part.object_id];
  p.model_id = part.model_id;
  p.name = part.name;
  p.file = part.file;
  p.triangles = part.triangles.size();
}

void RunReport::OnModelPartDrawn(uint32_t object_id, uint8_t contact, double clearance) {
  PartStats& p = parts_[object_id];
  p.frames_colliding += contact == kPartColliding;
  p.frames_near += contact == kPartNear;
  if (clearance >= 0 && p.clearance_m.size() < kMaxSamples) p.clearance_m.push_back(float(clearance));
}

void RunReport::OnMeshDrawn(const std::string& element, uint32_t object_id, double clearance, bool colliding) {
  auto key = std::make_pair(element, object_id);
  auto it = mesh_stats_.find(key);
  if (it == mesh_stats_.end()) {
    if (mesh_stats_.size() >= kMaxMeshObjects) {
      ++meshes_over_limit_;
      return;
    }
    it = mesh_stats_.emplace(std::move(key), MeshStats{}).first;
  }
  MeshStats& m = it->second;
  ++m.frames_drawn;
  m.frames_colliding += colliding;
  if (clearance >= 0 && std::isfinite(clearance))
    m.min_clearance_m = m.min_clearance_m < 0 ? clearance : std::min(m.min_clearance_m, clearance);
}

nlohmann::json RunReport::ModelsJson() const {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [model_id, stats] : model_stats_) {
    nlohmann::json m;
    m["model_id"] = model_id;
    m["triangles"] = stats.triangles;
    m["framesets"] = stats.framesets;
    const double n = double(std::max<uint64_t>(stats.framesets, 1));
    m["boxes_tested_mean"] = double(stats.boxes_tested) / n;
    m["triangles_queried_mean"] = double(stats.triangles_queried) / n;
    std::vector<double> q(stats.query_ms.begin(), stats.query_ms.end());
    m["query_ms_p50"] = q.empty() ? 0.0 : Percentile(q, 50);
    m["query_ms_p95"] = q.empty() ? 0.0 : Percentile(q, 95);
    nlohmann::json parts = nlohmann::json::array();
    for (const auto& [id, p] : parts_) {
      if (p.model_id != model_id) continue;
      if (m.find("file") == m.end()) m["file"] = p.file;
      std::vector<double> c(p.clearance_m.begin(), p.clearance_m.end());
      parts.push_back({{"object_id", id},
                       {"name", p.name},
                       {"triangles", p.triangles},
                       {"frames_in_collision", p.frames_colliding},
                       {"frames_near", p.frames_near},
                       {"clearance_mm_p50", c.empty() ? nlohmann::json() : nlohmann::json(Percentile(c, 50) * 1e3)},
                       {"clearance_mm_min", c.empty() ? nlohmann::json()
                                                      : nlohmann::json(*std::min_element(c.begin(), c.end()) * 1e3)}});
    }
    m["parts"] = parts;
    out.push_back(m);
  }
  return out;
}

LatencyBudget RunReport::Budget(const NodeStatsSample& render) const {
  std::map<std::string, NodeStatsSample> reports = node_stats_;
  reports["render"] = render;
  return BuildLatencyBudget(reports);
}

nlohmann::json RunReport::StatsJson(const RunFacts& facts) const {
  nlohmann::json j;
  j["view"] = {{"width", facts.width}, {"height", facts.height}, {"tiles", facts.tiles}};
  j["run_id"] = RunIdText(facts.run_id);
  j["ignored_from_other_runs"] = facts.ignored_from_other_runs;  // samples by kind (HullView, NodeStats)
  j["node_stats_over_limit"] = node_stats_over_limit_;  // reports of names past kMaxNodes, ignored
  j["calibrations_refused"] = facts.calibrations_refused;  // CameraInfo changing a calibration mid-run
  if (facts.cameras_ended_early) j["cameras_ended_early"] = *facts.cameras_ended_early;
  j["frames_composited"] = facts.frames_composited;
  j["last_frame_seq"] = facts.last_frame_seq;
  j["collision_frames_drawn"] = collisions_drawn_;
  j["collision_reports_with_points"] = collision_reports_;
  // Responses by their hull velocity (docs/collision.md, "Hull velocity").
  {
    // stats.json's keys, indexed by HullVelocityStatus (kNone is not counted).
    static const char* kNames[] = {"none", "measured", "clamped", "no_previous", "too_far_apart", "appeared"};
    static_assert(std::size(kNames) == size_t(HullVelocityStatus::kAppeared) + 1);
    nlohmann::json hv = nlohmann::json::object();
    for (int i = int(HullVelocityStatus::kMeasured); i <= int(HullVelocityStatus::kAppeared); ++i) {
      const auto it = hull_velocity_statuses_.find(uint8_t(i));
      hv[kNames[i]] = it == hull_velocity_statuses_.end() ? 0 : it->second;
    }
    const uint64_t valid = hv["measured"].get<uint64_t>() + hv["clamped"].get<uint64_t>();
    hv["max_normal_speed_mps"] = hull_speed_max_;
    hv["mean_normal_speed_mps"] = valid ? hull_speed_sum_ / double(valid) : 0.0;
    j["hull_velocity"] = hv;
  }
  j["meshes_drawn"] = meshes_drawn_;  // cloth, particle sets and payload parts, summed over frames
  j["lit_frames"] = lit_frames_;      // frames with the scene's light and shadows
  j["recon_outages"] = facts.recon_outages;
  j["hull_pixel_fraction_mean"] =
      facts.frames_composited ? hull_fraction_sum_ / double(facts.frames_composited) : 0.0;
  j["world"] = facts.world;
  if (!model_stats_.empty()) j["models"] = ModelsJson();
  // Each scene element's meshes, by the element's key and the object id.
  for (const auto& [key, m] : mesh_stats_)
    j["elements"][key.first][std::to_string(key.second)] = {
        {"frames_drawn", m.frames_drawn},
        {"frames_colliding", m.frames_colliding},
        {"min_clearance_mm", m.min_clearance_m < 0 ? nlohmann::json() : nlohmann::json(m.min_clearance_m * 1e3)}};
  if (meshes_over_limit_) j["meshes_over_limit"] = meshes_over_limit_;
  auto row = [](const NodeStatsSample& r) {
    nlohmann::json stages = nlohmann::json::object();
    for (const auto& [n, s] : r.stages)
      stages[n] = {{"ms_mean", s.ms_mean}, {"ms_p50", s.ms_p50}, {"ms_p95", s.ms_p95}, {"count", s.count}};
    nlohmann::json out{{"fps", r.fps},           {"latency_ms_p50", r.latency_ms_p50},
                       {"latency_ms_p95", r.latency_ms_p95}, {"frames_in", r.frames_in},
                       {"frames_out", r.frames_out}, {"dropped", r.dropped},
                       {"rejected", r.rejected}, {"stages_ms", stages}};
    if (!r.backend.empty()) out["backend"] = r.backend;
    return out;
  };
  auto assembly = [](const NodeStatsSample& r) {
    nlohmann::json cams = nlohmann::json::object();
    for (const auto& c : r.cameras)
      cams[std::to_string(c.camera_id)] = {{"skew_ms_p50", c.skew_ms_p50}, {"skew_ms_p95", c.skew_ms_p95},
                                           {"skew_ms_max", c.skew_ms_max}, {"period_ms", c.period_ms},
                                           {"frames", c.frames},           {"unpartnered", c.unpartnered},
                                           {"pauses", c.pauses},           {"restarts", c.restarts},
                                           {"clock_offsets", c.clock_offsets}};
    return nlohmann::json{{"dropped_for_skew", r.dropped_for_skew}, {"cameras", cams}};
  };
  j["nodes"] = nlohmann::json::object();
  for (const auto& [name, r] : node_stats_)
    if (name != "render") j["nodes"][name] = row(r);
  j["nodes"]["render"] = row(facts.render);
  // Frameset assembly by capture time, per assembling node and camera.
  j["framesets"] = nlohmann::json::object();
  for (const auto& [name, r] : node_stats_)
    if (name != "render" && !r.cameras.empty()) j["framesets"][name] = assembly(r);
  j["framesets"]["render"] = assembly(facts.render);
  // How many framesets the cameras' streams made, apart from how many this node
  // had time to composite (it takes the newest).
  j["framesets"]["render"]["reference_frames"] = facts.reference_frames;
  j["framesets"]["render"]["complete"] = facts.framesets_complete;
  j["latency_budget"] = Budget(facts.render).ToJson();
  return j;
}

std::string RunReport::Table(const RunFacts& facts) const {
  std::string out;
  auto line = [&out](const char* fmt, auto... args) {
    char buf[256];
    std::snprintf(buf, sizeof buf, fmt, args...);
    out += buf;
  };
  line("%-10s %8s %14s %14s %10s %10s %8s %8s\n", "node", "fps", "latency p50 ms", "latency p95 ms", "frames in",
       "frames out", "dropped", "rejected");
  auto row = [&](const NodeStatsSample& r) {
    line("%-10s %8.1f %14.1f %14.1f %10llu %10llu %8llu %8llu\n", r.name.c_str(), r.fps, r.latency_ms_p50,
         r.latency_ms_p95, (unsigned long long)r.frames_in, (unsigned long long)r.frames_out,
         (unsigned long long)r.dropped, (unsigned long long)r.rejected);
  };
  for (const auto& [name, r] : node_stats_)
    if (name != "render") row(r);
  const NodeStatsSample& self = facts.render;
  row(self);
  // What computed each node's hull or collisions (CPU, or which GL renderer).
  for (const auto& [name, r] : node_stats_)
    if (!r.backend.empty()) line("%-10s backend: %.200s\n", name.c_str(), r.backend.c_str());
  for (const auto& [kind, n] : facts.ignored_from_other_runs)
    line("ignored %llu %s sample(s) of other runs (this run is %s)\n", (unsigned long long)n, kind.c_str(),
         RunIdText(facts.run_id).c_str());
  // CAD models (docs/models.md): what sim's hierarchy spared per frameset.
  for (const auto& m : ModelsJson())
    line("model %.120s: %llu triangles, per frameset %.0f boxes tested, %.0f triangles queried, %.2f ms p50 "
         "(%llu framesets)\n",
         m.value("file", std::string("?")).c_str(), (unsigned long long)m["triangles"].get<uint64_t>(),
         m["boxes_tested_mean"].get<double>(), m["triangles_queried_mean"].get<double>(),
         m["query_ms_p50"].get<double>(), (unsigned long long)m["framesets"].get<uint64_t>());
  // Where the time from capture to composite goes (docs/latency.md).
  line("\nlatency budget (ms after capture; * on the critical path):\n");
  out += Budget(self).Table();
  // How render's framesets were assembled (the recon and sim nodes' are in stats.json).
  if (!self.cameras.empty()) {
    line("\nframesets (render): %llu dropped for skew\n", (unsigned long long)self.dropped_for_skew);
    line("%-7s %9s %9s %9s %9s %8s %11s %7s %9s %9s\n", "camera", "skew p50", "skew p95", "skew max", "period",
         "frames", "unpartnered", "pauses", "restarts", "clock off");
    for (const auto& c : self.cameras)
      line("%-7d %9.2f %9.2f %9.2f %9.2f %8llu %11llu %7llu %9llu %9llu\n", c.camera_id, c.skew_ms_p50,
           c.skew_ms_p95, c.skew_ms_max, c.period_ms, (unsigned long long)c.frames,
           (unsigned long long)c.unpartnered, (unsigned long long)c.pauses, (unsigned long long)c.restarts,
           (unsigned long long)c.clock_offsets);
  }
  return out;
}

}  // namespace hullpipe::nodes
