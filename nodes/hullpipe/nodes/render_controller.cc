#include "hullpipe/nodes/render_controller.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <limits>
#include <stdexcept>

#include "hullpipe/collision/hull_motion.h"
#include "hullpipe/util/percentile.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/reconstruction/tile_set.h"

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

void RenderOptions::ApplyWorld(const RigWorld* rig, const WorldFlags& flags) {
  if (rig) {
    up = rig->up;
    floor = rig->floor;
    floor_height = rig->floor_height;
    orbit_radius = rig->orbit_radius;
    orbit_height = rig->orbit_height;
  }
  if (flags.up) up = *flags.up;
  if (flags.orbit_radius) orbit_radius = *flags.orbit_radius;
  if (flags.orbit_height) orbit_height = *flags.orbit_height;
  if (flags.floor.empty()) return;
  if (flags.floor == "hull" || flags.floor == "none") {
    floor = flags.floor == "hull" ? RigWorld::Floor::kUnderHull : RigWorld::Floor::kNone;
    return;
  }
  size_t used = 0;
  double h = 0;
  try {
    h = std::stod(flags.floor, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != flags.floor.size() || !std::isfinite(h))
    throw std::invalid_argument("--floor must be metres along up, 'hull' or 'none', not '" + flags.floor + "'");
  floor = RigWorld::Floor::kPlane;
  floor_height = h;
}

void RenderOptions::Check() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (width < 1 || width > 8192) bad("--width must be 1..8192 pixels");
  if (height < 1 || height > 8192) bad("--height must be 1..8192 pixels");
  if (!(hfov_deg > 0 && hfov_deg <= 179)) bad("--hfov must be in (0, 179] degrees");
  if (tiles < 1 || tiles > 64) bad("--tiles must be 1..64");
  if (max_in_flight < 1 || max_in_flight > 64) bad("--max-in-flight must be 1..64");
  if (max_frames < 0) bad("--frames must be >= 0");
  if (!(idle_timeout > 0 && idle_timeout <= 3600)) bad("--idle-timeout must be in (0, 3600] s");
  if (!(tile_timeout > 0 && tile_timeout <= 3600)) bad("--tile-timeout must be in (0, 3600] s");
  if (!(recon_silence > 0 && recon_silence <= 3600)) bad("recon silence must be in (0, 3600] s");
  if (!(end_grace >= 0 && end_grace <= 60)) bad("end grace must be in [0, 60] s");
  if (!(std::isfinite(orbit_radius) && orbit_radius > 0)) bad("--orbit-radius must be > 0 m");
  if (!std::isfinite(orbit_height)) bad("--orbit-height must be finite");
  if (!std::isfinite(floor_height)) bad("--floor must be finite");
  if (!(std::isfinite(orbit_period) && orbit_period > 0)) bad("--orbit-period must be > 0 s");
  if (orbit_centre && !orbit_centre->allFinite()) bad("--orbit-centre must be finite");
  if (!up.allFinite() || up.norm() < 1e-9) bad("--up must be a finite non-zero vector");
  if (view == View::kFile && track.empty()) bad("--view file goes with --head-poses FILE");
  if (publish_max_side < 16 || publish_max_side > 16384) bad("--publish-max-side must be 16..16384 pixels");
  if (publish_jpeg_quality < 1 || publish_jpeg_quality > 100) bad("--publish-jpeg-quality must be 1..100");
}

RenderController::RenderController(RenderOptions options, const Clock& clock, FramesetAssembler& assembler,
                                   RenderSink& sink)
    : o_(std::move(options)),
      clock_(clock),
      assembler_(assembler),
      sink_(sink),
      counters_(clock),
      recon_liveness_((o_.Check(), o_.recon_silence)),
      runs_(o_.run_id) {
  tile_timeout_ = o_.tile_timeout;
  orbit_.up = o_.up.normalized();
  orbit_.radius = o_.orbit_radius;
  orbit_.height = o_.orbit_height;
  orbit_.period = o_.orbit_period;
  if (o_.orbit_centre) {
    orbit_.centre = *o_.orbit_centre;
    centre_known_ = true;
  }
  comp_.floor_normal = orbit_.up;
  comp_.draw_floor = o_.floor != RigWorld::Floor::kNone;
  comp_.floor_offset = o_.floor == RigWorld::Floor::kPlane ? o_.floor_height : 0.0;
  floor_known_ = o_.floor != RigWorld::Floor::kUnderHull;
  if (!floor_known_) comp_.draw_floor = false;  // until the first hull
  last_new_frame_s_ = clock_.Now();
}

void RenderController::Reject(const std::string& why) {
  ++rejected_;
  spdlog::warn("rejected: {}", why);
}

void RenderController::OnTile(HullTile t, int64_t sent_ns) {
  // A tile answers a pose, and a pose carries this run's id: render's tiles
  // always carry it, so one without it is another run's too.
  if (!runs_.Accept(t.run_id, "HullView", /*take_unset=*/o_.run_id == 0, "recon" + std::to_string(t.node_id)))
    return;
  auto it = in_flight_.find(t.pose_seq);
  if (it == in_flight_.end()) {
    ++tiles_late_;
    // A tile for a pose given up on: the recon nodes need longer than the
    // time-out. Wait twice what this one took from now on (docs/latency.md),
    // and keep the tile: Step composites the pose if all its tiles come.
    it = given_up_.find(t.pose_seq);
    if (it == given_up_.end()) return;
    const double took = clock_.Now() - it->second.sent_s;
    if (took > tile_timeout_ && tile_timeout_ < kMaxTileTimeoutS) {
      tile_timeout_ = std::min(kMaxTileTimeoutS, 2 * took);
      spdlog::warn("pose {}'s tile came {:.2f} s after the pose, past the tile time-out: waiting up to {:.2f} s "
                   "from now on (--tile-timeout sets where it starts)",
                   t.pose_seq, took, tile_timeout_);
    }
  }
  if (t.rect.x < 0 || t.rect.y < 0 || t.rect.x + t.rect.width > it->second.view.width ||
      t.rect.y + t.rect.height > it->second.view.height) {
    Reject("HullView tile rectangle lies outside the view");
    return;
  }
  counters_.StageSince("transport_tile", sent_ns);
  auto& tiles = it->second.tiles;
  tiles[t.tile_index] = std::move(t);
  // The tiles' round trip: the pose sent to its last tile in (beside recon's stages).
  if (int(tiles.size()) == o_.tiles) counters_.Stage("tiles", (clock_.Now() - it->second.sent_s) * 1e3);
}

void RenderController::OnObjectState(const VirtualObjectSample& s) {
  auto& per = states_[s.object_id];
  per[s.frame_seq] = s;
  while (per.size() > 32) per.erase(per.begin());
}

void RenderController::OnMesh(VirtualMeshSample m) {
  auto& per = meshes_[m.object_id];
  per[m.frame_seq] = std::move(m);
  while (per.size() > 8) per.erase(per.begin());
}

void RenderController::OnModelPart(ModelPartSample part) {
  ModelPartDraw& d = model_parts_[part.object_id];
  d.part = std::move(part);
  d.world.triangles = d.part.triangles;
  d.world.vertices.clear();
  d.position = Eigen::Vector3d::Constant(std::nan(""));  // moved again at its next state
}

void RenderController::OnModelState(ModelStateSample state) {
  auto& per = model_states_[state.model_id];
  auto& stats = model_stats_[state.model_id];
  if (per.find(state.frame_seq) == per.end()) {
    ++stats.framesets;
    stats.boxes_tested += state.boxes_tested;
    stats.triangles_queried += state.triangles_queried;
    stats.triangles = state.triangles;
    if (stats.query_ms.size() < 100000) stats.query_ms.push_back(float(state.query_ms));
  }
  per[state.frame_seq] = std::move(state);
  while (per.size() > 8) per.erase(per.begin());
}

void RenderController::DrawModels(uint64_t frame_seq, MeshDraws* draws) {
  static const cv::Vec3b kAmber(0, 170, 255);
  for (const auto& [model_id, per] : model_states_) {
    auto s = per.upper_bound(frame_seq);
    if (s == per.begin()) continue;
    --s;
    const ModelStateSample& st = s->second;
    for (size_t k = 0; k < st.parts.size(); ++k) {
      const auto it = model_parts_.find(model_id + uint32_t(k));
      if (it == model_parts_.end()) continue;  // its geometry has not come (yet)
      ModelPartDraw& d = it->second;
      const PartStateSample& ps = st.parts[k];
      if (!(d.position == ps.position) || !(d.orientation == ps.orientation) || d.world.vertices.empty()) {
        const Eigen::Matrix3d R =
            Eigen::Quaterniond(ps.orientation[0], ps.orientation[1], ps.orientation[2], ps.orientation[3])
                .normalized()
                .toRotationMatrix();
        d.world.vertices.resize(d.part.vertices.size());
        for (size_t v = 0; v < d.part.vertices.size(); ++v)
          d.world.vertices[v] = R * d.part.vertices[v].cast<double>() + ps.position;
        d.position = ps.position;
        d.orientation = ps.orientation;
      }
      d.world.colour = ps.contact == kPartColliding ? comp_.collide_colour
                       : ps.contact == kPartNear   ? kAmber
                                                   : d.part.colour;
      draws->push_back(&d.world);
      d.frames_colliding += ps.contact == kPartColliding;
      d.frames_near += ps.contact == kPartNear;
      if (ps.clearance >= 0 && d.clearance_m.size() < 100000) d.clearance_m.push_back(float(ps.clearance));
    }
  }
}

nlohmann::json RenderController::ModelsJson() const {
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
    for (const auto& [id, d] : model_parts_) {
      if (d.part.model_id != model_id) continue;
      if (m.find("file") == m.end()) m["file"] = d.part.file;
      std::vector<double> c(d.clearance_m.begin(), d.clearance_m.end());
      parts.push_back({{"object_id", id},
                       {"name", d.part.name},
                       {"triangles", d.part.triangles.size()},
                       {"frames_in_collision", d.frames_colliding},
                       {"frames_near", d.frames_near},
                       {"clearance_mm_p50", c.empty() ? nlohmann::json() : nlohmann::json(Percentile(c, 50) * 1e3)},
                       {"clearance_mm_min", c.empty() ? nlohmann::json()
                                                      : nlohmann::json(*std::min_element(c.begin(), c.end()) * 1e3)}});
    }
    m["parts"] = parts;
    out.push_back(m);
  }
  return out;
}

void RenderController::OnHeadPose(const Rigid3d& world_from_eye) { tracked_ = world_from_eye; }

void RenderController::OnCollisionReport(bool has_points, uint8_t hull_velocity_status, double hull_normal_speed) {
  if (has_points) ++collision_reports_;
  using S = HullVelocityStatus;
  if (hull_velocity_status == uint8_t(S::kNone) || hull_velocity_status > uint8_t(S::kAppeared)) return;  // none, or unknown
  ++hull_velocity_statuses_[hull_velocity_status];
  if ((hull_velocity_status == uint8_t(S::kMeasured) || hull_velocity_status == uint8_t(S::kClamped)) &&
      std::isfinite(hull_normal_speed)) {
    hull_speed_max_ = std::max(hull_speed_max_, std::abs(hull_normal_speed));
    hull_speed_sum_ += std::abs(hull_normal_speed);
  }
}

bool RenderController::AwaitingFinalReports() const {
  for (const auto& [name, st] : node_stats_)
    if (name != "render" && !st.final_report) return true;
  return false;
}

void RenderController::OnNodeStats(const NodeStatsSample& m) {
  if (!runs_.Accept(m.run_id, "NodeStats", /*take_unset=*/true, m.name)) return;
  // Per-node state is bounded: a peer flooding reports under distinct names
  // (render grew to 594 MB and wrote a 0.5-GB stats.json) is ignored past
  // kMaxNodes names, counted and said once.
  if (node_stats_.size() >= kMaxNodes && !node_stats_.count(m.name)) {
    if (node_stats_over_limit_++ == 0)
      spdlog::warn("NodeStats from more than {} node names (the latest '{}'): the rest are ignored and counted "
                   "(a peer on this domain publishes reports of nodes that are not a run's)",
                   kMaxNodes, m.name.substr(0, 64));
    return;
  }
  node_stats_[m.name] = m;
  // Only this run's recon names ("recon0".."recon<tiles-1>") are watched for
  // silence: 1000 names "recon_<n>" from a peer made 1000 false fail-over lines.
  int k = -1;
  char tail = 0;
  if (std::sscanf(m.name.c_str(), "recon%d%c", &k, &tail) == 1 && k >= 0 && k < o_.tiles &&
      m.name == "recon" + std::to_string(k))
    recon_liveness_.Heard(m.name, clock_.Now(), m.final_report);
  // With cameras on several capture nodes the input ends when every capture node
  // heard from has said so.
  if (m.name.rfind("capture", 0) == 0) {
    const bool was_final = capture_final_[m.name];
    capture_final_[m.name] = m.final_report;
    if (m.final_report && !was_final) spdlog::info("{} reports the end of its input", m.name);
    bool all = true;
    for (const auto& [name, final_report] : capture_final_) all = all && final_report;
    if (all && !capture_done_) {
      capture_done_ = true;
      capture_done_s_ = clock_.Now();
    }
  }
}

void RenderController::IssuePoses() {
  // A restarted capture numbers its frames from 1 again.
  if (assembler_.restarts() != seen_restarts_) {
    seen_restarts_ = assembler_.restarts();
    last_requested_ = 0;
    spdlog::info("capture restarted: following its new frame numbers");
  }
  while (int(in_flight_.size()) < o_.max_in_flight) {
    const auto newest = assembler_.NewestComplete();
    if (!newest || *newest <= last_requested_) break;
    auto fset = assembler_.Take(*newest);
    if (!fset) break;
    counters_.FrameIn();
    last_new_frame_s_ = clock_.Now();
    if (!any_frame_) {
      any_frame_ = true;
      first_source_time_ = fset->source_time_s;
    }
    // The frameset's hull: for the orbit centre until it is known, and for the
    // light's shadow map (one VolumeQuery, one hull box, for both).
    std::shared_ptr<const VolumeQuery> hull;
    if (o_.light || !centre_known_ || !floor_known_ || !floor_checked_)
      hull = std::make_shared<const VolumeQuery>(fset->maps, assembler_.workspace());
    const std::optional<double> reach_down =
        hull && !hull->hull_box().empty() && (!floor_known_ || !floor_checked_) ? HullExtentAlong(*hull, -orbit_.up)
                                                                               : std::nullopt;
    if (reach_down) {
      // The hull's lowest point along up (not its box's corner, which lies
      // below the hull where up is not an axis).
      const double lowest = -*reach_down;
      if (!floor_known_) {
        comp_.floor_offset = lowest;
        comp_.draw_floor = true;
        floor_known_ = true;
        spdlog::info("floor under the first hull: up . x = {:.3f} m", lowest);
      } else if (comp_.draw_floor && lowest < comp_.floor_offset - 0.05) {
        spdlog::warn("the hull reaches {:.2f} m below the rig's floor (up . x = {:.3f} m): the floor hides that "
                     "part; is the rig's world right? (hullpipe_rig check; world: floor: hull puts it under the hull)",
                     comp_.floor_offset - lowest, comp_.floor_offset);
      }
      floor_checked_ = true;
    }
    // The first hull's own box (stats.json's "world"), not the hull box, which
    // keeps the workspace's faces where the cameras' axes are not the world's.
    if (first_hull_box_.empty() && hull && !hull->hull_box().empty() && (reach_down || !centre_known_))
      first_hull_box_ = SampledHullBox(*hull);
    if (!centre_known_ && !hull->hull_box().empty()) {
      orbit_.centre = first_hull_box_.Center();
      centre_known_ = true;
      spdlog::info("orbit centre from the first hull's box: [{:.2f}, {:.2f}, {:.2f}] m", orbit_.centre.x(),
                   orbit_.centre.y(), orbit_.centre.z());
    }
    // The path is driven by the frames' source time, not the wall clock, so the
    // same frame is seen from the same place in every run and replay.
    const double t = fset->source_time_s - first_source_time_;
    InFlight f;
    f.frame_seq = fset->seq;
    f.capture_time_ns = fset->capture_time_ns;
    f.path_time_s = t;
    f.sent_s = clock_.Now();
    if (o_.light) f.hull = hull;
    Rigid3d world_from_eye = orbit_.WorldFromEye(t);
    if (o_.view == RenderOptions::View::kFile) world_from_eye = o_.track.At(t);
    if (o_.view == RenderOptions::View::kTopic && tracked_) world_from_eye = *tracked_;
    f.view = NovelView::FromFov(o_.width, o_.height, o_.hfov_deg * M_PI / 180.0, world_from_eye);
    ++pose_seq_;
    sink_.PublishPose(f.view, pose_seq_, fset->seq);
    // Render's own frameset in (its last sample taken) to its pose out.
    counters_.StageSince("issue", fset->last_arrival_ns);
    in_flight_[pose_seq_] = std::move(f);
    last_requested_ = fset->seq;
  }
}

void RenderController::Composite(uint64_t pose_seq, InFlight& f) {
  spdlog::debug("compositing a {}x{} view (frame {})", o_.width, o_.height, f.frame_seq);
  std::optional<StageTimer> st(std::in_place, counters_, "composite");
  std::vector<const HullTile*> tiles;
  for (const auto& [idx, t] : f.tiles) tiles.push_back(&t);
  const HullViewImage hull = PasteTiles(tiles, {o_.width, o_.height}, stop_);
  const cv::Mat& depth = hull.depth;
  const cv::Mat& colour = hull.colour;
  int64_t hull_pixels = 0;
  for (int r = 0; r < depth.rows; ++r) {
    const float* row = depth.ptr<float>(r);
    for (int c = 0; c < depth.cols; ++c) hull_pixels += row[c] < kNoDepth;
  }
  hull_fraction_sum_ += double(hull_pixels) / double(depth.total());
  std::vector<VirtualSphere> spheres;
  for (const auto& [id, per] : states_) {
    // The state stepped against this frameset, else the newest before it.
    auto s = per.upper_bound(f.frame_seq);
    if (s == per.begin()) continue;
    --s;
    spheres.push_back({s->second.position, s->second.radius, s->second.colliding});
    if (s->second.colliding) ++collisions_drawn_;
  }
  MeshDraws draws;  // pointers into meshes_ and model_parts_, unchanged until drawn
  for (const auto& [id, per] : meshes_) {
    auto s = per.upper_bound(f.frame_seq);
    if (s == per.begin()) continue;
    --s;
    draws.push_back(&s->second.draw);
    if (s->second.kind == kMeshPart && s->second.clearance >= 0) {
      auto [mc, fresh] = min_clearance_.try_emplace(id, s->second.clearance);
      if (!fresh) mc->second = std::min(mc->second, s->second.clearance);
      const auto& c = s->second.draw.colliding;
      if (std::find(c.begin(), c.end(), 1) != c.end()) ++part_collisions_[id];
    }
  }
  DrawModels(f.frame_seq, &draws);
  meshes_drawn_ += draws.size();
  cv::Mat composited_depth;
  cv::Mat frame = hullpipe::Composite(f.view, depth, colour, spheres, comp_, &composited_depth, draws, stop_);
  st.reset();
  if (o_.light) {
    StageTimer lt(counters_, "light");
    const ShadowMap shadow = RenderShadowMap(*o_.light, orbit_.up, f.hull.get(), spheres, draws);
    ApplyLighting(f.view, composited_depth, depth, *o_.light, shadow, &frame, stop_);
    ++lit_frames_;
  }
  {
    StageTimer wt(counters_, "write");
    sink_.WriteFrame(frame, f.frame_seq, counters_.frames_out() + 1, f.view, depth, f.path_time_s);
  }
  if (o_.publish_composite) {
    StageTimer pt(counters_, "publish");
    sink_.PublishComposite(frame, pose_seq, f.frame_seq, f.capture_time_ns);
  }
  counters_.FrameOut(f.capture_time_ns);
  last_composited_ = std::max(last_composited_, f.frame_seq);
}

int RenderController::Step() {
  IssuePoses();
  int composited = 0;
  // A pose given up on whose tiles all came after all: composited if nothing
  // newer was (it was counted as dropped when given up; no longer).
  for (auto it = given_up_.begin(); it != given_up_.end();) {
    if (int(it->second.tiles.size()) < o_.tiles) {
      ++it;
      continue;
    }
    if (it->second.frame_seq > last_composited_) {
      spdlog::info("pose {} (frame {}): its tiles came after it was given up; composited", it->first,
                   it->second.frame_seq);
      Composite(it->first, it->second);
      ++composited;
      ++late_composited_;
      counters_.SetDropped(counters_.dropped() - std::min<uint64_t>(1, counters_.dropped()));
    }
    it = given_up_.erase(given_up_.begin(), std::next(it));  // older ones cannot be composited now
  }
  // Composite every pose whose tiles are all in; give up on stale ones.
  for (auto it = in_flight_.begin(); it != in_flight_.end();) {
    InFlight& f = it->second;
    if (int(f.tiles.size()) < o_.tiles) {
      if (clock_.Now() - f.sent_s > tile_timeout_) {
        spdlog::warn("pose {} (frame {}): {} of {} tiles after {:.1f} s; dropped", it->first, f.frame_seq,
                     f.tiles.size(), o_.tiles, tile_timeout_);
        counters_.Dropped();
        given_up_[it->first] = std::move(f);
        while (given_up_.size() > kMaxGivenUp) given_up_.erase(given_up_.begin());
        it = in_flight_.erase(it);
      } else {
        ++it;
      }
      continue;
    }
    Composite(it->first, f);
    ++composited;
    // Older poses still waiting are superseded by this one.
    for (auto older = in_flight_.begin(); older != it;) {
      counters_.Dropped();
      older = in_flight_.erase(older);
    }
    it = in_flight_.erase(it);
    if (o_.max_frames > 0 && int64_t(last_composited_) >= o_.max_frames) done_ = true;
  }

  const double now = clock_.Now();
  // A recon node that stops reporting (NodeStats every 0.5 s) is noticed within
  // recon_silence; its tile comes from the lowest live recon node meanwhile.
  for (const auto& c : recon_liveness_.Update(now)) {
    if (c.silent)
      spdlog::warn("{} silent for {:.1f} s: its tile now comes from another recon node", c.peer, o_.recon_silence);
    else
      spdlog::info("{} is back", c.peer);
  }
  // The input ended: capture said so and everything it sent is composited
  // (end_grace for the last samples to land), or nothing came for idle_timeout.
  // A pose given up on shortly before may still have its tiles coming.
  bool awaiting_late = false;
  for (const auto& [seq, f] : given_up_)
    awaiting_late = awaiting_late || (f.frame_seq > last_composited_ && now - f.sent_s < kLateWaitS);
  if (capture_done_ && in_flight_.empty() && !awaiting_late && !assembler_.NewestComplete() &&
      now - capture_done_s_ > o_.end_grace) {
    spdlog::info("input ended; all framesets handled");
    done_ = true;
  }
  if (any_frame_ && now - last_new_frame_s_ > o_.idle_timeout && in_flight_.empty() && !awaiting_late) {
    spdlog::info("no new frameset for {:.1f} s: input ended", o_.idle_timeout);
    done_ = true;
  }
  counters_.SetRejected(rejected_ + malformed_input_ + assembler_.rejected() + assembler_.calibrations_refused());
  counters_.SetAssembly(assembler_.SkewReports(), assembler_.dropped_for_skew());
  return composited;
}

std::string RenderController::IncompleteInput() const {
  if (!capture_done_) return "";
  const auto early = assembler_.EndedEarly();
  if (early.empty()) return "";
  std::string ids, detail;
  for (const auto& e : early) {
    ids += (ids.empty() ? "" : ", ") + std::to_string(e.camera_id);
    char buf[96];
    std::snprintf(buf, sizeof buf, "%scamera %d: %llu frames, ended %.2f s of capture time before the last",
                  detail.empty() ? "" : "; ", e.camera_id, (unsigned long long)e.frames, e.lag_s);
    detail += buf;
  }
  return "the input ended early (exit 3): camera(s) " + ids +
         " ended before the others, so the framesets after their end are incomplete (" + detail + ")";
}

nlohmann::json RenderController::StatsJson() const {
  nlohmann::json j;
  j["view"] = {{"width", o_.width}, {"height", o_.height}, {"tiles", o_.tiles}};
  j["run_id"] = RunIdText(o_.run_id);
  j["ignored_from_other_runs"] = runs_.ignored();  // samples by kind (HullView, NodeStats)
  j["node_stats_over_limit"] = node_stats_over_limit_;  // reports of names past kMaxNodes, ignored
  j["calibrations_refused"] = assembler_.calibrations_refused();  // CameraInfo changing a calibration mid-run
  if (capture_done_) {
    j["cameras_ended_early"] = nlohmann::json::array();
    for (const auto& e : assembler_.EndedEarly()) j["cameras_ended_early"].push_back(e.camera_id);
  }
  j["frames_composited"] = counters_.frames_out();
  j["last_frame_seq"] = last_composited_;
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
  j["recon_outages"] = recon_liveness_.outages();  // times each recon node fell silent
  j["hull_pixel_fraction_mean"] =
      counters_.frames_out() ? hull_fraction_sum_ / double(counters_.frames_out()) : 0.0;
  // The world drawn (docs/rigs.md): up, the floor as drawn (null: none, or not
  // yet placed under a hull), the orbit, and the first hull's box in world
  // metres, from which a reader sees whether the person stands on the floor.
  {
    const auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
    nlohmann::json w;
    w["up"] = vec(orbit_.up);
    w["floor"] = o_.floor == RigWorld::Floor::kPlane ? "plane" : o_.floor == RigWorld::Floor::kNone ? "none" : "hull";
    w["floor_height"] = comp_.draw_floor && floor_known_ ? nlohmann::json(comp_.floor_offset) : nlohmann::json();
    w["orbit_radius"] = orbit_.radius;
    w["orbit_centre"] = vec(orbit_.centre);
    if (!first_hull_box_.empty())
      w["first_hull_box"] = {{"min", vec(first_hull_box_.min)}, {"max", vec(first_hull_box_.max)}};
    j["world"] = w;
  }
  if (!model_stats_.empty()) j["models"] = ModelsJson();
  for (const auto& [id, c] : min_clearance_) {
    const auto pc = part_collisions_.find(id);
    j["payload"][std::to_string(id)] = {{"min_clearance_mm", c * 1e3},
                                        {"frames_colliding", pc == part_collisions_.end() ? 0 : pc->second}};
  }
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
  j["nodes"]["render"] = row(counters_.Snapshot("render", true));
  // Frameset assembly by capture time, per assembling node and camera.
  j["framesets"] = nlohmann::json::object();
  for (const auto& [name, r] : node_stats_)
    if (name != "render" && !r.cameras.empty()) j["framesets"][name] = assembly(r);
  j["framesets"]["render"] = assembly(counters_.Snapshot("render", true));
  // How many framesets the cameras' streams made, apart from how many this node
  // had time to composite (it takes the newest).
  j["framesets"]["render"]["reference_frames"] = assembler_.reference_frames();
  j["framesets"]["render"]["complete"] = assembler_.framesets_complete();
  j["latency_budget"] = Budget().ToJson();
  return j;
}

LatencyBudget RenderController::Budget() const {
  std::map<std::string, NodeStatsSample> reports = node_stats_;
  reports["render"] = counters_.Snapshot("render", true);
  return BuildLatencyBudget(reports);
}

std::string RenderController::Table() const {
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
  const NodeStatsSample self = counters_.Snapshot("render", true);
  row(self);
  // What computed each node's hull or collisions (CPU, or which GL renderer).
  for (const auto& [name, r] : node_stats_)
    if (!r.backend.empty()) line("%-10s backend: %.200s\n", name.c_str(), r.backend.c_str());
  for (const auto& [kind, n] : runs_.ignored())
    line("ignored %llu %s sample(s) of other runs (this run is %s)\n", (unsigned long long)n, kind.c_str(),
         RunIdText(o_.run_id).c_str());
  // CAD models (docs/models.md): what sim's hierarchy spared per frameset.
  for (const auto& m : ModelsJson())
    line("model %.120s: %llu triangles, per frameset %.0f boxes tested, %.0f triangles queried, %.2f ms p50 "
         "(%llu framesets)\n",
         m.value("file", std::string("?")).c_str(), (unsigned long long)m["triangles"].get<uint64_t>(),
         m["boxes_tested_mean"].get<double>(), m["triangles_queried_mean"].get<double>(),
         m["query_ms_p50"].get<double>(), (unsigned long long)m["framesets"].get<uint64_t>());
  // Where the time from capture to composite goes (docs/latency.md).
  line("\nlatency budget (ms after capture; * on the critical path):\n");
  out += Budget().Table();
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
