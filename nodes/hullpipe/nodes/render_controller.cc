#include "hullpipe/nodes/render_controller.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <thread>
#include <iterator>
#include <limits>
#include <stdexcept>

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
  if (view == View::kEyes && (!eye_track || !stereo)) bad("--view eyes goes with --eye-views FILE (and is stereo)");
  if (view == View::kEyesTopic && !stereo) bad("--view eyes-topic is stereo");
  if (publish_max_side < 16 || publish_max_side > 16384) bad("--publish-max-side must be 16..16384 pixels");
  if (publish_jpeg_quality < 1 || publish_jpeg_quality > 100) bad("--publish-jpeg-quality must be 1..100");
  if (stereo) {
    StereoOptions s = *stereo;
    s.width = width, s.height = height;
    s.Check();
  }
}

std::map<uint64_t, RenderController::InFlight>::iterator RenderController::FindPose(
    std::map<uint64_t, InFlight>& poses, uint64_t pose_seq, size_t* eye) {
  auto it = poses.upper_bound(pose_seq);
  if (it == poses.begin()) return poses.end();
  --it;
  if (pose_seq - it->first >= it->second.eyes.size()) return poses.end();
  *eye = size_t(pose_seq - it->first);
  return it;
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
  reject_log_.Log(why, clock_.Now());
}

void RenderController::OnTile(HullTile t, int64_t sent_ns) {
  // A tile answers a pose, and a pose carries this run's id: render's tiles
  // always carry it, so one without it is another run's too.
  if (!runs_.Accept(t.run_id, "HullView", /*take_unset=*/o_.run_id == 0, "recon" + std::to_string(t.node_id)))
    return;
  size_t eye = 0;
  auto it = FindPose(in_flight_, t.pose_seq, &eye);
  if (it == in_flight_.end()) {
    ++tiles_late_;
    // A tile for a pose given up on: the recon nodes need longer than the
    // time-out. Wait twice what this one took from now on (docs/latency.md),
    // and keep the tile: Step composites the pose if all its tiles come.
    it = FindPose(given_up_, t.pose_seq, &eye);
    if (it == given_up_.end()) return;
    const double took = clock_.Now() - it->second.sent_s;
    if (took > tile_timeout_ && tile_timeout_ < kMaxTileTimeoutS) {
      tile_timeout_ = std::min(kMaxTileTimeoutS, 2 * took);
      spdlog::warn("pose {}'s tile came {:.2f} s after the pose, past the tile time-out: waiting up to {:.2f} s "
                   "from now on (--tile-timeout sets where it starts)",
                   t.pose_seq, took, tile_timeout_);
    }
  }
  const NovelView& view = it->second.eyes[eye].view;
  if (t.rect.x < 0 || t.rect.y < 0 || t.rect.x + t.rect.width > view.width ||
      t.rect.y + t.rect.height > view.height) {
    Reject("HullView tile rectangle lies outside the view");
    return;
  }
  counters_.StageSince("transport_tile", sent_ns);
  auto& tiles = it->second.eyes[eye].tiles;
  const bool was_complete = it->second.Complete(o_.tiles);
  tiles[t.tile_index] = std::move(t);
  // The tiles' round trip: the pose sent to its last tile in (beside recon's stages).
  if (!was_complete && it->second.Complete(o_.tiles)) {
    counters_.Stage("tiles", (clock_.Now() - it->second.sent_s) * 1e3);
    it->second.tiles_in_s = clock_.Now();
  }
}

void RenderController::OnObjectState(const VirtualObjectSample& s) {
  SimStepped(s.frame_seq);
  auto& per = states_[s.object_id];
  per[s.frame_seq] = s;
  while (per.size() > 32) per.erase(per.begin());
}

void RenderController::OnMesh(VirtualMeshSample m) {
  SimStepped(m.frame_seq);
  auto& per = meshes_[m.object_id];
  per[m.frame_seq] = std::move(m);
  while (per.size() > 8) per.erase(per.begin());
}

void RenderController::OnModelPart(ModelPartSample part) {
  report_.OnModelPart(part);
  ModelPartDraw& d = model_parts_[part.object_id];
  d.part = std::move(part);
  d.world.triangles = d.part.triangles;
  d.world.vertices.clear();
  d.position = Eigen::Vector3d::Constant(std::nan(""));  // moved again at its next state
}

void RenderController::OnModelState(ModelStateSample state) {
  SimStepped(state.frame_seq);
  auto& per = model_states_[state.model_id];
  if (per.find(state.frame_seq) == per.end()) report_.OnModelFrameset(state);
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
      report_.OnModelPartDrawn(it->first, ps.contact, ps.clearance);
    }
  }
}

void RenderController::OnEyeViews(const EyeViewsSample& views) { eye_views_ = views; }

void RenderController::OnHeadPose(const Rigid3d& world_from_eye, int64_t stamp_ns) {
  tracked_ = world_from_eye;
  tracked_stamp_ns_ = stamp_ns;
}

void RenderController::OnCollisionReport(bool has_points, uint8_t hull_velocity_status, double hull_normal_speed) {
  report_.OnCollisionReport(has_points, hull_velocity_status, hull_normal_speed);
}

bool RenderController::AwaitingFinalReports() const {
  for (const auto& [name, st] : report_.node_stats())
    if (name != "render" && !st.final_report) return true;
  return false;
}

void RenderController::OnNodeStats(const NodeStatsSample& m) {
  if (!runs_.Accept(m.run_id, "NodeStats", /*take_unset=*/true, m.name)) return;
  if (!report_.OnNodeStats(m)) return;  // past RunReport::kMaxNodes names
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
    // The frameset's hull: for the orbit centre and the floor until they are
    // known, before the pose; for the light's shadow map, after the pose is out
    // (below), while the recon nodes sweep. One VolumeQuery, one hull box, for
    // both.
    std::shared_ptr<const VolumeQuery> hull;
    if (!centre_known_ || !floor_known_ || !floor_checked_)
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
    Rigid3d world_from_eye = orbit_.WorldFromEye(t);
    if (o_.view == RenderOptions::View::kFile) world_from_eye = o_.track.At(t);
    if (o_.view == RenderOptions::View::kTopic && tracked_) {
      world_from_eye = *tracked_;
      f.head_stamp_ns = tracked_stamp_ns_;
    }
    if (o_.view == RenderOptions::View::kEyes) {
      // Each eye as the HMD runtime reported it (its log), poses key and key + 1.
      for (const Eye e : {Eye::kLeft, Eye::kRight}) f.eyes.push_back({o_.eye_track->At(t, e, o_.width, o_.height), {}});
    } else if (o_.view == RenderOptions::View::kEyesTopic && eye_views_) {
      // The runtime's newest views, live.
      for (size_t k = 0; k < 2; ++k)
        f.eyes.push_back({EyeView(eye_views_->fov[k], o_.width, o_.height, eye_views_->world_from_eye[k]), {}});
      f.head_stamp_ns = eye_views_->stamp_ns;
    } else if (o_.stereo) {
      // The head pose's two eyes (stereo_views.h), poses key and key + 1.
      StereoOptions so = *o_.stereo;
      so.width = o_.width, so.height = o_.height;
      const StereoViews eyes = MakeStereoViews(world_from_eye, so);
      for (const NovelView& v : eyes.eye) f.eyes.push_back({v, {}});
    } else {
      f.eyes.push_back({NovelView::FromFov(o_.width, o_.height, o_.hfov_deg * M_PI / 180.0, world_from_eye), {}});
    }
    const uint64_t key = pose_seq_ + 1;
    for (size_t k = 0; k < f.eyes.size(); ++k)
      sink_.PublishPose(f.eyes[k].view, ++pose_seq_, fset->seq, ViewEyeOf(k, f.eyes.size()), f.head_stamp_ns);
    // Render's own frameset in (its last sample taken) to its pose out.
    counters_.StageSince("issue", fset->last_arrival_ns);
    if (o_.light) {
      // The hull's part of the shadow map needs only the frameset: made now,
      // while the tiles are being swept, not after they are in.
      StageTimer lt(counters_, "light_hull");
      if (!hull) hull = std::make_shared<const VolumeQuery>(fset->maps, assembler_.workspace());
      f.light_hull_depth = HullDepthFromLight(*o_.light, orbit_.up, hull.get());
    }
    in_flight_[key] = std::move(f);
    last_requested_ = fset->seq;
  }
}

RenderController::FrameObjects RenderController::GatherObjects(uint64_t frame_seq) {
  FrameObjects o;
  for (const auto& [id, per] : states_) {
    // The state stepped against this frameset, else the newest before it.
    auto s = per.upper_bound(frame_seq);
    if (s == per.begin()) continue;
    --s;
    if (s->second.shape == VirtualObjectSample::Shape::kBox) {
      o.boxes.push_back(BoxDraw(s->second, comp_.ball_colour));
    } else {
      o.spheres.push_back({s->second.position, s->second.radius, s->second.colliding});
    }
    o.spheres_colliding += s->second.colliding != 0;
  }
  for (const VirtualMeshDraw& b : o.boxes) o.draws.push_back(&b);
  for (const auto& [id, per] : meshes_) {
    auto s = per.upper_bound(frame_seq);
    if (s == per.begin()) continue;
    --s;
    o.draws.push_back(&s->second.draw);
    const auto& c = s->second.draw.colliding;
    report_.OnMeshDrawn(s->second.element, id, s->second.clearance, std::find(c.begin(), c.end(), 1) != c.end());
  }
  DrawModels(frame_seq, &o.draws);
  o.meshes_drawn = o.draws.size() - o.boxes.size();
  return o;
}

RenderController::EyeImage RenderController::CompositeEye(const InFlight::Eye& eye, const FrameObjects& objects,
                                                          const ShadowMap* shadow) const {
  EyeImage out;
  const double t0 = MonotonicSeconds();
  std::vector<const HullTile*> tiles;
  for (const auto& [idx, t] : eye.tiles) tiles.push_back(&t);
  const HullViewImage hull = PasteTiles(tiles, {eye.view.width, eye.view.height}, stop_);
  const cv::Mat& depth = hull.depth;
  int64_t hull_pixels = 0;
  for (int r = 0; r < depth.rows; ++r) {
    const float* row = depth.ptr<float>(r);
    for (int c = 0; c < depth.cols; ++c) hull_pixels += row[c] < kNoDepth;
  }
  cv::Mat composited_depth;
  out.frame = hullpipe::Composite(eye.view, depth, hull.colour, objects.spheres, comp_, &composited_depth,
                                  objects.draws, stop_);
  const double t1 = MonotonicSeconds();
  if (shadow) ApplyLighting(eye.view, composited_depth, depth, *o_.light, *shadow, &out.frame, stop_);
  out.composite_ms = (t1 - t0) * 1e3;
  out.light_ms = (MonotonicSeconds() - t1) * 1e3;
  out.hull_fraction = double(hull_pixels) / double(depth.total());
  out.hull_depth = depth;
  return out;
}

void RenderController::Composite(uint64_t pose_seq, InFlight& f) {
  spdlog::debug("compositing {} {}x{} view{} (frame {})", f.eyes.size() == 1 ? "a" : "two", o_.width, o_.height,
                f.eyes.size() == 1 ? "" : "s", f.frame_seq);
  // The frameset's virtual objects and the light's shadow map are the eyes'
  // alike: made once (and counted once), then each eye composited and lit on
  // its own, the two eyes of a stereo frame at once.
  const double t0 = MonotonicSeconds();
  const FrameObjects objects = GatherObjects(f.frame_seq);
  const double gather_ms = (MonotonicSeconds() - t0) * 1e3;
  std::optional<ShadowMap> shadow;
  double shadow_ms = 0;
  if (o_.light) {
    const double ts = MonotonicSeconds();
    shadow = RenderShadowMap(*o_.light, orbit_.up, f.light_hull_depth, objects.spheres, objects.draws);
    shadow_ms = (MonotonicSeconds() - ts) * 1e3;
  }
  std::vector<EyeImage> eyes(f.eyes.size());
  {
    std::exception_ptr failed;  // an eye's Interrupted, rethrown here
    std::vector<std::thread> others;
    for (size_t k = 1; k < f.eyes.size(); ++k)
      others.emplace_back([&, k] {
        try {
          eyes[k] = CompositeEye(f.eyes[k], objects, shadow ? &*shadow : nullptr);
        } catch (...) {
          failed = std::current_exception();
        }
      });
    try {
      eyes[0] = CompositeEye(f.eyes[0], objects, shadow ? &*shadow : nullptr);
    } catch (...) {
      for (auto& t : others) t.join();
      throw;
    }
    for (auto& t : others) t.join();
    if (failed) std::rethrow_exception(failed);
  }
  double composite_ms = 0, light_ms = 0;
  for (const EyeImage& e : eyes) {
    composite_ms = std::max(composite_ms, e.composite_ms);
    light_ms = std::max(light_ms, e.light_ms);
  }
  counters_.Stage("composite", gather_ms + composite_ms);
  if (o_.light) counters_.Stage("light", shadow_ms + light_ms);
  report_.OnFrameDrawn(objects.spheres_colliding, objects.meshes_drawn, o_.light.has_value(), eyes[0].hull_fraction);
  std::vector<cv::Mat> frames, depths;
  for (const EyeImage& e : eyes) frames.push_back(e.frame), depths.push_back(e.hull_depth);
  cv::Mat frame;
  if (frames.size() == 1) {
    frame = frames[0];
  } else {
    cv::hconcat(frames, frame);  // left eye, right eye
  }
  {
    StageTimer wt(counters_, "write");
    const RenderSink::RightEye right{f.eyes.back().view, depths.back()};
    sink_.WriteFrame(frame, f.frame_seq, counters_.frames_out() + 1, f.eyes[0].view, depths[0], f.path_time_s,
                     frames.size() > 1 ? &right : nullptr);
  }
  // Motion to eye image: the tracker's sample this frame was seen from, to its
  // eye images written (what a headset would show next; docs/hmd.md).
  counters_.StageSince("tracker_to_eye", f.head_stamp_ns);
  if (o_.publish_composite) {
    StageTimer pt(counters_, "publish");
    // Each eye's composite with its own pose (a headset shows each to its eye).
    for (size_t k = 0; k < frames.size(); ++k)
      sink_.PublishComposite(frames[k], pose_seq + k, f.frame_seq, f.capture_time_ns,
                             ViewEyeOf(k, frames.size()));
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
    if (!it->second.Complete(o_.tiles)) {
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
    if (!f.Complete(o_.tiles)) {
      if (clock_.Now() - f.sent_s > tile_timeout_) {
        spdlog::warn("pose {} (frame {}): {} of {} tiles after {:.1f} s; dropped", it->first, f.frame_seq,
                     f.TilesIn(), size_t(o_.tiles) * f.eyes.size(), tile_timeout_);
        counters_.Dropped();
        given_up_[it->first] = std::move(f);
        while (given_up_.size() > kMaxGivenUp) given_up_.erase(given_up_.begin());
        it = in_flight_.erase(it);
      } else {
        ++it;
      }
      continue;
    }
    // The simulation's output of this frameset, briefly (RenderOptions::sim_wait).
    if (sim_seen_ && sim_seq_ < f.frame_seq && clock_.Now() - f.tiles_in_s < o_.sim_wait) {
      ++it;
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

RunFacts RenderController::Facts() const {
  RunFacts f;
  f.width = o_.width;
  f.height = o_.height;
  f.tiles = o_.tiles;
  f.run_id = o_.run_id;
  f.ignored_from_other_runs = runs_.ignored();
  f.calibrations_refused = assembler_.calibrations_refused();
  if (capture_done_) {
    f.cameras_ended_early.emplace();
    for (const auto& e : assembler_.EndedEarly()) f.cameras_ended_early->push_back(e.camera_id);
  }
  f.frames_composited = counters_.frames_out();
  f.last_frame_seq = last_composited_;
  f.recon_outages = recon_liveness_.outages();
  // The world drawn (docs/rigs.md): up, the floor as drawn (null: none, or not
  // yet placed under a hull), the orbit, and the first hull's box in world
  // metres, from which a reader sees whether the person stands on the floor.
  const auto vec = [](const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); };
  nlohmann::json& w = f.world;
  w["up"] = vec(orbit_.up);
  w["floor"] = o_.floor == RigWorld::Floor::kPlane ? "plane" : o_.floor == RigWorld::Floor::kNone ? "none" : "hull";
  w["floor_height"] = comp_.draw_floor && floor_known_ ? nlohmann::json(comp_.floor_offset) : nlohmann::json();
  w["orbit_radius"] = orbit_.radius;
  w["orbit_centre"] = vec(orbit_.centre);
  if (!first_hull_box_.empty())
    w["first_hull_box"] = {{"min", vec(first_hull_box_.min)}, {"max", vec(first_hull_box_.max)}};
  f.render = counters_.Snapshot("render", true);
  f.reference_frames = assembler_.reference_frames();
  f.framesets_complete = assembler_.framesets_complete();
  return f;
}

nlohmann::json RenderController::StatsJson() const { return report_.StatsJson(Facts()); }

LatencyBudget RenderController::Budget() const { return report_.Budget(counters_.Snapshot("render", true)); }

std::string RenderController::Table() const { return report_.Table(Facts()); }

}  // namespace hullpipe::nodes
