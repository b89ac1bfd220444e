// The input side of every node that consumes framesets (recon, sim, render):
// CameraInfo, ObjectPixelMap and optionally CameraImage readers feeding a
// FramesetAssembler (core/frameset.h). Malformed samples are logged on one line
// and counted; they never stop the node.
#pragma once

#include <algorithm>
#include <memory>
#include <set>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/reconstruction/frameset.h"

namespace CLI {
class App;  // CLI11: only the files that register flags compile it (docs/benchmarks.md, "Build")
}  // namespace CLI

namespace hullpipe::dds {

/// Frames kept per camera while a frameset waits for its partners: half a second
/// at 50 fps, five times the lag (capture_node --max-lag, 0.1 s) a capture host may
/// fall behind the others before it skips ahead, so a lagging host's frames —
/// and a busy receiver's backlog — still find theirs.
constexpr size_t kFramesetHistory = 24;

/// What every frameset-assembling node (recon, sim, render) takes on its
/// command line, registered once (AddFramesetOptions).
struct FramesetOptions {
  /// Largest |capture time - reference time| of a frameset's maps, ms, [0, 1000]
  /// (0: half the slowest camera's frame period; FramesetAssembler::SetTolerance).
  double skew_tolerance_ms = 0;
};

/// Adds --skew-tolerance, checked as it is parsed (before any participant starts).
void AddFramesetOptions(CLI::App& app, FramesetOptions& options);

class FramesetInput {
 public:
  /// Creates the readers and attaches them to `waitset`. max_pending and
  /// with_images as FramesetAssembler's; the assembler takes options' tolerance.
  FramesetInput(const Participant& participant, const WaitSet& waitset, size_t max_pending, bool with_images,
                const FramesetOptions& options = {});

  /// Takes every available CameraInfo, map and image sample into the assembler.
  void Poll();

  FramesetAssembler& assembler() { return assembler_; }
  /// Where each map's and image's transport time goes (the budget's
  /// "transport_map" and "transport_image", docs/latency.md): the take's time
  /// less the sample's DDS source timestamp, both CLOCK_REALTIME, the second on
  /// the writer's host. The counters' clock also stamps each sample's arrival
  /// (the assembler's clock check). nullptr (the default): not recorded, and
  /// arrivals stamped with the system clock.
  void SetCounters(NodeCounters* counters) { counters_ = counters; }
  /// Threads that decode the JPEG images of one Poll at once (capture_node
  /// --jpeg), >= 0; 0 (the default): this host's cores. Their time is the
  /// counters' "image_decode" stage.
  void SetDecodeThreads(int threads) { decode_threads_ = std::max(0, threads); }
  /// Malformed samples plus the assembler's rejections.
  uint64_t rejected() const { return malformed() + assembler_.rejected(); }
  /// Samples that could not be decoded (they never reached the assembler),
  /// those refused for their encapsulation (Reader::refused) included.
  uint64_t malformed() const {
    return malformed_ + info_.refused() + maps_.refused() + (images_ ? images_->refused() : 0);
  }
  /// Framesets superseded or evicted before use.
  uint64_t dropped() const { return assembler_.dropped(); }

 private:
  void Reject(const char* what);
  /// Now on the node's clock (the counters'), else the system's: a sample's arrival.
  int64_t ArrivalNs() const;
  Reader<hullpipe_msg_CameraInfo> info_;
  std::set<int> calibration_warned_;  ///< Cameras whose changed calibration was named.
  Reader<hullpipe_msg_ObjectPixelMap> maps_;
  std::unique_ptr<Reader<hullpipe_msg_CameraImage>> images_;
  FramesetAssembler assembler_;
  uint64_t malformed_ = 0;
  int decode_threads_ = 0;
  NodeCounters* counters_ = nullptr;
};

}  // namespace hullpipe::dds
