#include "hullpipe/segmentation/rig_source.h"

#include <filesystem>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {
namespace {

// The file of number `n` of a printf-style mask pattern ("mask_%04d.png"): one
// integer conversion; a pattern without one names a single file for every frame.
// Only "%d" or "%0Nd" (N <= 9) is expanded (no printf on a file's text).
std::string MaskFile(const std::string& pattern, int n) {
  const size_t p = pattern.find('%');
  if (p == std::string::npos) return pattern;
  size_t q = p + 1;
  int width = 0;
  if (q < pattern.size() && pattern[q] == '0') ++q;
  if (q < pattern.size() && pattern[q] >= '1' && pattern[q] <= '9') width = pattern[q++] - '0';
  if (q >= pattern.size() || pattern[q] != 'd') return pattern;  // not a number conversion: a literal name
  std::string num = std::to_string(n);
  if (int(num.size()) < width) num.insert(0, size_t(width) - num.size(), '0');
  return pattern.substr(0, p) + num + pattern.substr(q + 1);
}

// Masks number from the first of 0..4 that exists, as OpenCV's image sequences
// (the frames) do, so mask k goes with frame k.
int FirstMaskNumber(const std::string& pattern) {
  for (int n = 0; n <= 4; ++n)
    if (std::filesystem::exists(MaskFile(pattern, n))) return n;
  return 0;
}

bool Selected(const std::vector<int>& ids, int id) {
  return ids.empty() || std::find(ids.begin(), ids.end(), id) != ids.end();
}

// Live captures give up a blocking open or read after these, so a reader thread
// notices a stop request within half a second (every process stops within a
// second of SIGINT) and a silent stream is reported rather than waited on forever.
constexpr int kLiveOpenTimeoutMs = 2000, kLiveReadTimeoutMs = 500;

cv::VideoCapture OpenCapture(const std::string& spec) {
  if (spec.rfind("v4l2:", 0) == 0) {
    int index = -1;
    try {
      index = std::stoi(spec.substr(5));
    } catch (const std::exception&) {
    }
    if (index < 0) throw std::runtime_error("'" + spec + "': expected v4l2:<device index>");
    return cv::VideoCapture(index, cv::CAP_V4L2);
  }
  if (RigCamera::IsLiveSpec(spec)) {
    // FFmpeg probes a network stream for 5 s by default before the first frame
    // (and again after each reopen): a camera joins within half a second instead.
    // A user's own OPENCV_FFMPEG_CAPTURE_OPTIONS is kept.
    setenv("OPENCV_FFMPEG_CAPTURE_OPTIONS", "analyzeduration;500000|probesize;500000|fflags;nobuffer", 0);
    return cv::VideoCapture(spec, cv::CAP_FFMPEG,
                            {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, kLiveOpenTimeoutMs, cv::CAP_PROP_READ_TIMEOUT_MSEC,
                             kLiveReadTimeoutMs});
  }
  return cv::VideoCapture(spec, cv::CAP_ANY);
}

// What a VideoRig and its live readers share: one lock and one wake-up for "a
// frame arrived from any camera".
struct LiveHub {
  std::mutex mu;
  std::condition_variable cv;
};

// Reads one live camera on its own thread, as fast as it delivers, stamping each
// frame on arrival (before it waits for the capture loop), into a short queue
// (latest wins: the oldest frame is dropped when it is full). The
// thread owns its state with the reader: a reader destroyed while its thread is
// blocked in FFmpeg (an open or read time-out, at most kLiveOpenTimeoutMs) lets
// it finish alone, so the node stops at once.
class LiveReader {
 public:
  LiveReader(int camera_id, std::string spec, std::shared_ptr<LiveHub> hub)
      : s_(std::make_shared<State>()) {
    s_->id = camera_id;
    s_->spec = std::move(spec);
    s_->hub = std::move(hub);
    thread_ = std::thread([s = s_] { Run(*s); });
  }
  /// Asks the thread to stop; it notices within a read time-out, or when a
  /// blocked open returns.
  void RequestStop() { s_->stop = true; }
  bool Done() const { return s_->done; }
  /// Joins a thread that has finished; one still blocked in FFmpeg is left to
  /// finish alone (it holds its own state). Callers give it time first (StopAll).
  ~LiveReader() {
    RequestStop();
    if (s_->done)
      thread_.join();
    else
      thread_.detach();
  }
  /// Asks every reader to stop, then gives them together up to 0.5 s to finish
  /// (waiting for each in turn would add their time-outs up past the second a
  /// node has to stop).
  static void StopAll(const std::vector<LiveReader*>& readers) {
    for (LiveReader* r : readers) r->RequestStop();
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    for (LiveReader* r : readers)
      while (!r->Done() && std::chrono::steady_clock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  /// Under the hub's mutex: takes the oldest queued frame.
  bool Pop(cv::Mat* image, int64_t* arrival_ns) {
    if (s_->queue.empty()) return false;
    *image = std::move(s_->queue.front().second);
    *arrival_ns = s_->queue.front().first;
    s_->queue.pop_front();
    return true;
  }
  bool HasFrame() const { return !s_->queue.empty(); }  // under the hub's mutex

 private:
  struct State {
    int id = 0;
    std::string spec;
    std::shared_ptr<LiveHub> hub;
    std::deque<std::pair<int64_t, cv::Mat>> queue;
    std::atomic<bool> stop{false}, done{false};
  };
  static void Run(State& s) {
    cv::VideoCapture cap;
    bool told = false;
    int failures = 0;
    while (!s.stop) {
      if (!cap.isOpened()) {
        try {
          cap = OpenCapture(s.spec);
        } catch (const std::exception& e) {
          spdlog::error("camera {}: {}", s.id, e.what());
          break;
        }
        if (s.stop) break;
        if (!cap.isOpened()) {
          if (!told) spdlog::warn("camera {}: cannot open {} yet; retrying", s.id, s.spec);
          told = true;
          for (int i = 0; i < 10 && !s.stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
        if (told) spdlog::info("camera {}: {} opened", s.id, s.spec);
        told = false;
      }
      cv::Mat img;
      bool ok = false;
      try {
        ok = cap.read(img) && !img.empty();
      } catch (const cv::Exception&) {
        ok = false;
      }
      if (!ok) {
        // A read time-out: the stream is silent. FFmpeg's context does not recover
        // from an interrupted read, so a camera silent for two time-outs is
        // reopened (it is found again when it resumes).
        if (++failures >= 2) {
          cap.release();
          failures = 0;
        }
        continue;
      }
      failures = 0;
      const int64_t arrival = NowNs();
      std::lock_guard<std::mutex> lock(s.hub->mu);
      if (s.queue.size() >= 4) s.queue.pop_front();
      s.queue.emplace_back(arrival, std::move(img));
      s.hub->cv.notify_all();
    }
    s.done = true;
  }

  std::shared_ptr<State> s_;
  std::thread thread_;
};

class VideoRig final : public RigSource {
 public:
  VideoRig(const std::string& path, const VideoRigOptions& o) : options_(o) {
    o.segmentation.Check();
    const Rig rig = LoadRig(path);
    workspace_ = rig.workspace;
    rig_camera_count_ = int(rig.cameras.size());
    for (const auto& rc : rig.cameras) {
      if (!Selected(o.camera_ids, rc.camera.id)) continue;
      Cam cam;
      cam.camera = rc.camera;
      cam.frames_spec = rc.frames;
      cam.masks_spec = rc.masks;
      cam.mask_format = rc;
      cam.latency_ns = int64_t(rc.latency_s * 1e9);
      if (!rc.tracked.empty()) cam.track = LoadPoseTrack(rc.tracked);
      cam.live = rc.live();
      if (cam.live && !rc.masks.empty())
        throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": a live camera cannot have masks");
      if (cam.live && !rc.tracked.empty())
        throw std::runtime_error("camera " + std::to_string(rc.camera.id) +
                                 ": key 'tracked': a pose log is keyed by source time and serves file sources; a "
                                 "live tracked camera is not supported");
      if (rc.masks.empty() && !rc.background.empty()) cam.background = LearnBackground(rc);
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
      if (!c.live && c.masks_spec.empty() && c.background.empty())
        throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": no background and no masks");
    }
    OpenAll();
    for (Cam& c : cams_)
      if (c.live && c.background.empty()) LearnLiveBackground(c);
  }
  ~VideoRig() override {
    std::vector<LiveReader*> readers;
    for (Cam& c : cams_)
      if (c.reader) readers.push_back(c.reader.get());
    LiveReader::StopAll(readers);
  }
  bool live() const override { return live_; }
  bool Skip() override {
    if (live_) return false;
    int alive = 0;
    for (Cam& c : cams_) {
      if (c.ended) continue;
      if (!c.frames.grab()) {
        c.ended = true;
        continue;
      }
      // (masks are read by number: nothing to skip)
      ++alive;
    }
    if (!CheckEnds(alive)) return false;
    ++index_;
    return true;
  }
  std::string IncompleteEnd() const override { return incomplete_; }
  const std::vector<Camera>& cameras() const override { return cameras_; }
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
    std::vector<int> alive_of(cams_.size(), 0);
    const int threads = std::max(1, std::min(int(cams_.size()), int(std::thread::hardware_concurrency())));
    ForEachRowBand(int(cams_.size()), threads, [&](int c0, int c1, int) {
      for (int ci = c0; ci < c1; ++ci) ReadOne(size_t(ci), f, &errors[size_t(ci)], &alive_of[size_t(ci)]);
    });
    int alive = 0;
    for (size_t i = 0; i < cams_.size(); ++i) {
      alive += alive_of[i];
      for (auto& e : errors[i]) f->errors.push_back(std::move(e));
    }
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
    cv::VideoCapture frames;
    int mask_first = 0;      ///< Number of the first mask file (0..4, as OpenCV's image sequences).
    RigCamera mask_format;   ///< Its mask_threshold and mask_channel.
    BackgroundModel background;
    bool ended = false;
    int64_t declared_frames = 0;  ///< The container's frame count (0: unknown).
    bool live = false;
    int64_t latency_ns = 0;
    std::unique_ptr<LiveReader> reader;
    PoseTrack track;  ///< A tracked camera's world_from_camera by source time.
  };

  // Reads and segments camera i's next frame into f (its own slots only).
  void ReadOne(size_t i, RigFrame* f, std::vector<std::string>* errors, int* alive) {
    Cam& c = cams_[i];
    if (c.ended) return;
    cv::Mat img;
    bool ok = false;
    const double t_read = MonotonicSeconds();
    try {
      ok = c.frames.read(img);
    } catch (const cv::Exception& e) {
      ok = false;
    }
    if (!ok || img.empty()) {
      c.ended = true;  // CheckEnds says whether this is the input's end or a short camera
      return;
    }
    *alive = 1;
    if (img.type() != CV_8UC3 || img.cols != c.camera.width || img.rows != c.camera.height) {
      errors->push_back("camera " + std::to_string(c.camera.id) + ": frame " + std::to_string(index_) +
                          " is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                          ", calibration says " + std::to_string(c.camera.width) + "x" +
                          std::to_string(c.camera.height) + "; skipped");
      return;
    }
    const double t_segment = MonotonicSeconds();
    f->read_ms[i] = (t_segment - t_read) * 1e3;
    cv::Mat map;
    if (!c.masks_spec.empty()) {
      // Read as stored (cv::IMREAD_UNCHANGED): an RGBA mask keeps its alpha.
      const std::string file = MaskFile(c.masks_spec, c.mask_first + int(index_));
      const cv::Mat m = cv::imread(file, cv::IMREAD_UNCHANGED);
      std::string why = m.empty() ? "unreadable (" + file + ")" : "";
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
        return;
      }
    } else {
      map = c.background.Segment(img, options_.segmentation);
      if (options_.follow_files) c.background.Follow(img, map, options_.background_rate);
    }
    f->images[i] = img;
    f->maps[i] = map;
    f->segment_ms[i] = (MonotonicSeconds() - t_segment) * 1e3;
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
      ++index_;
      return true;
    }
    if (now - last_live_frame_s_ > options_.live_timeout_s) {
      f->errors.push_back(cv::format("no frame from any live camera for %.1f s: input ended", options_.live_timeout_s));
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
      last = MonotonicSeconds();
      if (img.cols == c.camera.width && img.rows == c.camera.height && img.type() == CV_8UC3)
        frames.push_back(img);
    }
    c.background = BackgroundModel(frames);
    spdlog::info("camera {}: background learnt from {} frames; capturing", c.camera.id, frames.size());
  }

  BackgroundModel LearnBackground(const RigCamera& rc) {
    if (rc.background.empty())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": no background and no masks");
    cv::VideoCapture cap = OpenCapture(rc.background);
    if (!cap.isOpened())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": cannot open background " +
                               rc.background);
    std::vector<cv::Mat> frames;
    cv::Mat f;
    while (int(frames.size()) < options_.background_frames && cap.read(f) && !f.empty()) {
      if (f.cols == rc.camera.width && f.rows == rc.camera.height && f.type() == CV_8UC3)
        frames.push_back(f.clone());
    }
    if (frames.empty())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": background " + rc.background +
                               " has no readable frame of the calibrated size");
    return BackgroundModel(frames);
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
        const int64_t slack = std::max<int64_t>(5, c.declared_frames / 100);
        if (c.declared_frames > 0 && index_ + slack < c.declared_frames) {
          incomplete_ = "camera " + std::to_string(c.camera.id) + ": " + c.frames_spec + " ends after frame " +
                        std::to_string(index_) + " of the " + std::to_string(c.declared_frames) +
                        " its container declares (truncated or damaged)";
          break;
        }
      }
    }
    return false;
  }
  std::string FilesOf(bool ended) const {
    std::string s;
    for (const Cam& c : cams_)
      if (c.ended == ended) s += (s.empty() ? "" : ", ") + c.frames_spec;
    return s;
  }

  void OpenAll() {
    index_ = 0;
    incomplete_.clear();
    for (Cam& c : cams_) {
      if (c.live) {
        c.reader = std::make_unique<LiveReader>(c.camera.id, c.frames_spec, hub_);
        continue;
      }
      c.frames = OpenCapture(c.frames_spec);
      if (!c.frames.isOpened())
        throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": cannot open " + c.frames_spec);
      if (!c.masks_spec.empty()) c.mask_first = FirstMaskNumber(c.masks_spec);
      c.ended = false;
      const double declared = c.frames.get(cv::CAP_PROP_FRAME_COUNT);
      c.declared_frames = std::isfinite(declared) && declared > 0 && declared < 1e9 ? int64_t(declared) : 0;
      const double f = c.frames.get(cv::CAP_PROP_FPS);
      if (f > 1 && f < 1000) fps_ = f;
    }
  }

  VideoRigOptions options_;
  std::shared_ptr<LiveHub> hub_ = std::make_shared<LiveHub>();
  bool live_ = false;
  double last_live_frame_s_ = 0;
  std::vector<Cam> cams_;
  std::vector<Camera> cameras_;
  Aabb workspace_;
  int rig_camera_count_ = 0;
  double fps_ = 25;
  int64_t index_ = 0;
  std::string incomplete_;
};

class SyntheticRig final : public RigSource {
 public:
  explicit SyntheticRig(const SyntheticRigOptions& o) : options_(o) {
    if (o.cameras < 1 || o.cameras > SyntheticRigOptions::kMaxCameras)
      throw std::invalid_argument("synthetic rig: --cameras must be in [1, 64]");
    if (o.width < 8 || o.height < 8 || o.width > SyntheticRigOptions::kMaxSide ||
        o.height > SyntheticRigOptions::kMaxSide)
      throw std::invalid_argument("synthetic rig: --synthetic-size must be in [8, 4096] x [8, 4096] pixels");
    if (!(o.fps > 0 && o.fps <= 1000)) throw std::invalid_argument("synthetic rig: --fps must be in (0, 1000]");
    if (o.frames < 0) throw std::invalid_argument("synthetic rig: --frames must be >= 0");
    (void)NamedScene(o.scene, 0);  // throws on an unknown name
    if (o.placement != "ring" && o.placement != "dome")
      throw std::invalid_argument("synthetic rig: placement must be ring or dome, not '" + o.placement + "'");
    const Eigen::Vector3d target = o.scene == "figure" ? Eigen::Vector3d(0, 0, -0.9) : Eigen::Vector3d(0, 0, -1.0);
    target_ = target;
    if (o.tracked_camera < 0 || o.tracked_camera > o.cameras)
      throw std::invalid_argument("synthetic rig: the tracked camera must be one of 1.." + std::to_string(o.cameras));
    const auto all = o.placement == "dome"
                         ? DomeCameras(o.cameras, 3.0, target, o.width, o.height, o.hfov, o.distortion)
                         : RingCameras(o.cameras, 4.0, 2.0, target, o.width, o.height, o.hfov, o.distortion);
    for (const auto& c : all)
      if (Selected(o.camera_ids, c.id)) cameras_.push_back(c);
    if (cameras_.empty()) throw std::invalid_argument("synthetic rig: no camera selected");
    workspace_.min = Eigen::Vector3d(-2, -2, -2.5);
    workspace_.max = Eigen::Vector3d(2, 2, 0.02);
  }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return options_.cameras; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return options_.fps; }
  bool Next(RigFrame* f) override {
    if (index_ >= options_.frames) return false;
    f->time_s = double(index_) / options_.fps;
    const SyntheticScene scene = NamedScene(options_.scene, f->time_s);
    f->images.clear();
    f->maps.clear();
    f->errors.clear();
    f->poses.assign(cameras_.size(), std::nullopt);
    for (size_t i = 0; i < cameras_.size(); ++i) {
      Camera c = cameras_[i];
      if (c.id == options_.tracked_camera) {
        c.cam_from_world = SyntheticTrackedPose(cameras_[i], target_, f->time_s);
        f->poses[i] = c.cam_from_world;
      }
      f->maps.push_back(RenderExactMap(c, scene));
      f->images.push_back(RenderColour(c, scene));
    }
    ++index_;
    return true;
  }
  bool Rewind() override {
    index_ = 0;
    return true;
  }
  bool Skip() override {
    if (index_ >= options_.frames) return false;
    ++index_;  // nothing to render
    return true;
  }

 private:
  SyntheticRigOptions options_;
  std::vector<Camera> cameras_;
  Eigen::Vector3d target_ = Eigen::Vector3d::Zero();
  Aabb workspace_;
  int64_t index_ = 0;
};

}  // namespace

Rigid3d SyntheticTrackedPose(const Camera& calibrated, const Eigen::Vector3d& target, double t) {
  const Rigid3d world_from_cam = calibrated.cam_from_world.Inverse();
  Rigid3d move;  // about the vertical through the target, then up (-z)
  move.rotation = Eigen::AngleAxisd(0.35 * std::sin(t), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  move.translation = target - move.rotation * target + Eigen::Vector3d(0.4 * std::sin(t), 0, -0.1 * std::sin(2 * t));
  return (move * world_from_cam).Inverse();
}

std::unique_ptr<RigSource> OpenVideoRig(const std::string& rig_path, const VideoRigOptions& options) {
  return std::make_unique<VideoRig>(rig_path, options);
}

std::unique_ptr<RigSource> OpenSyntheticRig(const SyntheticRigOptions& options) {
  return std::make_unique<SyntheticRig>(options);
}

}  // namespace hullpipe
