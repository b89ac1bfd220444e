#include "hullpipe/reconstruction/frameset.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

namespace hullpipe {

FramesetAssembler::FramesetAssembler(size_t max_pending, bool want_images)
    : max_pending_(std::max<size_t>(1, max_pending)), want_images_(want_images) {}

namespace {

// What differs between two calibrations of one camera ("" when none does).
std::string CalibrationChange(const Camera& was, const Camera& now) {
  std::string what;
  auto add = [&](const std::string& s) { what += (what.empty() ? "" : ", ") + s; };
  if (was.width != now.width || was.height != now.height)
    add("size " + std::to_string(was.width) + "x" + std::to_string(was.height) + " -> " + std::to_string(now.width) +
        "x" + std::to_string(now.height));
  if (was.fx != now.fx || was.fy != now.fy || was.cx != now.cx || was.cy != now.cy || was.skew != now.skew)
    add("intrinsics K");
  if (was.distortion != now.distortion) add("distortion");
  if (was.cam_from_world.rotation != now.cam_from_world.rotation ||
      was.cam_from_world.translation != now.cam_from_world.translation) {
    const double moved = (was.Center() - now.Center()).norm();
    const Eigen::AngleAxisd turn(now.cam_from_world.rotation * was.cam_from_world.rotation.transpose());
    char text[96];
    std::snprintf(text, sizeof text, "pose (centre moved %.4g m, turned %.3g deg)", moved,
                  std::abs(turn.angle()) * 180.0 / 3.14159265358979323846);
    add(text);
  }
  return what;
}

}  // namespace

bool FramesetAssembler::SetWorkspace(const Aabb& workspace, std::string* why) {
  if (workspace_.empty() || (workspace_.min == workspace.min && workspace_.max == workspace.max)) {
    workspace_ = workspace;
    return true;
  }
  ++calibrations_refused_;
  if (why) *why = "a CameraInfo with another workspace than the run's first: refused (a changed rig is a new run)";
  return false;
}

bool FramesetAssembler::SetCamera(const Camera& camera, std::string* why) {
  if (const auto known = cameras_.find(camera.id); known != cameras_.end()) {
    const std::string change = CalibrationChange(known->second, camera);
    if (change.empty()) return true;
    ++calibrations_refused_;
    if (why)
      *why = "camera " + std::to_string(camera.id) + ": a CameraInfo that changes its calibration mid-run (" + change +
             "): refused, the first one holds (a recalibrated rig is a new run)";
    return false;
  }
  Cam& cam = cams_[camera.id];
  // Samples of this camera that left the history before its first CameraInfo were
  // a start-up race (DDS does not order samples across topics), not bad input:
  // dropped, not rejected.
  if (!cameras_.count(camera.id) && cam.evicted_uncalibrated) {
    rejected_ -= cam.evicted_uncalibrated;
    dropped_ += cam.evicted_uncalibrated;
    cam.evicted_uncalibrated = 0;
  }
  cameras_[camera.id] = camera;
  // Check maps that arrived before this calibration.
  for (Sample& s : cam.samples)
    if (!s.map.empty() && (s.map.cols != camera.width || s.map.rows != camera.height)) {
      ++rejected_;
      s.map = cv::Mat();
    }
  return true;
}

bool FramesetAssembler::Reject(std::string* why, std::string text) {
  ++rejected_;
  if (why) *why = std::move(text);
  return false;
}

double FramesetAssembler::tolerance_s() const {
  if (tolerance_s_ > 0) return tolerance_s_;
  double slowest = 0;
  for (const auto& [id, cam] : cams_)
    if (cam.any && cameras_.count(id)) slowest = std::max(slowest, PeriodS(cam));
  return 0.5 * (slowest > 0 ? slowest : kDefaultPeriodS);
}

int FramesetAssembler::ReferenceId() const {
  for (const auto& [id, cam] : cams_)
    if (cam.any && cameras_.count(id)) return id;
  return -1;
}

void FramesetAssembler::RemoveSample(int camera_id, Cam& cam, std::deque<Sample>::iterator it) {
  if (!cameras_.count(camera_id)) {
    ++rejected_;  // no CameraInfo (yet): rejected unless one comes later
    ++cam.evicted_uncalibrated;
  } else if (!it->partnered && camera_id != ReferenceId()) {
    ++cam.unpartnered;  // reference samples are classified by PassOver
  }
  cam.newest_removed_t_ns = std::max(cam.newest_removed_t_ns, it->t_ns);
  cam.samples.erase(it);
}

void FramesetAssembler::ForgetCamera(int camera_id, Cam& cam, const std::string& reason) {
  spdlog::warn("camera {}: {}; its {} pending frame(s) are dropped", camera_id, reason, cam.samples.size());
  dropped_ += cam.samples.size();
  cam.samples.clear();
  cam.steps_ns.clear();
  cam.period_s = 0;
  cam.any = false;
  cam.newest_seq = 0;
  ++cam.restarts;
}

FramesetAssembler::Sample* FramesetAssembler::Slot(int camera_id, uint64_t seq, int64_t t_ns, uint64_t source_id,
                                                   std::string* why) {
  Cam& cam = cams_[camera_id];
  const bool is_reference = camera_id == ReferenceId();
  if (source_id != 0 && cam.source_id != 0 && source_id != cam.source_id && cam.any) {
    ForgetCamera(camera_id, cam, "a new sender (its capture node restarted)");
    if (is_reference && seq <= taken_up_to_) {
      ++restarts_;  // frameset ids start over with the reference camera's numbers
      taken_up_to_ = 0;
    }
  }
  if (source_id != 0) cam.source_id = source_id;
  if (cam.any && seq <= cam.newest_seq) {
    for (Sample& s : cam.samples)
      if (s.seq == seq) return &s;
    if (seq + kRestartGap < cam.newest_seq) {
      ForgetCamera(camera_id, cam, "frame numbers started over (its capture source restarted)");
      if (is_reference) {
        ++restarts_;
        taken_up_to_ = 0;
      }
    } else {
      ++dropped_;
      if (why) *why = "camera " + std::to_string(camera_id) + " frame " + std::to_string(seq) + " arrived late";
      return nullptr;
    }
  }
  if (is_reference && seq <= taken_up_to_) {
    ++dropped_;
    if (why) *why = "frame " + std::to_string(seq) + " arrived after a newer frameset was used";
    return nullptr;
  }
  if (cam.any) {
    const int64_t step = t_ns - cam.newest_t_ns;
    const double gap_s = double(step) * 1e-9;
    if (gap_s > std::max(kPausePeriods * PeriodS(cam), kPauseMinS)) {
      // Said once per camera; every pause is counted (SkewReports, the
      // end-of-run table's "pauses"): a rig that falls behind pauses every
      // frame, and a line each buried the log (580 lines in a 30-frame run).
      if (++cam.pauses == 1)
        spdlog::warn("camera {}: no frame for {:.2f} s of capture time (frames {}..{}); resumed (further pauses of "
                     "this camera are counted in the end-of-run table, not logged)",
                     camera_id, gap_s, cam.newest_seq, seq);
    } else if (step > 0) {
      // The period is measured here, once per frame, not in every evaluation.
      cam.steps_ns.push_back(step);
      while (cam.steps_ns.size() > 15) cam.steps_ns.pop_front();
      std::vector<int64_t> s(cam.steps_ns.begin(), cam.steps_ns.end());
      std::nth_element(s.begin(), s.begin() + s.size() / 2, s.end());
      cam.period_s = double(s[s.size() / 2]) * 1e-9;
    }
  }
  if (!cam.any) cam.first_t_ns = t_ns;
  cam.any = true;
  cam.newest_seq = seq;
  cam.newest_t_ns = t_ns;
  ++cam.frames;
  Sample s;
  s.seq = seq;
  s.t_ns = t_ns;
  cam.samples.push_back(std::move(s));
  // Latest wins: the history is bounded.
  const int reference = ReferenceId();
  while (cam.samples.size() > max_pending_ + 2) {
    if (camera_id == reference && cam.samples.front().seq > taken_up_to_) PassOver(cam.samples.front());
    RemoveSample(camera_id, cam, cam.samples.begin());
  }
  return &cam.samples.back();
}

bool FramesetAssembler::CheckMapSize(int camera_id, int width, int height, std::string* why) {
  const auto cam = cameras_.find(camera_id);
  if (cam != cameras_.end() && (width != cam->second.width || height != cam->second.height))
    return Reject(why, "map of camera " + std::to_string(camera_id) + " is " + std::to_string(width) + "x" +
                           std::to_string(height) + ", calibration says " + std::to_string(cam->second.width) +
                           "x" + std::to_string(cam->second.height));
  return true;
}

bool FramesetAssembler::CheckImageSize(int camera_id, int width, int height, std::string* why) {
  const auto cam = cameras_.find(camera_id);
  if (cam != cameras_.end() && (width > cam->second.width || height > cam->second.height))
    return Reject(why, "image of camera " + std::to_string(camera_id) + " is " + std::to_string(width) + "x" +
                           std::to_string(height) + ", larger than its calibration's " +
                           std::to_string(cam->second.width) + "x" + std::to_string(cam->second.height));
  return true;
}

bool FramesetAssembler::AddMap(MapSample m, std::string* why) {
  const int camera_id = m.camera_id;
  if (m.map.type() != CV_8UC1 || m.map.empty())
    return Reject(why, "map of camera " + std::to_string(camera_id) + " is not a CV_8UC1 image");
  if (!CheckMapSize(camera_id, m.map.cols, m.map.rows, why)) return false;
  if (m.camera_count < 1 || m.camera_count > 64)
    return Reject(why, "map of camera " + std::to_string(camera_id) + " states " +
                           std::to_string(m.camera_count) + " cameras");
  if (m.object_rect && (*m.object_rect & cv::Rect(0, 0, m.map.cols, m.map.rows)) != *m.object_rect)
    return Reject(why, "map of camera " + std::to_string(camera_id) + ": its object rectangle is outside the map");
  expected_ = m.camera_count;
  const int64_t t = m.capture_time_ns;
  Sample* s = Slot(camera_id, m.seq, t, m.source_id, why);
  if (!s) return false;
  s->t_ns = t;  // the map's capture time is authoritative
  s->source_time_s = m.source_time_s;
  s->map = std::move(m.map);
  s->object_rect = m.object_rect;
  s->cam_from_world = m.cam_from_world;
  s->map_arrival_ns = m.arrival_ns;
  if (m.arrival_ns != 0) CheckClock(camera_id, cams_[camera_id], t, m.arrival_ns);
  return true;
}

void FramesetAssembler::CheckClock(int camera_id, Cam& cam, int64_t t, int64_t arrival_ns) {
  cam.delays_ns.push_back(arrival_ns - t);
  while (cam.delays_ns.size() > 31) cam.delays_ns.pop_front();
  if (cam.delays_ns.size() < 5) return;
  // The least delay of the recent frames: queueing, and a node that polls late,
  // only ever add delay (the minimum filter of clock-offset estimation, as NTP's).
  cam.delay_least_ns = *std::min_element(cam.delays_ns.begin(), cam.delays_ns.end());
  // The smallest delay of the cameras that have enough samples is the level.
  int64_t level = INT64_MAX;
  for (const auto& [id, c] : cams_)
    if (c.delays_ns.size() >= 5) level = std::min(level, c.delay_least_ns);
  const double tol = tolerance_s();
  const double ahead_s = -double(cam.delay_least_ns) * 1e-9;                // stamped in the future
  const double behind_s = double(cam.delay_least_ns - level) * 1e-9;        // later than the others
  const bool off = ahead_s > tol || behind_s > std::max(tol, kClockCheckMinS);
  if (off && !cam.clock_off) {
    ++cam.clock_offsets;
    spdlog::warn(
        "camera {}: its capture times are {:.1f} ms {} (least arrival - capture time {:.1f} ms, the other cameras' "
        "{:.1f} ms): its host's clock or its latency setting is off — is the host synchronised (PTP or chrony)?",
        camera_id, ahead_s > tol ? ahead_s * 1e3 : behind_s * 1e3,
        ahead_s > tol ? "in the future of this host's clock" : "behind the other cameras'",
        double(cam.delay_least_ns) * 1e-6, double(level) * 1e-6);
  }
  cam.clock_off = off;
}

bool FramesetAssembler::AddImage(ImageSample sample, std::string* why) {
  if (sample.image.empty() || sample.image.type() != CV_8UC3)
    return Reject(why, "image of camera " + std::to_string(sample.camera_id) + " is not BGR8");
  Sample* s = Slot(sample.camera_id, sample.seq, sample.capture_time_ns, sample.source_id, why);
  if (!s) return false;
  s->image = std::move(sample.image);
  s->image_arrival_ns = sample.arrival_ns;
  return true;
}

FramesetAssembler::Evaluation FramesetAssembler::Evaluate(const Sample& ref) const {
  Evaluation e;
  const int reference = ReferenceId();
  int cameras = 0;
  for (const auto& [id, cam] : cams_)
    if (cam.any && cameras_.count(id)) ++cameras;
  bool missing = cameras < expected_ || expected_ < 1;
  const auto usable = [&](const Sample& s) { return !s.map.empty() && (!want_images_ || !s.image.empty()); };
  if (!usable(ref)) missing = true;
  e.members[reference] = &ref;
  const double tol_ns = tolerance_s() * 1e9;
  for (const auto& [id, cam] : cams_) {
    if (id == reference || !cam.any || !cameras_.count(id)) continue;
    // The first sample at or after t_ref decides: the nearest is it or the one before.
    auto after = std::find_if(cam.samples.begin(), cam.samples.end(),
                              [&](const Sample& s) { return s.t_ns >= ref.t_ns; });
    if (after == cam.samples.end()) {
      missing = true;  // not yet decided: a nearer frame may still come
      continue;
    }
    const Sample* chosen = &*after;
    if (after != cam.samples.begin()) {
      const Sample& before = *std::prev(after);
      if (ref.t_ns - before.t_ns <= after->t_ns - ref.t_ns) chosen = &before;
    } else if (cam.newest_removed_t_ns >= ref.t_ns - (after->t_ns - ref.t_ns)) {
      missing = true;  // the nearest may have left the history: undecidable
      continue;
    } else if (cam.newest_removed_t_ns == INT64_MIN && cam.restarts == 0 &&
               double(after->t_ns - ref.t_ns) > tol_ns) {
      missing = true;  // the camera started after t_ref: no partner, not skew
      continue;
    }
    if (std::abs(double(chosen->t_ns - ref.t_ns)) > tol_ns) {
      e.out_of_tolerance.push_back(id);
      if (after != cam.samples.begin() &&
          double(after->t_ns - std::prev(after)->t_ns) * 1e-9 <= kPausePeriods * PeriodS(cam))
        e.running.push_back(id);
      continue;
    }
    if (!usable(*chosen)) missing = true;
    e.members[id] = chosen;
  }
  e.state = !e.out_of_tolerance.empty() ? State::kSkewed : missing ? State::kIncomplete : State::kComplete;
  return e;
}

void FramesetAssembler::PassOver(const Sample& ref) {
  const Evaluation e = Evaluate(ref);
  ++dropped_;
  ++reference_frames_;
  if (e.state == State::kComplete) {
    ++framesets_complete_;
    for (const auto& [id, s] : e.members) const_cast<Sample*>(s)->partnered = true;
  } else if (e.state == State::kSkewed) {
    ++dropped_for_skew_;
    for (const auto& [id, s] : e.members) cams_[id].out_of_tolerance_run = 0;
    for (int id : e.running) {
      Cam& cam = cams_[id];
      if (++cam.out_of_tolerance_run == kOffsetFramesets) {
        ++cam.clock_offsets;
        spdlog::warn(
            "camera {}: no frame within {:.1f} ms of camera {}'s in {} framesets in a row: its clock (or its "
            "latency setting) is off by more than the tolerance — is its host synchronised (PTP or chrony)?",
            id, tolerance_s() * 1e3, ReferenceId(), kOffsetFramesets);
      }
    }
  }
}

std::optional<uint64_t> FramesetAssembler::NewestComplete() const {
  const int reference = ReferenceId();
  if (reference < 0) return std::nullopt;
  const Cam& rc = cams_.at(reference);
  for (auto it = rc.samples.rbegin(); it != rc.samples.rend(); ++it) {
    if (it->seq <= taken_up_to_) break;
    if (Evaluate(*it).state == State::kComplete) return it->seq;
  }
  return std::nullopt;
}

std::optional<uint64_t> FramesetAssembler::OldestComplete() const {
  const int reference = ReferenceId();
  if (reference < 0) return std::nullopt;
  for (const Sample& s : cams_.at(reference).samples)
    if (s.seq > taken_up_to_ && Evaluate(s).state == State::kComplete) return s.seq;
  return std::nullopt;
}

bool FramesetAssembler::IsComplete(uint64_t seq) const {
  const int reference = ReferenceId();
  if (reference < 0 || seq <= taken_up_to_) return false;
  for (const Sample& s : cams_.at(reference).samples)
    if (s.seq == seq) return Evaluate(s).state == State::kComplete;
  return false;
}

std::optional<Frameset> FramesetAssembler::Take(uint64_t seq) {
  const int reference = ReferenceId();
  if (reference < 0 || seq <= taken_up_to_) return std::nullopt;
  Cam& rc = cams_.at(reference);
  auto it = std::find_if(rc.samples.begin(), rc.samples.end(), [&](const Sample& s) { return s.seq == seq; });
  if (it == rc.samples.end()) return std::nullopt;
  const Evaluation e = Evaluate(*it);
  if (e.state != State::kComplete) return std::nullopt;
  Frameset f;
  f.seq = seq;
  f.capture_time_ns = it->t_ns;
  f.source_time_s = it->source_time_s;
  for (const auto& [id, s] : e.members) {
    const_cast<Sample*>(s)->partnered = true;
    Camera camera = cameras_.at(id);
    if (s->cam_from_world) camera.cam_from_world = *s->cam_from_world;  // a tracked camera's pose of this frame
    f.maps.push_back({camera, s->map, s->object_rect});
    if (!s->image.empty()) f.images.push_back({camera, s->image});
    f.skew_ns.push_back(s->t_ns - it->t_ns);
    f.last_arrival_ns = std::max({f.last_arrival_ns, s->map_arrival_ns, want_images_ ? s->image_arrival_ns : 0});
    Cam& cam = cams_[id];
    cam.skew_ms.Add(std::abs(double(s->t_ns - it->t_ns)) * 1e-6);
    cam.out_of_tolerance_run = 0;
  }
  // Every older reference sample is passed over for good.
  while (rc.samples.begin()->seq != seq) {
    if (rc.samples.front().seq > taken_up_to_) PassOver(rc.samples.front());
    RemoveSample(reference, rc, rc.samples.begin());
  }
  taken_up_to_ = seq;
  taken_time_ns_ = f.capture_time_ns;
  ++reference_frames_;
  ++framesets_complete_;
  rc.samples.pop_front();
  Prune();
  return f;
}

void FramesetAssembler::Prune() {
  // A sample older than a camera's newest at or before the last reference time
  // can never be the nearest to a later reference time.
  const int reference = ReferenceId();
  for (auto& [id, cam] : cams_) {
    if (id == reference) continue;
    // A camera without calibration is in no frameset: its samples up to the
    // reference time are rejected (dropped instead if its CameraInfo comes later).
    const bool calibrated = cameras_.count(id) > 0;
    while (!cam.samples.empty() && (calibrated ? cam.samples.size() >= 2 && cam.samples[1].t_ns <= taken_time_ns_
                                               : cam.samples.front().t_ns <= taken_time_ns_))
      RemoveSample(id, cam, cam.samples.begin());
  }
}

std::optional<Frameset> FramesetAssembler::TakeNewest() {
  const auto seq = NewestComplete();
  if (!seq) return std::nullopt;
  return Take(*seq);
}

std::optional<Frameset> FramesetAssembler::TakeOldest() {
  const auto seq = OldestComplete();
  if (!seq) return std::nullopt;
  return Take(*seq);
}

std::vector<CameraSkewReport> FramesetAssembler::SkewReports() const {
  std::vector<CameraSkewReport> out;
  for (const auto& [id, cam] : cams_) {
    if (!cameras_.count(id)) continue;
    CameraSkewReport r;
    r.camera_id = id;
    r.skew_ms_p50 = cam.skew_ms.Percentile(50);
    r.skew_ms_p95 = cam.skew_ms.Percentile(95);
    r.skew_ms_max = cam.skew_ms.Percentile(100);
    r.frames = cam.frames;
    r.unpartnered = cam.unpartnered;
    r.pauses = cam.pauses;
    r.restarts = cam.restarts;
    r.clock_offsets = cam.clock_offsets;
    r.period_ms = cam.period_s * 1e3;
    out.push_back(r);
  }
  return out;
}

std::vector<FramesetAssembler::EarlyEnd> FramesetAssembler::EndedEarly() const {
  int64_t newest = INT64_MIN, first = INT64_MAX;
  for (const auto& [id, cam] : cams_) {
    if (!cam.any || !cameras_.count(id)) continue;
    newest = std::max(newest, cam.newest_t_ns);
    first = std::min(first, cam.first_t_ns);
  }
  std::vector<EarlyEnd> out;
  if (newest == INT64_MIN) return out;
  const double span_s = double(newest - first) * 1e-9;
  for (const auto& [id, cam] : cameras_) {
    const auto it = cams_.find(id);
    const bool any = it != cams_.end() && it->second.any;
    const double lag_s = any ? double(newest - it->second.newest_t_ns) * 1e-9 : span_s;
    const double period = any ? PeriodS(it->second) : kDefaultPeriodS;
    if (!any || lag_s > std::max({kEarlyEndMinS, kEarlyEndPeriods * period, kEarlyEndFraction * span_s}))
      out.push_back({id, lag_s, any ? it->second.frames : 0});
  }
  return out;
}

Aabb FramesetAssembler::workspace() const {
  if (!workspace_.empty()) return workspace_;
  std::vector<Camera> cams;
  for (const auto& [id, c] : cameras_) cams.push_back(c);
  return DefaultWorkspace(cams);
}

}  // namespace hullpipe
