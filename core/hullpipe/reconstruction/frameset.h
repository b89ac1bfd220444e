// Assembling framesets: all n cameras' object-pixel maps (and optionally colour
// images) of one frame, as they arrive one by one from the network. Latest wins:
// a bounded number of frames is kept pending; older ones are dropped and counted,
// never queued without bound. Transport-free, so it is tested without DDS.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/texture.h"
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe {

/// All cameras' data for one frame.
struct Frameset {
  uint64_t seq = 0;
  int64_t capture_time_ns = 0;
  double source_time_s = 0;         ///< Frame time in the source's timeline, seconds.
  std::vector<CameraMap> maps;      ///< In camera-id order.
  std::vector<CameraImage> images;  ///< In camera-id order (empty unless wanted).
};

/// Collects maps (and images) into framesets.
class FramesetAssembler {
 public:
  /// max_pending: frames kept while incomplete (>= 1). want_images: a frameset is
  /// complete only when every camera's image has arrived too.
  explicit FramesetAssembler(size_t max_pending = 6, bool want_images = false);

  /// Registers (or updates) a camera's calibration (from CameraInfo).
  void SetCamera(const Camera& camera);
  void SetWorkspace(const Aabb& workspace) { workspace_ = workspace; }
  /// The workspace from CameraInfo, else DefaultWorkspace of the cameras known.
  Aabb workspace() const;
  size_t camera_count() const { return cameras_.size(); }
  bool HasCamera(int id) const { return cameras_.count(id) > 0; }

  /// Adds one camera's map for frame `seq`. camera_count is how many cameras the
  /// sender's frameset has. A map of a camera with no calibration yet is parked
  /// with its frame (DDS does not order samples across topics, so CameraInfo may
  /// come second) and checked when the calibration arrives; if its frame is evicted
  /// first, it counts as rejected — and moves to dropped if the camera's CameraInfo
  /// comes later (a start-up race, not bad input). Returns false (and counts a rejection, *why
  /// says why) if the map's size differs from the calibration or camera_count is
  /// out of range; false (counted as dropped) if the frame is older than the newest
  /// frameset already taken.
  bool AddMap(int camera_id, uint64_t seq, int64_t capture_time_ns, int camera_count,
              cv::Mat map, std::string* why = nullptr, double source_time_s = 0);
  /// Adds one camera's colour image (any size) for frame `seq`; same rules.
  bool AddImage(int camera_id, uint64_t seq, int64_t capture_time_ns, cv::Mat image,
                std::string* why = nullptr);

  /// Sequence number of the newest complete frameset, if any.
  std::optional<uint64_t> NewestComplete() const;
  /// True if frame seq is complete.
  bool IsComplete(uint64_t seq) const;
  /// Removes and returns frameset `seq` if complete, dropping every older frame
  /// (complete ones count as dropped). nullopt if not complete.
  std::optional<Frameset> Take(uint64_t seq);
  /// Take(NewestComplete()).
  std::optional<Frameset> TakeNewest();
  /// True if frame seq can no longer arrive (older than what was taken or evicted).
  bool IsGone(uint64_t seq) const { return seq <= taken_up_to_; }

  /// A map or image more than kRestartGap frames older than the newest taken
  /// frameset means its capture source restarted (frame numbers start over): the
  /// assembler forgets what it had and takes the new run (counted in restarts()).
  /// A frame that is merely late is never that far behind (history depth 4).
  static constexpr uint64_t kRestartGap = 64;
  uint64_t restarts() const { return restarts_; }

  uint64_t dropped() const { return dropped_; }
  uint64_t rejected() const { return rejected_; }

 private:
  struct Pending {
    int64_t capture_time_ns = 0;
    double source_time_s = 0;
    int expected = 0;
    std::map<int, cv::Mat> maps, images;
  };
  void Evict(std::map<uint64_t, Pending>::iterator it);
  bool Complete(const Pending& p) const;
  Pending* Slot(uint64_t seq, int64_t t, int camera_count);
  bool Reject(std::string* why, std::string text);

  size_t max_pending_;
  bool want_images_;
  std::map<int, Camera> cameras_;
  Aabb workspace_;
  std::map<uint64_t, Pending> pending_;
  uint64_t taken_up_to_ = 0;
  uint64_t dropped_ = 0, rejected_ = 0, restarts_ = 0;
  void CheckRestart(uint64_t seq);
  std::map<int, uint64_t> evicted_uncalibrated_;  ///< Per camera id, maps evicted before its CameraInfo.
};

}  // namespace hullpipe
