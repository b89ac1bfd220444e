// capture_node: grabs every selected camera, segments each frame against the
// reference background into an object-pixel map (paper §3.1), and publishes
// CameraInfo once (transient-local), then per frame an ObjectPixelMap and a
// CameraImage per camera under one frame sequence number. Parses flags, opens
// the source and connects DDS to a CaptureController (nodes/capture_controller.h).
#include <utility>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/nodes/capture_controller.h"
#include "hullpipe/nodes/capture_flags.h"
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
  nodes::PublishTimes PublishFrame(const nodes::CameraFrameOut& f) override {
    const double t0 = MonotonicSeconds();
    const auto map_msg = MakeMapMessage(f.stamp, f.camera_count, f.map, f.cam_from_world);
    const auto image_msg =
        f.image_region ? MakeImageRegionMessage(f.stamp.camera_id, f.stamp.seq, f.stamp.capture_time_ns, f.image,
                                                f.image_region->rect, f.image_region->whole, jpeg_)
                       : MakeImageMessage(f.stamp.camera_id, f.stamp.seq, f.stamp.capture_time_ns, f.image, jpeg_);
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
  CLI::App app{"hullpipe capture_node: cameras -> object-pixel maps + colour images over DDS"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "capture", app, common, /*with_run_id=*/true);
  nodes::CaptureFlags flags;
  flags.Register(app);
  CLI11_PARSE(app, argc, argv);

  try {
    flags.Resolve();
    auto participant = StartNode("capture", common);
    std::unique_ptr<RigSource> source = flags.OpenSource([] { return StopRequested(); });
    std::string name = "capture";
    for (size_t i = 0; i < flags.camera_ids.size(); ++i)
      name += (i ? "," : "-") + std::to_string(flags.camera_ids[i]);
    CaptureWriters writers(*participant, flags.jpeg_quality, name);
    Reader<hullpipe_msg_CaptureTimeline> timelines(*participant);
    SystemClock clock;
    nodes::CaptureController capture(flags.options, clock, *source, writers);
    // A camera posed live (rig 'tracked: topic'): the tracker's samples, taken
    // just before each frame is posed.
    std::unique_ptr<Reader<hullpipe_msg_CameraPose>> camera_poses;
    bool bad_pose_said = false;
    if (capture.posed_live()) {
      camera_poses = std::make_unique<Reader<hullpipe_msg_CameraPose>>(*participant);
      capture.SetPoseRefresh([&] {
        camera_poses->TakeEach([&](const hullpipe_msg_CameraPose& m, const dds_sample_info_t&) {
          try {
            capture.OnCameraPose(m.camera_id, m.stamp_ns, CameraPoseFromMsg(m));
          } catch (const MessageError& e) {
            capture.counters().Rejected();
            if (!std::exchange(bad_pose_said, true)) spdlog::warn("{} (said once; counted)", e.what());
          }
        });
      });
    }
    auto hear_timelines = [&] {
      timelines.TakeEach([&](const hullpipe_msg_CaptureTimeline& m, const dds_sample_info_t&) {
        capture.OnTimeline(m.start_ns, m.fps);
      });
    };
    const char* pacing = flags.options.fast ? " (unpaced)" : source->live() ? " (live)" : "";
    spdlog::info("{} camera(s) of {}, {:.1f} fps{}, images {}{}", source->cameras().size(),
                 source->rig_camera_count(), capture.rate(), pacing,
                 flags.jpeg_quality > 0 ? "JPEG " + std::to_string(flags.jpeg_quality) : std::string("raw"),
                 flags.options.image_regions ? " around their object pixels" : "");
    NodeReporter reporter(*participant, name, capture.counters(), common.run_id);
    capture.PublishCalibration();
    if (flags.wait_readers > 0) {
      const double deadline = MonotonicSeconds() + flags.wait_timeout_s;
      while (writers.MatchedMapReaders() < flags.wait_readers && MonotonicSeconds() < deadline && !StopRequested())
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
    if (capture.unposed_frames() > 0)
      spdlog::warn("{} frame(s) of cameras posed live not published: no CameraPose near them",
                   capture.unposed_frames());
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
