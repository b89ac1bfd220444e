// The input side of every node that consumes framesets (recon, sim, render):
// CameraInfo, ObjectPixelMap and optionally CameraImage readers feeding a
// FramesetAssembler (core/frameset.h). Malformed samples are logged on one line
// and counted; they never stop the node. The samples may be taken and decoded
// on a thread of the input's own while the node works on the last frameset
// (StartInputThread; docs/architecture.md, "Threads").
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/util/reject_log.h"

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
  /// Whether the node takes and decodes its input on a thread of its own
  /// (FramesetInput::StartInputThread; --input-thread, on by default).
  bool input_thread = true;
};

/// Adds --skew-tolerance (checked as it is parsed, before any participant
/// starts) and --input-thread / --no-input-thread.
void AddFramesetOptions(CLI::App& app, FramesetOptions& options);

class FramesetInput {
 public:
  /// Creates the readers and attaches them to `waitset`. max_pending and
  /// with_images as FramesetAssembler's; the assembler takes options' tolerance.
  FramesetInput(const Participant& participant, const WaitSet& waitset, size_t max_pending, bool with_images,
                const FramesetOptions& options = {});

  /// Stops and joins the input thread, if one was started.
  ~FramesetInput();
  FramesetInput(const FramesetInput&) = delete;
  FramesetInput& operator=(const FramesetInput&) = delete;

  /// Without the input thread: takes every available CameraInfo, map and image
  /// sample, decodes it and gives it to the assembler. With it: gives the
  /// assembler what the thread has taken and decoded since the last Poll, in
  /// the order taken (cameras, then maps, then images of each take).
  void Poll();

  /// From now on the samples are taken and decoded (maps' runs, images, JPEG
  /// on SetDecodeThreads' threads) on a thread of the input's own, as they
  /// arrive, while the node works on the last frameset; Poll only hands them
  /// to the assembler, which stays the caller's alone. The readers leave the
  /// waitset given to the constructor; a guard condition there wakes it when
  /// the thread has something for Poll; if a DDS call fails on the thread,
  /// the next Poll throws std::runtime_error saying so. The thread holds at
  /// most as many decoded maps (and images) as the assembler keeps
  /// (max_pending framesets of the cameras seen, at least 64 samples; one take
  /// may pass that by what the readers hold) and takes no more until Poll
  /// drains them: past that the readers' history is the bound, as without the
  /// thread. Call after SetCounters and SetDecodeThreads (the thread reads
  /// them; the counters' clock, which stamps arrivals, must be safe to read
  /// from another thread: SystemClock is). Once only; the destructor stops it
  /// within 50 ms. Throws DdsError if a guard condition or waitset cannot be
  /// made.
  void StartInputThread();
  bool input_thread() const { return thread_.joinable(); }
  /// Decoded samples (cameras, maps, images) the input thread holds for the
  /// next Poll; 0 without the thread.
  size_t queued() const;
  /// Times the input thread found its queue full and waited for Poll.
  uint64_t paused() const { return paused_; }

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
  /// Malformed samples plus the assembler's rejections (with the input thread:
  /// as of the last Poll).
  uint64_t rejected() const { return malformed() + assembler_.rejected(); }
  /// Samples that could not be decoded (they never reached the assembler),
  /// those refused for their encapsulation (Reader::refused) included.
  uint64_t malformed() const { return malformed_ + refused_; }
  /// Framesets superseded or evicted before use.
  uint64_t dropped() const { return assembler_.dropped(); }

 private:
  /// What one take gives the assembler: each sample decoded, with its DDS
  /// source timestamp (the transport stages) and arrival stamped at the take.
  struct Received {
    std::vector<std::pair<Camera, Aabb>> cameras;
    std::vector<std::pair<MapSample, int64_t>> maps;
    std::vector<std::pair<ImageSample, int64_t>> images;
    std::vector<double> decode_ms;  ///< Each take's JPEG decode ("image_decode"), ms.
    uint64_t malformed = 0;         ///< Samples that did not decode (each named in a warning).
    size_t samples() const { return cameras.size() + maps.size() + images.size(); }
  };
  /// Takes every available sample into *r (the input thread, or Poll without it).
  void Take(Received* r);
  /// Gives *r to the assembler and the counters (the caller's thread).
  void Apply(Received&& r);
  void Run();
  /// Whether the thread's queue holds as many maps or images as the assembler keeps.
  bool QueueFull() const;
  /// Now on the node's clock (the counters'), else the system's: a sample's arrival.
  int64_t ArrivalNs() const;
  Reader<hullpipe_msg_CameraInfo> info_;
  std::set<int> calibration_warned_;  ///< Cameras whose changed calibration was named.
  Reader<hullpipe_msg_ObjectPixelMap> maps_;
  std::unique_ptr<Reader<hullpipe_msg_CameraImage>> images_;
  FramesetAssembler assembler_;
  /// The calibrations the takes have seen (SetCamera as the assembler's, in
  /// the same order), against which a map's size is checked before its runs
  /// are decoded (decoding allocates it): the taking side's own, so that the
  /// input thread never reads the assembler.
  FramesetAssembler sizes_;
  size_t max_pending_;
  uint64_t malformed_ = 0;
  RejectLog reject_log_;  // the rejected samples' lines, bounded (on either thread)
  uint64_t refused_ = 0;  ///< The readers' refused samples as of the last take (Poll's copy).
  int decode_threads_ = 0;
  NodeCounters* counters_ = nullptr;
  // The input thread (StartInputThread).
  const Participant& participant_;
  const WaitSet& caller_waitset_;
  std::unique_ptr<GuardCondition> wake_caller_;  ///< On the caller's waitset: Poll has work.
  std::unique_ptr<WaitSet> thread_waitset_;
  std::unique_ptr<GuardCondition> wake_thread_;  ///< On the thread's waitset: stop.
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> paused_{0};
  mutable std::mutex mutex_;
  std::condition_variable drained_;
  Received queue_;               ///< Guarded by mutex_.
  uint64_t queue_refused_ = 0;   ///< Guarded by mutex_: the readers' refused count at the last take.
  std::string failure_;          ///< Guarded by mutex_: why the thread stopped taking (Poll throws it).
  std::thread thread_;
};

}  // namespace hullpipe::dds
