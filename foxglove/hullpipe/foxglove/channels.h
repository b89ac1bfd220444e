// The viewable channels (docs/recording.md, "Viewable channels"): hullpipe's
// samples turned into messages of Foxglove's well-known schemas (JSON-encoded,
// `jsonschema` schemas), which Foxglove and Lichtblick draw in their Image, 3D
// and Plot panels with no plugin. Used by `hullpipe_record export --foxglove`
// (into an MCAP file) and by hullpipe_bridge (live, over the WebSocket):
//   /foxglove/camN/image              foxglove.CompressedImage (JPEG of the colour
//                                     image; a JPEG on the wire is passed through)
//   /foxglove/camN/object_pixel_map   foxglove.CompressedImage (PNG of the map)
//   /foxglove/camN/calibration        foxglove.CameraCalibration (pixel centres at
//                                     integers, as Foxglove and ROS put them)
//   /foxglove/tf                      foxglove.FrameTransforms (world -> camN)
//   /foxglove/hull_view               foxglove.CompressedImage (the composited tiles)
//   /foxglove/composited              foxglove.CompressedImage (render_node's composited
//                                     frame: hull and virtual objects; its JPEG passed through)
//   /foxglove/hull_view/left, /right  the same for a headset's eyes (render_node --stereo:
//   /foxglove/composited/left, /right ViewPose.eye, CompositedView.eye; docs/hmd.md)
//   /foxglove/hull_points             foxglove.PointCloud (the hull seen from the view:
//                                     the tiles' depth, every 4th pixel, in the eye
//                                     frame placed at the view's pose; in stereo the
//                                     left eye's: one cloud per frameset)
//   /foxglove/scene                   foxglove.SceneUpdate (balls, red while colliding;
//                                     collision points as small red spheres; cloth and
//                                     payload meshes with their colliding triangles red;
//                                     the CAD models' parts at their poses, red where
//                                     the hull touches them, amber near it)
//   /foxglove/node_stats              hullpipe.NodeStatsPlot (fps, latencies: plottable)
// Frames: "world" is the rig's world (metres), "camN" the OpenCV camera frame of
// camera N, "view" the composited view's eye frame ("view_left", "view_right":
// a headset's eyes).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_stats.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"

namespace hullpipe::foxglove {

/// One derived message.
struct Message {
  std::string topic;        ///< e.g. "/foxglove/cam1/image".
  std::string schema_name;  ///< e.g. "foxglove.CompressedImage".
  int64_t stamp_ns = 0;     ///< The sample's capture time (or arrival, for calibration and stats).
  /// Non-empty for state that a late viewer needs (calibration, transforms,
  /// model parts): the latest message of each (topic, latch_key) describes it.
  std::string latch_key;
  std::string json;  ///< The message, JSON text in the schema.
};

/// A derived channel: topic, schema name and the schema's JSON Schema text.
struct ChannelSpec {
  std::string topic, schema_name, schema;
};

/// The channels that do not depend on the rig (tf, hull_view and composited
/// with their left and right eyes', hull_points, scene, node_stats).
std::vector<ChannelSpec> FixedChannels();
/// The three channels of camera `camera_id` (image, object_pixel_map,
/// calibration).
std::vector<ChannelSpec> CameraChannels(uint32_t camera_id);
/// The camera a per-camera derived topic belongs to ("/foxglove/cam7/image": 7),
/// or -1 for any other topic.
int64_t CameraOfTopic(const std::string& topic);
/// The JSON Schema text of a derived schema name ("foxglove.CompressedImage",
/// ...). Throws std::out_of_range for a name no derived channel has.
const std::string& SchemaText(const std::string& schema_name);
/// The hullpipe types (IDL scoped names) a derived topic is made from; empty
/// for a topic that is not a derived one.
std::vector<std::string> SourceTypes(const std::string& topic);

/// Turns hullpipe samples into derived messages. Not thread-safe. Bounded: it
/// keeps the 256 newest view poses, the tiles of views not yet whole as
/// TileSet bounds them (hullpipe/reconstruction/tile_set.h) and the parts of at
/// most 4096 models (the geometry a validated ModelPart message may carry).
class Deriver {
 public:
  using Sink = std::function<void(Message)>;
  /// Whether anyone wants a topic; derivations nobody wants (a JPEG encode) are
  /// skipped. Empty: every topic is wanted.
  using Wanted = std::function<bool(const std::string& topic)>;

  /// `participant` is used to deserialize samples (dds::CdrWriter::Decode)
  /// and must outlive the Deriver.
  Deriver(const dds::Participant& participant, Sink sink, Wanted wanted = {});
  ~Deriver();

  /// A sample of hullpipe type `type_name` (CDR with its 4-byte header, as on
  /// the wire and in recordings), received at `arrival_ns`: sends what it
  /// derives to the sink. Returns false (and sends nothing) if the sample does
  /// not decode or is refused by the message's validation; never throws for
  /// bad bytes.
  bool Add(const std::string& type_name, const std::vector<uint8_t>& cdr, int64_t arrival_ns);

  /// The derivations themselves, for decoded samples.
  void Calibration(int64_t stamp_ns, const hullpipe_msg_CameraInfo& m);
  void Image(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& bgr);
  void Map(int64_t stamp_ns, uint32_t camera_id, const cv::Mat& map);
  /// The composited tiles of a view of `eye` (its ViewPose's; kMono: the one
  /// view): /foxglove/hull_view, or its /left or /right.
  void HullView(int64_t stamp_ns, const cv::Mat& bgr, ViewEye eye = ViewEye::kMono);
  /// The hull points of a composited view: `depth` (CV_32FC1 eye z metres, <= 0
  /// or not finite: no hull) of the view `view` (its intrinsics and pose).
  void HullPoints(int64_t stamp_ns, const NovelView& view, const cv::Mat& depth);
  void Object(int64_t stamp_ns, const VirtualObjectSample& o);
  void Collision(int64_t stamp_ns, const hullpipe_msg_CollisionReport& m);
  void Mesh(int64_t stamp_ns, const VirtualMeshSample& mesh);
  void Part(const ModelPartSample& part);
  void Model(int64_t stamp_ns, const ModelStateSample& state);
  void Stats(int64_t stamp_ns, const NodeStatsSample& st);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hullpipe::foxglove
