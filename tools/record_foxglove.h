// `hullpipe_record export --foxglove` (docs/recording.md, "Viewable channels"): an
// MCAP file for people who want to look, not decode — the recording's own
// channels (cdr, omgidl) beside derived channels in Foxglove's well-known schemas
// (JSON-encoded, `jsonschema` schemas), which Foxglove and Lichtblick draw in
// their Image, 3D and Plot panels with no plugin:
//   /foxglove/camN/image              foxglove.CompressedImage (JPEG of the colour image)
//   /foxglove/camN/object_pixel_map   foxglove.CompressedImage (PNG of the map)
//   /foxglove/camN/calibration        foxglove.CameraCalibration (OpenCV pixel centres)
//   /foxglove/tf                      foxglove.FrameTransforms (world -> camN)
//   /foxglove/hull_view               foxglove.CompressedImage (the composited tiles)
//   /foxglove/hull_points             foxglove.PointCloud (the hull seen from the view:
//                                     the tiles' depth, every 4th pixel, in the eye frame
//                                     placed at the view's pose)
//   /foxglove/scene                   foxglove.SceneUpdate (balls, red while colliding;
//                                     collision points as small red spheres)
//   /foxglove/node_stats              hullpipe.NodeStatsPlot (fps, latencies: plottable)
// Done at export, not while recording: the recorder keeps the traffic untouched
// and costs nothing extra; the derivation (JPEG, transforms) happens once, later.
#pragma once

#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "hullpipe/dds/convert.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_stats.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/reconstruction/plane_sweep.h"

namespace hullpipe::record {

/// Writes the viewable MCAP. Not thread-safe.
class FoxgloveExport {
 public:
  /// Creates `path` (MCAP, zstd chunks; never overwritten). Throws RecordingError.
  explicit FoxgloveExport(const std::string& path);
  /// A recorded sample, copied untouched on its own channel (topic added once).
  /// Derived messages written after it are logged at its arrival time (their
  /// timestamps are the capture times).
  void Raw(const TopicInfo& topic, const Sample& sample);
  /// CameraCalibration of the camera, and its world -> camN transform.
  void Calibration(int64_t stamp_ns, const hullpipe_msg_CameraInfo& m);
  void Image(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& bgr);
  void Map(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& map);
  void HullView(int64_t stamp_ns, const cv::Mat& bgr);
  /// The hull points of a composited view: `depth` (CV_32FC1 eye z metres, <= 0
  /// or not finite: no hull) of the view `view` (its intrinsics and pose).
  void HullPoints(int64_t stamp_ns, const NovelView& view, const cv::Mat& depth);
  void Object(int64_t stamp_ns, const VirtualObjectSample& o);
  void Collision(int64_t stamp_ns, const hullpipe_msg_CollisionReport& m);
  void Stats(int64_t stamp_ns, const NodeStatsSample& st);
  /// Derived messages written, per channel.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const std::string& path() const { return path_; }

 private:
  void Json(const std::string& topic, const std::string& schema, const char* schema_json, int64_t stamp_ns,
            const nlohmann::json& message);
  void Compressed(const std::string& topic, int64_t stamp_ns, const std::string& frame, const cv::Mat& image,
                  const char* format);
  std::string path_;
  RecordingWriter w_;
  std::map<std::string, int64_t> ids_;  // channel topic -> id
  std::map<std::string, int64_t> counts_;
  int64_t appended_ = 0;
  int64_t log_ns_ = -1;  // the arrival of the raw sample a derived one comes from
};

}  // namespace hullpipe::record
