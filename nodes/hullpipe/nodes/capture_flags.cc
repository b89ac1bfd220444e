#include "hullpipe/nodes/capture_flags.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include "hullpipe/capture/prefetching_source.h"
#include "hullpipe/segmentation/video_rig.h"
#include "hullpipe/util/cli_range.h"

namespace hullpipe::nodes {

void CaptureFlags::Register(CLI::App& app) {
  SyntheticRigOptions& so = synthetic_options;
  CaptureOptions& o = options;
  app.add_option("--rig", rig, "Rig directory (Utrecht layout) or YAML rig file");
  app.add_flag("--synthetic", synthetic, "Use the built-in synthetic scene (exact masks, no files)");
  app.add_option("--synthetic-size", synthetic_size, "Synthetic camera size WxH")->capture_default_str();
  app.add_option("--synthetic-scene", so.scene, "Synthetic scene: figure|hand|sphere|box|torus|mixed")
      ->capture_default_str();
  app.add_option("--synthetic-placement", so.placement, "Synthetic cameras: ring|dome")->capture_default_str();
  app.add_option("--synthetic-cameras", so.cameras, "Number of synthetic cameras (1-64)")
      ->check(CLI::Range(1, SyntheticRigOptions::kMaxCameras))
      ->capture_default_str();
  app.add_option("--synthetic-k1", so.distortion[0], "Synthetic radial distortion k1")
      ->check(FiniteRange(-1.0, 1.0))
      ->capture_default_str();
  app.add_option("--synthetic-tracked", so.tracked_camera,
                 "Synthetic camera that moves on a known path, its pose sent with each frame (0: none)")
      ->check(CLI::Range(0, SyntheticRigOptions::kMaxCameras))
      ->capture_default_str();
  app.add_option("--cameras", camera_ids, "Camera ids to capture (default: all)")->delimiter(',');
  app.add_option("--frames", o.frames, "Stop after this many frames (0: end of input)")->check(CLI::NonNegativeNumber);
  app.add_option("--fps", o.fps, "Pace at this rate (default: the source's rate)")->check(FiniteRange(0.0, 1000.0));
  app.add_flag("--fast", o.fast, "Do not pace: as fast as possible");
  app.add_flag("--loop", o.loop, "Restart the input at its end");
  app.add_option("--image-scale", o.image_scale, "Scale of the published colour images (0,1]")
      ->check(FiniteRange(0.05, 1.0))
      ->capture_default_str();
  app.add_option("--jpeg", jpeg_quality,
                 "Publish images as JPEG of this quality (0: raw BGR8; -1: JPEG 90 when one frame's images "
                 "would pass 2 MiB raw, else raw)")
      ->check(CLI::Range(-1, 100))
      ->capture_default_str();
  app.add_option("--image-region", image_region,
                 "Send each colour image whole, or only around its object pixels (all that texturing reads; "
                 "viewers show black around them); auto: object when one frame's images would pass 2 MiB raw")
      ->check(CLI::IsMember({"whole", "object", "auto"}))
      ->capture_default_str();
  app.add_option("--background-frames", background_frames,
                 "Frames of each camera's background video (or, for a live camera without one, of its first "
                 "frames) to learn the background from")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--live-timeout", live_timeout_s, "Live cameras: end the input when none delivered for this long, s")
      ->check(FiniteRange(0.2, 3600.0))
      ->capture_default_str();
  app.add_option("--start-time", o.start_ns,
                 "Capture timeline start, ns since the Unix epoch (default: adopt the one announced on the domain, "
                 "or announce one now)");
  app.add_option("--max-lag", o.max_lag_s, "Seconds behind the timeline before skipping to the frame due now")
      ->check(FiniteRange(1e-3, 60.0))
      ->capture_default_str();
  app.add_option("--timeline-window", o.timeline_window_s,
                 "Refuse an announced capture timeline starting further than this from now, seconds")
      ->check(FiniteRange(1.0, 86400.0))
      ->capture_default_str();
  app.add_option("--wait-readers", wait_readers, "Wait until this many map readers matched")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  app.add_option("--wait-timeout", wait_timeout_s, "Longest wait for readers, seconds")
      ->check(FiniteRange(0.0, 3600.0))
      ->capture_default_str();
  app.add_option("--threads", o.threads,
                 "Threads that scale, encode and write the cameras' frames at once (0: the machine's cores)")
      ->check(CLI::Range(0, 256))
      ->capture_default_str();
  app.add_option("--camera-pose-hold", o.camera_pose_hold_s,
                 "A camera posed live (rig 'tracked: topic'): most seconds between a frame and the tracker's "
                 "nearest CameraPose for the frame to take it")
      ->check(CLI::Range(0.001, 1.0))
      ->capture_default_str();
  app.add_flag("!--no-read-ahead", read_ahead,
               "Read and segment each frame only when it is due (default: file and synthetic sources read the "
               "next frame while this one is published)");
}

void CaptureFlags::Resolve() {
  options.Check();
  if (synthetic) {
    char tail = 0;
    if (std::sscanf(synthetic_size.c_str(), "%dx%d%c", &synthetic_options.width, &synthetic_options.height,
                    &tail) != 2)
      throw std::invalid_argument("--synthetic-size must be WxH, not '" + synthetic_size + "'");
    synthetic_options.camera_ids = camera_ids;
    synthetic_options.frames = options.frames > 0 ? int(std::min<int64_t>(options.frames, 1 << 30)) : 250;
  } else if (rig.empty()) {
    throw std::invalid_argument("give --rig DIR or --synthetic");
  }
}

std::unique_ptr<RigSource> CaptureFlags::OpenSource(std::function<bool()> stop_requested) {
  std::unique_ptr<RigSource> source;
  if (synthetic) {
    source = OpenSyntheticRig(synthetic_options);
  } else {
    VideoRigOptions vo;
    vo.camera_ids = camera_ids;
    vo.stop_requested = std::move(stop_requested);
    vo.live_timeout_s = live_timeout_s;
    vo.background_frames = background_frames;
    source = OpenVideoRig(rig, vo);
  }
  if (read_ahead) source = ReadAhead(std::move(source));
  jpeg_quality = ImageJpegQuality(jpeg_quality, source->cameras(), options.image_scale);
  options.image_regions = ImageRegions(image_region, source->cameras(), options.image_scale);
  return source;
}

}  // namespace hullpipe::nodes
