// capture_node's command line in one place (as render_flags.h for render_node):
// every flag registered once into CaptureOptions and the source's settings,
// then resolved and checked before any participant starts, and the source they
// name opened. Unit-tested by parsing argument lists.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "hullpipe/capture/rig_source.h"
#include "hullpipe/evaluation/synthetic_source.h"
#include "hullpipe/nodes/capture_controller.h"

namespace hullpipe::nodes {

struct CaptureFlags {
  CaptureOptions options;  ///< --frames, --fps, --fast, --loop, --image-scale, --start-time, --max-lag, ...
  std::string rig;         ///< --rig DIR|FILE (a Utrecht directory or a YAML rig)
  bool synthetic = false;  ///< --synthetic: the built-in scene with exact maps
  std::string synthetic_size = "320x240";
  SyntheticRigOptions synthetic_options;  ///< --synthetic-* (size from synthetic_size at Resolve)
  std::vector<int> camera_ids;            ///< --cameras 1,3 (empty: all)
  /// --jpeg: JPEG quality of the published images, 0 raw, -1 (the default)
  /// decided by the cameras' size at OpenSource (ImageJpegQuality).
  int jpeg_quality = -1;
  /// --image-region whole|object|auto: settled at OpenSource into
  /// options.image_regions (ImageRegions).
  std::string image_region = "auto";
  int background_frames = 60;  ///< --background-frames
  double live_timeout_s = 5;   ///< --live-timeout
  uint32_t wait_readers = 0;   ///< --wait-readers
  double wait_timeout_s = 10;  ///< --wait-timeout
  bool read_ahead = true;      ///< false with --no-read-ahead (PrefetchingSource)

  /// Registers capture_node's own flags on `app` (the common DDS flags are
  /// dds/node.h's); they write into this struct, which must outlive the parse.
  void Register(CLI::App& app);
  /// After the parse: --synthetic-size parsed into synthetic_options, the
  /// camera subset given to it, its frames from --frames (250 when 0), a
  /// source named (--rig or --synthetic), CaptureOptions::Check. Throws
  /// std::invalid_argument naming the flag.
  void Resolve();
  /// Opens the source the flags name (after Resolve), read one frame ahead
  /// unless --no-read-ahead, and settles --jpeg -1 and --image-region auto by
  /// its cameras' size.
  /// `stop_requested` is polled while a live background is learnt. Throws the
  /// loaders' errors (naming the file) or std::invalid_argument.
  std::unique_ptr<RigSource> OpenSource(std::function<bool()> stop_requested);
};

}  // namespace hullpipe::nodes
