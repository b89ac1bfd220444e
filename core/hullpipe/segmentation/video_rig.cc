#include "hullpipe/segmentation/video_rig.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <optional>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/capture/camera_reader.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/util/image_file.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {
namespace {

class VideoRig final : public RigSource {
 public:
  VideoRig(const std::string& path, const VideoRigOptions& o) : options_(o) {
    o.segmentation.Check();
    const Rig rig = LoadRig(path);
    workspace_ = rig.workspace;
    rig_camera_count_ = int(rig.cameras.size());
    for (const auto& rc : rig.cameras) {
      if (!CameraSelected(o.camera_ids, rc.camera.id)) continue;
      Cam cam;
      cam.camera = rc.camera;
      cam.frames_spec = rc.frames;
      cam.masks_spec = rc.masks;
      cam.mask_format = rc;
      cam.latency_ns = int64_t(rc.latency_s * 1e9);
      if (!rc.tracked.empty() && !rc.tracked_by_topic()) cam.track = LoadPoseTrack(rc.tracked);
      cam.by_topic = rc.tracked_by_topic();
      cam.live = rc.live();
      if (cam.live && !rc.masks.empty())
        throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": a live camera cannot have masks");
      if (cam.live && !rc.tracked.empty() && !rc.tracked_by_topic())
        throw std::runtime_error("camera " + std::to_string(rc.camera.id) +
                                 ": key 'tracked': a pose log is keyed by source time and serves file sources; a "
                                 "live tracked camera takes its poses live ('tracked: topic')");
      if (rc.masks.empty()) cam.background_spec = rc.background;  // learnt below
      cams_.push_back(std::move(cam));
      cameras_.push_back(rc.camera);
    }
    if (cams_.empty()) throw std::runtime_error(path + ": none of the selected cameras is in the rig");
    live_ = cams_.front().live;
    for (const Cam& c : cams_)
      if (c.live != live_)
        throw std::runtime_error(path + ": the selected cameras mix live sources and files; run them in separate "
                                        "capture nodes (--cameras)");
    for (Cam& c : cams_) {
      if (!c.live && c.masks_spec.empty() && c.background_spec.empty())
        throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": no background and no masks");
    }
    // Files: every video opens (or the node ends naming it) before seconds of
    // background learning. Live cameras start streaming once the backgrounds
    // from files are ready.
    if (!live_) OpenAll();
    LearnFileBackgrounds();
    if (live_) OpenAll();
    for (Cam& c : cams_)
      if (c.live && c.background.empty()) LearnLiveBackground(c);
  }
  ~VideoRig() override {
    std::vector<LiveCameraReader*> readers;
    for (Cam& c : cams_)
      if (c.reader) readers.push_back(c.reader.get());
    LiveCameraReader::StopAll(readers);
  }
  bool live() const override { return live_; }
  int64_t frame_count() const override {
    if (live_) return 0;
    int64_t n = 0;
    for (const Cam& c : cams_) {
      const int64_t d = c.frames ? c.frames->declared_frames() : 0;
      if (d <= 0) return 0;
      n = n == 0 ? d : std::min(n, d);
    }
    return n;
  }
  bool Skip() override {
    if (live_) return false;
    // In parallel as Next: a grab decodes a video's frame (MJPG, MPEG-4), and
    // twenty of them in a row made each skipped frame cost more than a frame
    // period, so a node that fell behind fell further behind.
    const int alive = ForEachCameraAtOnce([&](size_t i) {
      Cam& c = cams_[i];
      if (c.ended) return false;
      if (!c.frames->Grab()) {
        c.ended = true;
        return false;
      }
      return true;  // (masks are read by number: nothing to skip)
    });
    if (!CheckEnds(alive)) return false;
    ++index_;
    return true;
  }
  std::string IncompleteEnd() const override { return incomplete_; }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  std::vector<bool> tracked_by_topic() const override {
    std::vector<bool> t;
    for (const Cam& c : cams_) t.push_back(c.by_topic);
    return t;
  }
  int rig_camera_count() const override { return rig_camera_count_; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return fps_; }

  bool Next(RigFrame* f) override {
    f->images.assign(cams_.size(), cv::Mat());
    f->maps.assign(cams_.size(), cv::Mat());
    f->capture_ns.assign(cams_.size(), 0);
    f->poses.assign(cams_.size(), std::nullopt);
    f->read_ms.assign(cams_.size(), 0.0);
    f->segment_ms.assign(cams_.size(), 0.0);
    f->errors.clear();
    f->time_s = double(index_) / fps_;
    for (size_t i = 0; i < cams_.size(); ++i)
      if (!cams_[i].track.empty()) f->poses[i] = cams_[i].track.At(f->time_s).Inverse();
    if (live_) return NextLive(f);
    // The cameras are read and segmented in parallel (one file each); errors are
    // collected per camera and reported in camera order.
    std::vector<std::vector<std::string>> errors(cams_.size());
    const int alive = ForEachCameraAtOnce([&](size_t i) { return ReadOne(i, f, &errors[i]); });
    for (auto& camera_errors : errors)
      for (auto& e : camera_errors) f->errors.push_back(std::move(e));
    if (!CheckEnds(alive)) return false;
    ++index_;
    return true;
  }

  bool Rewind() override {
    if (live_) return false;
    OpenAll();
    return true;
  }

 private:
  struct Cam {
    Camera camera;
    std::string frames_spec, masks_spec;
    std::string background_spec;  ///< Its background video or images (none with masks).
    std::unique_ptr<FileCameraReader> frames;  ///< A file camera's reader (live: reader).
    int mask_first = 0;      ///< Number of the first mask file (0..4, as OpenCV's image sequences).
    RigCamera mask_format;   ///< Its mask_threshold and mask_channel.
    BackgroundModel background;
    bool ended = false;
    bool live = false;
    int64_t latency_ns = 0;
    std::unique_ptr<LiveCameraReader> reader;
    PoseTrack track;  ///< A tracked camera's world_from_camera by source time.
    bool by_topic = false;  ///< Posed live by capture_node (RigSource::tracked_by_topic).
  };

  // Calls one_camera(i) for every camera, the cameras on up to the machine's
  // cores at once (one thread a camera at most); returns how many returned
  // true (the cameras still delivering). one_camera touches camera i only.
  template <class OneCamera>
  int ForEachCameraAtOnce(OneCamera&& one_camera) {
    std::vector<int> alive_of(cams_.size(), 0);
    const int threads = std::min(int(cams_.size()), ThreadsOrCores(0));
    ForEachRowBand(int(cams_.size()), threads, [&](int c0, int c1, int) {
      for (int ci = c0; ci < c1; ++ci) alive_of[size_t(ci)] = one_camera(size_t(ci)) ? 1 : 0;
    });
    int alive = 0;
    for (const int a : alive_of) alive += a;
    return alive;
  }

  // Reads and segments camera i's next frame into f (its own slots only).
  // Returns false when the camera has no frame left (ended now or before).
  bool ReadOne(size_t i, RigFrame* f, std::vector<std::string>* errors) {
    Cam& c = cams_[i];
    if (c.ended) return false;
    cv::Mat img;
    const double t_read = MonotonicSeconds();
    if (!c.frames->Read(&img)) {
      c.ended = true;  // CheckEnds says whether this is the input's end or a short camera
      return false;
    }
    if (img.type() != CV_8UC3 || img.cols != c.camera.width || img.rows != c.camera.height) {
      errors->push_back("camera " + std::to_string(c.camera.id) + ": frame " + std::to_string(index_) +
                          " is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                          ", calibration says " + std::to_string(c.camera.width) + "x" +
                          std::to_string(c.camera.height) + "; skipped");
      return true;  // delivered, but skipped (its line says why)
    }
    const double t_segment = MonotonicSeconds();
    f->read_ms[i] = (t_segment - t_read) * 1e3;
    cv::Mat map;
    if (!c.masks_spec.empty()) {
      // Read as stored (cv::IMREAD_UNCHANGED): an RGBA mask keeps its alpha.
      const std::string file = NumberedFile(c.masks_spec, c.mask_first + int(index_));
      std::string why;
      const cv::Mat m = ReadImageFile(file, cv::IMREAD_UNCHANGED, &why);
      if (m.empty()) why = "unreadable (" + why + ")";
      if (!m.empty() && m.size() != img.size())
        why = "of the wrong size (" + std::to_string(m.cols) + "x" + std::to_string(m.rows) + ", " + file + ")";
      if (why.empty()) {
        try {
          map = MaskToObjectPixelMap(m, c.mask_format);
        } catch (const std::invalid_argument& e) {
          why = std::string(e.what()) + " (" + file + ")";
        }
      }
      if (map.empty()) {
        errors->push_back("camera " + std::to_string(c.camera.id) + ": mask of frame " + std::to_string(index_) +
                          " " + why + "; skipped");
        return true;  // delivered, but skipped (its line says why)
      }
    } else {
      map = c.background.Segment(img, options_.segmentation);
      if (options_.follow_files) c.background.Follow(img, map, options_.background_rate);
    }
    f->images[i] = img;
    f->maps[i] = map;
    f->segment_ms[i] = (MonotonicSeconds() - t_segment) * 1e3;
    return true;
  }

  // Live: waits up to kLiveWaitS for any camera's frame, then takes one queued
  // frame of every camera that has one. The input ends when no camera delivered
  // for options_.live_timeout_s.
  static constexpr double kLiveWaitS = 0.1;
  bool NextLive(RigFrame* f) {
    std::vector<std::pair<cv::Mat, int64_t>> got(cams_.size());
    {
      std::unique_lock<std::mutex> lock(hub_->mu);
      hub_->cv.wait_for(lock, std::chrono::duration<double>(kLiveWaitS), [&] {
        for (const Cam& c : cams_)
          if (c.reader->HasFrame()) return true;
        return false;
      });
      for (size_t i = 0; i < cams_.size(); ++i) cams_[i].reader->Pop(&got[i].first, &got[i].second);
    }
    const double now = MonotonicSeconds();
    if (last_live_frame_s_ == 0) last_live_frame_s_ = now;
    bool any = false;
    for (size_t i = 0; i < cams_.size(); ++i) {
      if (got[i].first.empty()) continue;
      any = true;
      Cam& c = cams_[i];
      const cv::Mat& img = got[i].first;
      if (img.type() != CV_8UC3 || img.cols != c.camera.width || img.rows != c.camera.height) {
        f->errors.push_back("camera " + std::to_string(c.camera.id) + ": a frame of " + std::to_string(img.cols) +
                            "x" + std::to_string(img.rows) + ", calibration says " + std::to_string(c.camera.width) +
                            "x" + std::to_string(c.camera.height) + "; skipped");
        continue;
      }
      f->images[i] = img;
      const double t_segment = MonotonicSeconds();
      f->maps[i] = c.background.Segment(img, options_.segmentation);
      c.background.Follow(img, f->maps[i], options_.background_rate);
      f->segment_ms[i] = (MonotonicSeconds() - t_segment) * 1e3;
      f->capture_ns[i] = got[i].second - c.latency_ns;
    }
    if (any) {
      last_live_frame_s_ = now;
      any_live_frame_ = true;
      ++index_;
      return true;
    }
    const double timeout = any_live_frame_ ? options_.live_timeout_s
                                           : std::max(options_.live_timeout_s, VideoRigOptions::kFirstLiveFrameS);
    if (now - last_live_frame_s_ > timeout) {
      f->errors.push_back(cv::format("no frame from any live camera for %.1f s%s: input ended", timeout,
                                     any_live_frame_ ? "" : " (none since the start)"));
      return false;
    }
    return true;  // nothing this time; the caller asks again
  }

  // A live camera without a background learns it from its first frames: the
  // operator keeps the scene empty meanwhile.
  void LearnLiveBackground(Cam& c) {
    spdlog::info("camera {}: learning the background from its first {} frames: keep the scene empty", c.camera.id,
                 options_.background_frames);
    std::vector<cv::Mat> frames;
    double last = MonotonicSeconds();
    int wrong = 0;  // frames of another size in a row
    constexpr int kWrongSizeFrames = 10;
    while (int(frames.size()) < options_.background_frames) {
      cv::Mat img;
      int64_t t;
      {
        std::unique_lock<std::mutex> lock(hub_->mu);
        hub_->cv.wait_for(lock, std::chrono::duration<double>(kLiveWaitS), [&] { return c.reader->HasFrame(); });
        c.reader->Pop(&img, &t);
      }
      if (options_.stop_requested && options_.stop_requested())
        throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": stopped while learning the background");
      if (img.empty()) {
        if (MonotonicSeconds() - last > options_.live_timeout_s)
          throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": no frame from " + c.frames_spec +
                                   cv::format(" for %.1f s while learning the background", options_.live_timeout_s));
        continue;
      }
      // Only frames of the calibrated size count as the camera delivering: a
      // stream of another size (a camera left in another mode) learnt
      // forever before; it ends the input after a few frames, naming both.
      if (img.cols == c.camera.width && img.rows == c.camera.height && img.type() == CV_8UC3) {
        last = MonotonicSeconds();
        wrong = 0;
        frames.push_back(img);
      } else if (++wrong >= kWrongSizeFrames || MonotonicSeconds() - last > options_.live_timeout_s) {
        throw std::runtime_error(
            "camera " + std::to_string(c.camera.id) + ": " + c.frames_spec + " delivers " + std::to_string(img.cols) +
            "x" + std::to_string(img.rows) + (img.type() == CV_8UC3 ? "" : " (not 8-bit colour)") +
            " frames, its calibration says " + std::to_string(c.camera.width) + "x" + std::to_string(c.camera.height) +
            ": set the camera's mode to the calibrated size, or calibrate it at this one");
      }
    }
    c.background = BackgroundModel(frames);
    spdlog::info("camera {}: background learnt from {} frames; capturing", c.camera.id, frames.size());
  }

  static BackgroundModel LearnBackground(const Cam& c, int background_frames) {
    const std::vector<cv::Mat> frames =
        ReadCalibratedFrames(c.camera.id, "background " + c.background_spec, c.background_spec, background_frames,
                             c.camera.width, c.camera.height);
    if (frames.empty())
      throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": background " + c.background_spec +
                               " has no readable frame of the calibrated size");
    return BackgroundModel(frames);
  }

  // The frames that background learning may hold at once, all cameras together.
  static constexpr int64_t kBackgroundBytes = int64_t(1) << 30;

  // Every camera's background from its file, the cameras at once (one after
  // the other, a 20-camera rig's start-up took twenty times one camera's), on
  // up to the machine's cores while the frames held stay within
  // kBackgroundBytes. A failure is the first camera's in camera order.
  void LearnFileBackgrounds() {
    std::vector<size_t> todo;
    int64_t per_camera = 1;
    for (size_t i = 0; i < cams_.size(); ++i) {
      const Cam& c = cams_[i];
      if (c.background_spec.empty()) continue;
      todo.push_back(i);
      per_camera = std::max(per_camera, int64_t(options_.background_frames) * c.camera.width * c.camera.height * 3);
    }
    const int by_memory = int(std::clamp<int64_t>(kBackgroundBytes / per_camera, 1, 64));
    const int threads = std::min({int(todo.size()), ThreadsOrCores(0), by_memory});
    std::vector<std::exception_ptr> failed(todo.size());
    ForEachRowDynamic(int(todo.size()), threads, [&](int k, int) {
      try {
        Cam& c = cams_[todo[size_t(k)]];
        c.background = LearnBackground(c, options_.background_frames);
      } catch (...) {
        failed[size_t(k)] = std::current_exception();
      }
    });
    for (const std::exception_ptr& e : failed)
      if (e) std::rethrow_exception(e);
  }

  // After reading frame index_ (alive: cameras that delivered it). A frameset
  // needs every camera, so the input ends at the first camera that ends; the
  // end is incomplete when other cameras went on, or when a video ends well
  // before the frame count its container declares (a truncated or damaged file).
  // Returns false at the end of the input.
  bool CheckEnds(int alive) {
    std::string ended, going_on;
    for (const Cam& c : cams_) {
      std::string& list = c.ended ? ended : going_on;
      list += (list.empty() ? "" : ", ") + std::to_string(c.camera.id);
    }
    if (ended.empty()) return true;
    if (alive > 0) {
      incomplete_ = "camera(s) " + ended + " ended after frame " + std::to_string(index_) + " while camera(s) " +
                    going_on + " went on (" + FilesOf(true) +
                    "): a frameset needs every camera, so the input ends there";
    } else {
      for (const Cam& c : cams_) {
        // Containers' counts are estimates (the rig's 426-frame videos declare
        // 428): short by more than max(5 frames, 1%) is a truncated file.
        const int64_t declared = c.frames->declared_frames();  // 0: unknown
        const int64_t slack = std::max<int64_t>(5, declared / 100);
        if (!c.frames->error().empty()) {
          incomplete_ = "camera " + std::to_string(c.camera.id) + ": " + c.frames_spec + " ends after frame " +
                        std::to_string(index_) + ": " + c.frames->error();
          break;
        }
        if (declared > 0 && index_ + slack < declared) {
          incomplete_ = "camera " + std::to_string(c.camera.id) + ": " + c.frames_spec + " ends after frame " +
                        std::to_string(index_) + " of the " + std::to_string(declared) +
                        " its container declares (truncated or damaged)";
          break;
        }
      }
    }
    return false;
  }
  std::string FilesOf(bool ended) const {
    std::string s;
    for (const Cam& c : cams_) {
      if (c.ended != ended) continue;
      s += (s.empty() ? "" : ", ") + c.frames_spec;
      if (c.frames && c.frames->sequence())
        s += " (" + std::to_string(c.frames->sequence()->count) + " image file(s) from " +
             NumberedFile(c.frames->sequence()->pattern, c.frames->sequence()->first) + ")";
      if (c.frames && !c.frames->error().empty()) s += " (" + c.frames->error() + ")";
    }
    return s;
  }

  void OpenAll() {
    index_ = 0;
    incomplete_.clear();
    for (Cam& c : cams_) {
      if (c.live) {
        c.reader = std::make_unique<LiveCameraReader>(c.camera.id, c.frames_spec, hub_);
        continue;
      }
      if (c.frames)
        c.frames->Reopen();
      else
        c.frames = std::make_unique<FileCameraReader>(c.camera.id, c.frames_spec);
      if (!c.masks_spec.empty()) c.mask_first = FirstFileNumber(c.masks_spec);
      c.ended = false;
      if (c.frames->fps() > 0) fps_ = c.frames->fps();
    }
  }

  VideoRigOptions options_;
  std::shared_ptr<LiveHub> hub_ = std::make_shared<LiveHub>();
  bool live_ = false;
  double last_live_frame_s_ = 0;
  bool any_live_frame_ = false;  // a live camera delivered since the start
  std::vector<Cam> cams_;
  std::vector<Camera> cameras_;
  Aabb workspace_;
  int rig_camera_count_ = 0;
  double fps_ = 25;
  int64_t index_ = 0;
  std::string incomplete_;
};

}  // namespace

std::unique_ptr<RigSource> OpenVideoRig(const std::string& rig_path, const VideoRigOptions& options) {
  return std::make_unique<VideoRig>(rig_path, options);
}

}  // namespace hullpipe
