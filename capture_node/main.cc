// capture_node: grabs every selected camera, segments each frame against the
// reference background into an object-pixel map (paper §3.1), and publishes
// CameraInfo once (transient-local), then per frame an ObjectPixelMap and a
// CameraImage per camera under one frame sequence number. Parses flags, opens
// the source and connects DDS to a CaptureController (nodes/capture_controller.h).
#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/capture/prefetching_source.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/nodes/capture_controller.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/logging.h"

using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

class CaptureWriters final : public nodes::CaptureSink {
 public:
  CaptureWriters(const Participant& p, int jpeg_quality, std::string name)
      : info_(p), maps_(p), images_(p), timeline_(p), jpeg_(jpeg_quality), name_(std::move(name)) {}
  void AnnounceTimeline(int64_t start_ns, double fps) override {
    hullpipe_msg_CaptureTimeline m{};
    m.start_ns = start_ns;
    m.fps = fps;
    m.announcer = const_cast<char*>(name_.c_str());
    timeline_.Write(m);
  }
  void PublishCameraInfo(const Camera& c, const Aabb& workspace) override { info_.Write(CameraToMsg(c, workspace)); }
  nodes::PublishTimes PublishFrame(const FrameStamp& stamp, uint32_t count, const cv::Mat& map, const cv::Mat& image,
                                   const Rigid3d* cam_from_world) override {
    const double t0 = MonotonicSeconds();
    const auto map_msg = MakeMapMessage(stamp, count, map, cam_from_world);
    const auto image_msg = MakeImageMessage(stamp.camera_id, stamp.seq, stamp.capture_time_ns, image, jpeg_);
    const double t1 = MonotonicSeconds();
    maps_.Write(map_msg.msg);
    images_.Write(image_msg.msg);
    return {(t1 - t0) * 1e3, (MonotonicSeconds() - t1) * 1e3};
  }
  uint32_t MatchedMapReaders() const { return maps_.MatchedReaders(); }
  bool Concurrent() const override { return true; }  // Cyclone's writers take writes from several threads

 private:
  Writer<hullpipe_msg_CameraInfo> info_;
  Writer<hullpipe_msg_ObjectPixelMap> maps_;
  Writer<hullpipe_msg_CameraImage> images_;
  Writer<hullpipe_msg_CaptureTimeline> timeline_;
  int jpeg_;
  std::string name_;
};

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("capture");  // stdout carries only what a user asked for
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe capture_node: cameras -> object-pixel maps + colour images over DDS"};
  CommonOptions common;
  AddCommonOptions(app, common);
  AddRunIdOption(app, common);
  std::string rig_path;
  bool synthetic = false;
  std::vector<int> camera_ids;
  int64_t frames = 0;
  double fps = 0;
  bool fast = false, loop = false;
  double image_scale = 0.5;
  int jpeg_quality = -1;
  uint32_t wait_readers = 0;
  double wait_timeout = 10;
  std::string synthetic_size = "320x240";
  SyntheticRigOptions synthetic_options;
  app.add_option("--rig", rig_path, "Rig directory (Utrecht layout) or YAML rig file");
  app.add_flag("--synthetic", synthetic, "Use the built-in synthetic scene (exact masks, no files)");
  app.add_option("--synthetic-size", synthetic_size, "Synthetic camera size WxH")->capture_default_str();
  app.add_option("--synthetic-scene", synthetic_options.scene, "Synthetic scene: figure|hand|sphere|box|torus|mixed")
      ->capture_default_str();
  app.add_option("--synthetic-placement", synthetic_options.placement, "Synthetic cameras: ring|dome")
      ->capture_default_str();
  app.add_option("--synthetic-cameras", synthetic_options.cameras, "Number of synthetic cameras (1-64)")
      ->check(CLI::Range(1, SyntheticRigOptions::kMaxCameras))->capture_default_str();
  app.add_option("--synthetic-k1", synthetic_options.distortion[0], "Synthetic radial distortion k1")
      ->check(hullpipe::FiniteRange(-1.0, 1.0))
      ->capture_default_str();
  app.add_option("--synthetic-tracked", synthetic_options.tracked_camera,
                 "Synthetic camera that moves on a known path, its pose sent with each frame (0: none)")
      ->check(CLI::Range(0, SyntheticRigOptions::kMaxCameras))
      ->capture_default_str();
  app.add_option("--cameras", camera_ids, "Camera ids to capture (default: all)")->delimiter(',');
  app.add_option("--frames", frames, "Stop after this many frames (0: end of input)")->check(CLI::NonNegativeNumber);
  app.add_option("--fps", fps, "Pace at this rate (default: the source's rate)")
      ->check(hullpipe::FiniteRange(0.0, 1000.0));
  app.add_flag("--fast", fast, "Do not pace: as fast as possible");
  app.add_flag("--loop", loop, "Restart the input at its end");
  app.add_option("--image-scale", image_scale, "Scale of the published colour images (0,1]")
      ->check(hullpipe::FiniteRange(0.05, 1.0))->capture_default_str();
  app.add_option("--jpeg", jpeg_quality,
                 "Publish images as JPEG of this quality (0: raw BGR8; -1: JPEG 90 when one frame's images "
                 "would pass 2 MiB raw, else raw)")
      ->check(CLI::Range(-1, 100))
      ->capture_default_str();
  int background_frames = 60;
  app.add_option("--background-frames", background_frames,
                 "Frames of each camera's background video (or, for a live camera without one, of its first "
                 "frames) to learn the background from")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  double live_timeout = 5;
  app.add_option("--live-timeout", live_timeout, "Live cameras: end the input when none delivered for this long, s")
      ->check(hullpipe::FiniteRange(0.2, 3600.0))
      ->capture_default_str();
  int64_t start_time_ns = 0;
  double max_lag = 0.1;
  app.add_option("--start-time", start_time_ns,
                 "Capture timeline start, ns since the Unix epoch (default: adopt the one announced on the domain, "
                 "or announce one now)");
  app.add_option("--max-lag", max_lag, "Seconds behind the timeline before skipping to the frame due now")
      ->check(hullpipe::FiniteRange(1e-3, 60.0))
      ->capture_default_str();
  double timeline_window = 600;
  app.add_option("--timeline-window", timeline_window,
                 "Refuse an announced capture timeline starting further than this from now, seconds")
      ->check(hullpipe::FiniteRange(1.0, 86400.0))
      ->capture_default_str();
  app.add_option("--wait-readers", wait_readers, "Wait until this many map readers matched")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  app.add_option("--wait-timeout", wait_timeout, "Longest wait for readers, seconds")
      ->check(hullpipe::FiniteRange(0.0, 3600.0))
      ->capture_default_str();
  int threads = 0;
  app.add_option("--threads", threads,
                 "Threads that scale, encode and write the cameras' frames at once (0: the machine's cores)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  bool no_read_ahead = false;
  app.add_flag("--no-read-ahead", no_read_ahead,
               "Read and segment each frame only when it is due (default: file and synthetic sources read the "
               "next frame while this one is published)");
  CLI11_PARSE(app, argc, argv);

  try {
    nodes::CaptureOptions co;
    co.threads = threads;
    co.frames = frames;
    co.fps = fps;
    co.fast = fast;
    co.loop = loop;
    co.image_scale = image_scale;
    co.start_ns = start_time_ns;
    co.max_lag_s = max_lag;
    co.timeline_window_s = timeline_window;
    co.Check();
    auto participant = StartNode("capture", common);
    std::unique_ptr<RigSource> source;
    if (synthetic) {
      SyntheticRigOptions so = synthetic_options;
      if (std::sscanf(synthetic_size.c_str(), "%dx%d", &so.width, &so.height) != 2)
        throw std::invalid_argument("--synthetic-size must be WxH");
      so.camera_ids = camera_ids;
      so.frames = frames > 0 ? int(frames) : 250;
      source = OpenSyntheticRig(so);
    } else {
      if (rig_path.empty()) throw std::invalid_argument("give --rig DIR or --synthetic");
      VideoRigOptions vo;
      vo.camera_ids = camera_ids;
      vo.stop_requested = [] { return StopRequested(); };
      vo.live_timeout_s = live_timeout;
      vo.background_frames = background_frames;
      source = OpenVideoRig(rig_path, vo);
    }
    if (!no_read_ahead) source = ReadAhead(std::move(source));
    std::string name = "capture";
    for (size_t i = 0; i < camera_ids.size(); ++i) name += (i ? "," : "-") + std::to_string(camera_ids[i]);
    jpeg_quality = nodes::ImageJpegQuality(jpeg_quality, source->cameras(), image_scale);
    CaptureWriters writers(*participant, jpeg_quality, name);
    Reader<hullpipe_msg_CaptureTimeline> timelines(*participant);
    SystemClock clock;
    nodes::CaptureController capture(co, clock, *source, writers);
    auto hear_timelines = [&] {
      timelines.TakeEach([&](const hullpipe_msg_CaptureTimeline& m, const dds_sample_info_t&) {
        capture.OnTimeline(m.start_ns, m.fps);
      });
    };
    spdlog::info("{} camera(s) of {}, {:.1f} fps{}, images {}", source->cameras().size(),
                 source->rig_camera_count(), capture.rate(), fast ? " (unpaced)" : source->live() ? " (live)" : "",
                 jpeg_quality > 0 ? "JPEG " + std::to_string(jpeg_quality) : std::string("raw"));
    NodeReporter reporter(*participant, name, capture.counters(), common.run_id);
    capture.PublishCalibration();
    if (wait_readers > 0) {
      const double deadline = MonotonicSeconds() + wait_timeout;
      while (writers.MatchedMapReaders() < wait_readers && MonotonicSeconds() < deadline && !StopRequested())
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      spdlog::info("{} map reader(s) matched", writers.MatchedMapReaders());
    }
    hear_timelines();
    capture.Start();
    spdlog::info("capture timeline starts at {} ns", capture.timeline_start_ns());
    while (!StopRequested() && capture.Step()) {
      hear_timelines();
      reporter.Publish();
    }
    reporter.Publish(true);
    // Give reliable readers a moment to receive the tail before the writers go.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    spdlog::info("published {} frames, {} rejected", capture.published(), capture.counters().rejected());
    if (capture.timelines_refused() > 0)
      spdlog::warn("{} announced capture timeline(s) refused (beyond --timeline-window)", capture.timelines_refused());
    if (!capture.incomplete().empty()) {
      spdlog::error("the input ended early (exit 3): {}", capture.incomplete());
      return 3;
    }
    if (capture.published() == 0 && !StopRequested()) {
      spdlog::error("no frame published: the input ended before its first frame");
      return 1;
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
