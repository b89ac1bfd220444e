#include "hullpipe/nodes/capture_controller.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe::nodes {

void CaptureOptions::Check() const {
  if (frames < 0) throw std::invalid_argument("--frames must be >= 0");
  if (!(fps == 0 || (std::isfinite(fps) && fps > 0 && fps <= 1000)))
    throw std::invalid_argument("--fps must be in (0, 1000] (0: the source's rate)");
  if (!(image_scale >= 0.05 && image_scale <= 1.0)) throw std::invalid_argument("--image-scale must be in [0.05, 1]");
  if (start_ns < 0) throw std::invalid_argument("--start-time must be >= 0 (ns since the Unix epoch; 0: none)");
  if (!(max_lag_s > 0 && max_lag_s <= 60)) throw std::invalid_argument("--max-lag must be in (0, 60] seconds");
  if (!(timeline_window_s >= 1 && timeline_window_s <= 86400))
    throw std::invalid_argument("--timeline-window must be in [1, 86400] seconds");
  if (threads < 0 || threads > 256)
    throw std::invalid_argument("--threads must be in [0, 256] (0: the machine's cores)");
  if (!(camera_pose_hold_s > 0 && camera_pose_hold_s <= 1))
    throw std::invalid_argument("--camera-pose-hold must be in (0, 1] seconds");
}

CaptureController::CaptureController(CaptureOptions options, const Clock& clock, RigSource& source,
                                     CaptureSink& sink)
    : o_((options.Check(), options)), clock_(clock), source_(source), sink_(sink), counters_(clock) {
  rate_ = o_.fps > 0 ? o_.fps : source_.fps();
  if (!(std::isfinite(rate_) && rate_ > 0 && rate_ <= 1000))
    throw std::invalid_argument("the source's frame rate is " + std::to_string(rate_) + ": give --fps");
  last_seq_.assign(source_.cameras().size(), 0);
  start_ns_ = o_.start_ns;
  const std::vector<bool> by_topic = source_.tracked_by_topic();
  for (size_t i = 0; i < by_topic.size() && i < source_.cameras().size(); ++i)
    if (by_topic[i]) live_poses_.emplace(uint32_t(source_.cameras()[i].id), LivePoseTrack(o_.camera_pose_hold_s));
}

void CaptureController::OnCameraPose(uint32_t camera_id, int64_t stamp_ns, const Rigid3d& world_from_camera) {
  const auto it = live_poses_.find(camera_id);
  if (it == live_poses_.end()) return;  // not a camera of this node posed live
  const std::string why = it->second.Add(stamp_ns, world_from_camera);
  if (why.empty()) return;
  counters_.Rejected();
  if (pose_said_.size() < 64 && pose_said_.insert("sample " + std::to_string(camera_id)).second)
    spdlog::warn("a CameraPose of camera {} refused: {} (said once per camera; counted)", camera_id, why);
}

void CaptureController::PublishCalibration() {
  for (const auto& c : source_.cameras()) sink_.PublishCameraInfo(c, source_.workspace());
}

void CaptureController::OnTimeline(int64_t start_ns, double fps) {
  if (o_.fast || o_.start_ns != 0) return;  // unpaced, or told by the launcher
  const double from_now_s = double(start_ns) * 1e-9 - double(clock_.WallNs()) * 1e-9;
  if (!(std::abs(from_now_s) <= o_.timeline_window_s)) {
    if (timelines_refused_++ == 0)
      spdlog::warn("a capture timeline starting {:.6g} s {} now was announced on the domain: refused (beyond "
                   "--timeline-window {:g} s; a peer's clock is wrong, or the sample is not a run's); counted",
                   std::abs(from_now_s), from_now_s < 0 ? "before" : "after", o_.timeline_window_s);
    return;
  }
  if (!(std::abs(fps - rate_) <= 1e-6 * rate_)) {
    spdlog::warn("a capture timeline at {:.3f} fps was announced; this node runs at {:.3f} fps: ignored", fps, rate_);
    return;
  }
  if (start_ns_ != 0 && start_ns >= start_ns_) return;
  if (started_) {
    spdlog::info("adopting an earlier capture timeline ({:.3f} s earlier)", double(start_ns_ - start_ns) * 1e-9);
    rejoin_ = true;  // at the frame due on it now, as when joining late
  }
  start_ns_ = start_ns;
}

void CaptureController::Start() {
  if (start_ns_ == 0) start_ns_ = clock_.WallNs();
  // Every node announces the timeline it runs on, so it outlives the first node.
  if (!o_.fast) sink_.AnnounceTimeline(start_ns_, rate_);
  started_ = true;
}

bool CaptureController::CatchUp(double lag_s, const char* why) {
  auto due_now = [&] { return int64_t(std::floor(double(clock_.WallNs() - start_ns_) * 1e-9 * rate_)); };
  // Behind by more than the lag, and by two frames at least (at low rates a
  // fraction of a frame is no lag).
  if (due_now() - index_ <= std::max<int64_t>(int64_t(lag_s * rate_), lag_s > 0 ? 2 : 0)) return true;
  if (lag_s > 0 && !behind_said_ && frame_s_ > 0) {
    // Behind the timeline (not joining it): said once, with what would keep up.
    behind_said_ = true;
    // How much of a file's input that skips, where the files say how long they are.
    int64_t total = source_.frame_count();
    if (o_.frames > 0) total = total > 0 ? std::min(total, o_.frames) : o_.frames;
    std::string share;
    if (total > 0 && !o_.loop) {
      const double kept = std::min(1.0, 1.0 / (frame_s_ * rate_));
      const int64_t skipped = total - int64_t(std::ceil(double(total) * kept));
      share = " This run would skip about " + std::to_string(skipped) + " of its " + std::to_string(total) +
              " frames" + (kept < 0.5 ? " (most of its input)." : ".");
    }
    spdlog::warn("cannot keep the timeline's {:.1f} fps: a frame takes {:.0f} ms to read, segment and publish here "
                 "({:.1f} fps); frames are skipped to stay on it (counted as dropped).{} Pace the run at what the "
                 "machine does (capture_node or hullpipe_launch --fps {:.1f}), or give it fewer or smaller cameras",
                 rate_, frame_s_ * 1e3, 1.0 / frame_s_, share, std::max(0.1, 0.9 / frame_s_));
  }
  if (lag_s > 0 && behind_said_)
    spdlog::debug("{}: skipping frames {}..{} to the frame due now", why, index_ + 1, due_now());
  else
    spdlog::info("{}: skipping frames {}..{} to the frame due now", why, index_ + 1, due_now());
  // (Skipping takes time too: the frame due is asked again after each.) A
  // looping input of known length skips whole passes without reading them,
  // and skipping yields after kMaxWaitS so a stop request is seen.
  const double t0 = clock_.Now();
  const int64_t length = o_.loop ? source_.frame_count() : 0;
  catching_up_ = false;
  while (index_ < due_now()) {
    if (length > 0 && due_now() - index_ > 2 * length && index_ % length == 0) {
      const int64_t passes = (due_now() - index_) / length - 1;
      if (published_ > 0) counters_.Dropped(uint64_t(passes * length));
      index_ += passes * length;
      continue;
    }
    if (!source_.Skip()) {
      if (AtEnd()) continue;
      return false;
    }
    if (published_ > 0) counters_.Dropped();
    ++index_;
    if (clock_.Now() - t0 > kMaxWaitS) {
      catching_up_ = true;
      return true;
    }
  }
  return true;
}

namespace {
// Bytes of one frame's images, raw, at image_scale (ScaledImageSize: as cv::resize makes them).
double FrameImageBytes(const std::vector<Camera>& cameras, double image_scale) {
  double bytes = 0;
  for (const Camera& c : cameras) bytes += 3.0 * ScaledImageSize(cv::Size(c.width, c.height), image_scale).area();
  return bytes;
}
}  // namespace

int ImageJpegQuality(int requested, const std::vector<Camera>& cameras, double image_scale) {
  if (requested >= 0) return requested;
  return FrameImageBytes(cameras, image_scale) > kAutoJpegAboveBytes ? kAutoJpegQuality : 0;
}

cv::Size ScaledImageSize(cv::Size size, double scale) {
  if (scale >= 1.0) return size;
  return {cv::saturate_cast<int>(size.width * scale), cv::saturate_cast<int>(size.height * scale)};
}

cv::Mat ScaledImageRegion(const cv::Mat& image, double scale, const cv::Rect& region) {
  const cv::Size whole = ScaledImageSize(image.size(), scale);
  const cv::Rect r = region & cv::Rect(cv::Point(0, 0), whole);
  if (r.area() == 0) return {};
  if (scale >= 1.0) return image(r);
  // INTER_AREA at a whole factor k averages each k x k block on its own (its
  // fast path), so the region's blocks give the whole image's pixels there.
  const int k = int(std::lround(1.0 / scale));
  if (k >= 2 && 1.0 / scale == double(k) && image.cols == whole.width * k && image.rows == whole.height * k) {
    cv::Mat out;
    cv::resize(image(cv::Rect(r.x * k, r.y * k, r.width * k, r.height * k)), out, r.size(), 0, 0, cv::INTER_AREA);
    return out;
  }
  cv::Mat scaled;
  cv::resize(image, scaled, cv::Size(), scale, scale, cv::INTER_AREA);
  return scaled(r);
}

bool ImageRegions(const std::string& requested, const std::vector<Camera>& cameras, double image_scale) {
  if (requested == "object") return true;
  if (requested == "whole") return false;
  if (requested == "auto") return FrameImageBytes(cameras, image_scale) > kAutoJpegAboveBytes;
  throw std::invalid_argument("--image-region must be whole, object or auto, not '" + requested + "'");
}

int CaptureController::PublishThreads() const { return ThreadsOrCores(o_.threads); }

bool CaptureController::AtEnd() {
  const std::string why = source_.IncompleteEnd();
  if (!why.empty()) incomplete_ = why;  // the node's last line says it, once
  const bool rewound = o_.loop && source_.Rewind();
  if (rewound && !why.empty()) spdlog::warn("input ended early ({}); --loop: from the start again", why);
  return rewound;
}

bool CaptureController::Step() {
  if (!started_) Start();
  const bool paced = !o_.fast && !source_.live();
  // Paced nodes count frames on the timeline, so that every node of a run stops
  // at the same frame however late it joined.
  while (o_.frames <= 0 || (paced ? index_ : published_) < o_.frames) {
    if (paced) {
      // Join the timeline at the frame due now; later, skip only when far behind.
      const bool join = published_ == 0 || rejoin_;
      rejoin_ = false;
      if (!CatchUp(join ? 0.0 : o_.max_lag_s, join ? "joining the capture timeline" : "behind the capture timeline")) {
        spdlog::info("end of input after {} frames", published_);
        return false;
      }
      if (catching_up_) {  // still skipping: back to the node's loop (it checks for a stop), then on
        rejoin_ = join;
        return true;
      }
      // Wait for the frame's due time in slices, so a stop request is seen
      // within kMaxWaitS even when the timeline starts in the future.
      const int64_t wait_ns = DueNs(index_) - clock_.WallNs();
      if (double(wait_ns) * 1e-9 > kMaxWaitS) {
        clock_.SleepUntil(clock_.Now() + kMaxWaitS);
        return true;
      }
      if (wait_ns > 0) clock_.SleepUntil(clock_.Now() + double(wait_ns) * 1e-9);
    }
    // Paced frames carry their due time: equal for every camera of one instant,
    // in every process. Unpaced ones carry the time they were read.
    const int64_t t_ns = paced ? DueNs(index_) : clock_.WallNs();
    // The budget's capture stages (docs/latency.md): lag (due time to read),
    // read, segment, encode, publish.
    const double lag_ms = paced ? double(clock_.WallNs() - t_ns) * 1e-6 : 0.0;
    const double t_read = clock_.Now();
    const bool ok = source_.Next(&frame_);
    const double next_ms = (clock_.Now() - t_read) * 1e3;
    for (const auto& e : frame_.errors) {
      spdlog::warn("{}", e);
      if (ok) counters_.Rejected();  // a skipped frame; the end of input is no rejection
    }
    if (!ok) {
      if (AtEnd()) continue;
      spdlog::info("end of input after {} frames", published_);
      return false;
    }
    bool any = false;
    for (const auto& m : frame_.maps) any = any || !m.empty();
    if (source_.live() && !any) return true;  // no frame yet: ask again
    counters_.FrameIn();
    if (paced) counters_.Stage("lag", lag_ms);
    if (frame_.read_ms.empty()) {
      counters_.Stage("read", next_ms);  // a source that does not split its time
    } else {
      counters_.Stage("read", *std::max_element(frame_.read_ms.begin(), frame_.read_ms.end()));
      counters_.Stage("segment", *std::max_element(frame_.segment_ms.begin(), frame_.segment_ms.end()));
    }
    {
      const uint32_t camera_count = uint32_t(source_.rig_camera_count());
      const size_t n = source_.cameras().size();
      // Numbering first (in camera order: it carries state from frame to frame),
      // then each camera scaled, encoded and written, on several cores where the
      // sink allows it: one core did all of it for 20 HD cameras.
      std::vector<int64_t> stamps(n, t_ns);
      std::vector<uint64_t> seqs(n, 0);
      std::vector<std::optional<Rigid3d>> live_pose(n);  // cam_from_world of the cameras posed live
      if (!live_poses_.empty() && pose_refresh_) pose_refresh_();
      for (size_t i = 0; i < n; ++i) {
        if (frame_.maps[i].empty()) continue;
        int64_t stamp = t_ns;
        uint64_t seq = uint64_t(index_ + 1);
        if (i < frame_.capture_ns.size() && frame_.capture_ns[i] != 0) {
          // A live frame: its own stamp, numbered by its place on the timeline
          // (strictly increasing per camera).
          stamp = frame_.capture_ns[i];
          seq = uint64_t(std::max<int64_t>(1, std::llround(double(stamp - start_ns_) * 1e-9 * rate_) + 1));
        }
        seq = std::max(seq, last_seq_[i] + 1);
        last_seq_[i] = seq;
        stamps[i] = stamp;
        seqs[i] = seq;
        const auto live = live_poses_.find(uint32_t(source_.cameras()[i].id));
        if (live == live_poses_.end()) continue;
        if (const auto world_from_camera = live->second.At(stamp)) {
          live_pose[i] = world_from_camera->Inverse();
          continue;
        }
        // No tracker sample near the frame: its map would be carved at a
        // wrong pose. Not published (the frameset waits or drops), counted.
        ++unposed_frames_;
        counters_.Rejected();
        if (pose_said_.insert("unposed " + std::to_string(live->first)).second)
          spdlog::warn("camera {} (tracked: topic): no CameraPose within --camera-pose-hold {:g} s of its frame (the "
                       "nearest {:.3g} s away): frame not published (said once; counted)",
                       live->first, o_.camera_pose_hold_s, live->second.DistanceS(stamp));
        frame_.maps[i].release();
      }
      std::vector<PublishTimes> spent(n);
      auto publish = [&](size_t i) {
        if (frame_.maps[i].empty()) return;
        const double t_scale = clock_.Now();
        cv::Mat img = frame_.images[i];
        std::optional<ImageRegion> region;
        if (o_.image_regions) {
          // Only the region is scaled (and sent): texturing reads nothing else.
          const cv::Size whole = ScaledImageSize(img.size(), o_.image_scale);
          region = ImageRegion{
              ImageRectAroundObjectPixels(cv::boundingRect(frame_.maps[i]), frame_.maps[i].size(), whole), whole};
          img = ScaledImageRegion(img, o_.image_scale, region->rect);
        } else if (o_.image_scale < 1.0) {
          cv::resize(img, img, cv::Size(), o_.image_scale, o_.image_scale, cv::INTER_AREA);
        }
        spent[i].encode_ms += (clock_.Now() - t_scale) * 1e3;
        const Rigid3d* pose = live_pose[i]                                     ? &*live_pose[i]
                              : i < frame_.poses.size() && frame_.poses[i] ? &*frame_.poses[i]
                                                                           : nullptr;
        const FrameStamp stamp{uint32_t(source_.cameras()[i].id), seqs[i], stamps[i], frame_.time_s};
        const PublishTimes t = sink_.PublishFrame({.stamp = stamp, .camera_count = camera_count,
                                                   .map = frame_.maps[i], .image = img, .image_region = region,
                                                   .cam_from_world = pose});
        spent[i].encode_ms += t.encode_ms;
        spent[i].write_ms += t.write_ms;
      };
      const int threads = sink_.Concurrent() ? PublishThreads() : 1;
      if (threads > 1) {
        ForEachRowDynamic(int(n), threads, [&](int i, int) { publish(size_t(i)); });
      } else {
        for (size_t i = 0; i < n; ++i) publish(i);
      }
      // The stages as the frame's critical path: the slowest camera with
      // several threads, the sum with one.
      PublishTimes total;
      for (const PublishTimes& t : spent) {
        total.encode_ms = threads > 1 ? std::max(total.encode_ms, t.encode_ms) : total.encode_ms + t.encode_ms;
        total.write_ms = threads > 1 ? std::max(total.write_ms, t.write_ms) : total.write_ms + t.write_ms;
      }
      counters_.Stage("encode", total.encode_ms);
      counters_.Stage("publish", total.write_ms);
    }
    ++index_;
    ++published_;
    // What a frame costs here (read to published), smoothed: the rate this
    // machine keeps, for the line said when the node falls behind.
    const double took = clock_.Now() - t_read;
    frame_s_ = frame_s_ > 0 ? 0.8 * frame_s_ + 0.2 * took : took;
    int64_t latency_from = t_ns;
    for (const int64_t c : frame_.capture_ns)
      if (c != 0) latency_from = c;  // a live frame: from its own stamp
    counters_.FrameOut(latency_from);
    return true;
  }
  return false;
}

}  // namespace hullpipe::nodes
