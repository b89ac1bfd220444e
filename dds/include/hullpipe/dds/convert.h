// Conversion between hullpipe's core types and its DDS messages, with validation
// of everything that arrives from outside: a sample of the wrong size, a bad
// encoding or non-finite numbers raise MessageError (the node logs, counts it as
// rejected and goes on). Library hullpipe_dds: it links the core types it
// converts (cameras, views, maps); the Cyclone wrapper beneath it
// (hullpipe_dds_base: dds.h, cdr.h, node.h) links none.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe.h"
#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/dds/node_stats_convert.h"
#include "hullpipe/dds/owned_sample.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/segmentation/object_pixel_map.h"

namespace hullpipe::dds {

/// Fills a CameraInfo from a camera and the rig's workspace (may be empty).
hullpipe_msg_CameraInfo CameraToMsg(const Camera& camera, const Aabb& workspace);
/// Validated Camera from a CameraInfo; *workspace (optional) gets its box.
Camera CameraFromMsg(const hullpipe_msg_CameraInfo& msg, Aabb* workspace = nullptr);

/// ObjectPixelMap of one camera's map (CV_8UC1, non-zero = object), run-length
/// encoded, stamped with `stamp`; camera_count: cameras in the rig's frameset.
/// cam_from_world: a tracked camera's pose at this frame (nullptr: a fixed camera).
OwnedSample<hullpipe_msg_ObjectPixelMap> MakeMapMessage(const FrameStamp& stamp, uint32_t camera_count,
                                                        const cv::Mat& map, const Rigid3d* cam_from_world = nullptr);
/// A tracked camera's pose of this frame; nullopt for a fixed camera. Throws
/// MessageError if the rotation is not orthonormal (1e-6) or a value not finite.
std::optional<Rigid3d> MapPoseFromMsg(const hullpipe_msg_ObjectPixelMap& msg);
/// Decoded map (CV_8UC1 0/255). Throws MessageError on a bad encoding or size.
cv::Mat MapFromMsg(const hullpipe_msg_ObjectPixelMap& msg);
/// Decoded map with its object pixels' bounding rectangle and count, found from
/// the runs. Throws MessageError on a bad encoding or size.
DecodedMap DecodedMapFromMsg(const hullpipe_msg_ObjectPixelMap& msg);

/// CameraImage of a BGR image, raw (jpeg_quality <= 0) or JPEG. With `region`
/// (image pixels, clipped to the image) only that part is sent, as
/// CameraImage's region (capture_node --image-region; docs/gpu.md); an empty
/// one sends no data, a region of the whole image is sent as the whole image.
OwnedSample<hullpipe_msg_CameraImage> MakeImageMessage(uint32_t camera_id, uint64_t frame_seq,
                                                       int64_t capture_time_ns, const cv::Mat& bgr,
                                                       int jpeg_quality,
                                                       const std::optional<cv::Rect>& region = std::nullopt);
/// CameraImage of a region of an image: `part` (CV_8UC3) holds the pixels of
/// `rect` of a whole image of `whole` size (rect within it; an empty rect and
/// part send no data). A rect of the whole image is sent as the whole image.
OwnedSample<hullpipe_msg_CameraImage> MakeImageRegionMessage(uint32_t camera_id, uint64_t frame_seq,
                                                             int64_t capture_time_ns, const cv::Mat& part,
                                                             const cv::Rect& rect, cv::Size whole, int jpeg_quality);
/// True if the message holds only a region of its image (full_width or
/// full_height set).
bool ImageHasRegion(const hullpipe_msg_CameraImage& msg);
/// The size of the message's whole image: a region's whole size, else its
/// own (each side at most 2^30, so that it fits an int).
cv::Size WholeImageSize(const hullpipe_msg_CameraImage& msg);
/// Throws MessageError unless the message's whole image (WholeImageSize) is
/// at most width x height, its camera's calibrated size: a reader checks it
/// before ImageFromMsg allocates that image (a region's whole image costs its
/// size whatever the message's).
void CheckImageWithin(const hullpipe_msg_CameraImage& msg, int width, int height);

/// The cameras' calibrated sizes as a reader without a frameset assembler
/// hears their CameraInfo (the bridges, the export), at most kMaxCameras of
/// them: what bounds a region's whole image before ImageFromMsg makes it.
class RegionBounds {
 public:
  static constexpr size_t kMaxCameras = 256;
  /// Keeps camera camera_id's calibrated size (a camera past kMaxCameras is not kept).
  void Calibrated(uint32_t camera_id, int width, int height);
  /// Throws MessageError if `msg` holds a region (ImageHasRegion) of a camera
  /// with no calibration kept, or whose whole image its calibration does not
  /// bound (CheckImageWithin). A whole image passes.
  void CheckRegion(const hullpipe_msg_CameraImage& msg) const;

 private:
  std::map<uint32_t, cv::Size> sizes_;
};
/// Decoded BGR image, the whole image's size: a region's pixels at its place,
/// black elsewhere. Throws MessageError on a bad encoding or size, or a region
/// not within its whole image.
cv::Mat ImageFromMsg(const hullpipe_msg_CameraImage& msg);

/// Throws MessageError ("<who>data is not a JPEG of the stated size WxH") unless
/// `data` (n bytes) starts with a JPEG header of exactly width x height
/// (hullpipe/util/image_file.h): only such bytes may reach a decoder or be
/// passed on to a viewer. Nothing is decoded.
void CheckJpegOfSize(const std::string& who, const uint8_t* data, size_t n, uint32_t width, uint32_t height);

/// How a CompositedView's image is encoded (render_node --publish-max-side,
/// --publish-jpeg-quality).
struct ViewEncoding {
  int max_side = 1280;    ///< The image's longer side at most this, px, in [16, 16384].
  int jpeg_quality = 90;  ///< JPEG quality in [1, 100].
};

/// The CompositedView of render_node's composited frame `bgr` (CV_8UC3, the
/// view's size) of frameset `frame_seq` (captured at capture_time_ns, shown for
/// pose `pose_seq`, run `run_id`, for `eye`): scaled down with area
/// interpolation so that its longer side is at most encoding.max_side px
/// (aspect kept), then JPEG. Throws MessageError for an empty frame or an
/// encoding outside its ranges.
OwnedSample<hullpipe_msg_CompositedView> MakeCompositedViewMessage(const cv::Mat& bgr, uint64_t pose_seq,
                                                                   uint64_t frame_seq, int64_t capture_time_ns,
                                                                   uint64_t run_id, const ViewEncoding& encoding,
                                                                   ViewEye eye = ViewEye::kMono);
/// The eye of a ViewPose's or CompositedView's `eye` field (VIEW_EYE_*).
/// Throws MessageError naming `who` for a value that is none of them.
ViewEye ViewEyeFromMsg(const std::string& who, uint8_t eye);
/// Checks a CompositedView without decoding it: image and view sizes in
/// [1, 16384], the image no larger than the view, `data` a JPEG of the stated
/// size, the eye one of VIEW_EYE_*. Throws MessageError naming what is wrong.
void CheckCompositedViewMsg(const hullpipe_msg_CompositedView& msg);
/// The decoded BGR image (CV_8UC3, width x height) after CheckCompositedViewMsg.
/// Throws MessageError.
cv::Mat CompositedViewFromMsg(const hullpipe_msg_CompositedView& msg);

/// ViewPose for a novel view, of run `run_id` (docs/reliability.md, "run id"),
/// for `eye` (a headset's left or right eye; kMono: a monitor's one view).
hullpipe_msg_ViewPose ViewToMsg(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq,
                                int64_t stamp_ns, uint64_t run_id = 0, ViewEye eye = ViewEye::kMono);
/// Validated NovelView (size 1..8192, finite, orthonormal rotation, the eye one
/// of VIEW_EYE_*: its value is ViewEyeFromMsg(msg.eye)).
NovelView ViewFromMsg(const hullpipe_msg_ViewPose& msg);

OwnedSample<hullpipe_msg_HullView> MakeHullViewMessage(const HullTile& tile, uint32_t planes);
/// Validated tile (lengths match the rectangle). Throws MessageError.
HullTile TileFromMsg(const hullpipe_msg_HullView& msg);

/// The message of a mesh (vertices as floats). Throws MessageError if the mesh
/// breaks the message's limits (too many vertices, colliding of the wrong length).
OwnedSample<hullpipe_msg_VirtualMesh> MakeVirtualMeshMessage(const VirtualMeshSample& mesh);
/// Validated mesh: vertex floats a multiple of 3 and finite, triangle indices in
/// range, colliding of the right length, a known kind. Throws MessageError.
VirtualMeshSample VirtualMeshFromMsg(const hullpipe_msg_VirtualMesh& msg);

/// The message of a model part (vertices as floats). Throws MessageError past
/// the message's limits (2,000,000 vertices, indices out of range).
OwnedSample<hullpipe_msg_ModelPart> MakeModelPartMessage(const ModelPartSample& part);
/// Validated part: vertex floats a multiple of 3 and finite, triangle indices
/// in range, part_index < part_count, object_id = model_id + part_index.
/// Throws MessageError.
ModelPartSample ModelPartFromMsg(const hullpipe_msg_ModelPart& msg);
/// The message of a model's state.
OwnedSample<hullpipe_msg_ModelState> MakeModelStateMessage(const ModelStateSample& state);
/// Validated state: finite poses with unit quaternions (to 1e-6), known
/// contact values, at most 1,000,000 parts. Throws MessageError.
ModelStateSample ModelStateFromMsg(const hullpipe_msg_ModelState& msg);

/// A head pose message of world_from_eye (metres, OpenCV eye frame).
hullpipe_msg_HeadPose HeadPoseToMsg(const Rigid3d& world_from_eye, uint32_t tracker_id, int64_t stamp_ns);
/// Validated world_from_eye (finite, rotation orthonormal with det +1 to 1e-6).
/// Throws MessageError.
Rigid3d HeadPoseFromMsg(const hullpipe_msg_HeadPose& msg);

/// An HMD runtime's two views (EyeViews; world_from_eye in OpenCV's eye axes,
/// sent as XrPosefs).
hullpipe_msg_EyeViews EyeViewsToMsg(const EyeViewsSample& views);
/// Validated views: finite, non-zero quaternions, each fov as EyeFov::Check.
/// Throws MessageError naming the tracker and the eye.
EyeViewsSample EyeViewsFromMsg(const hullpipe_msg_EyeViews& msg);

/// A tracked camera's pose message of world_from_camera (metres, OpenCV
/// camera frame), measured at `stamp_ns`.
hullpipe_msg_CameraPose CameraPoseToMsg(const Rigid3d& world_from_camera, uint32_t camera_id, int64_t stamp_ns);
/// Validated world_from_camera (finite, rotation orthonormal with det +1 to
/// 1e-6). Throws MessageError naming the camera.
Rigid3d CameraPoseFromMsg(const hullpipe_msg_CameraPose& msg);

/// VirtualObjectState of a sphere's state.
hullpipe_msg_VirtualObjectState VirtualObjectToMsg(const VirtualObjectSample& s);
/// Validated state (finite position, velocity and radius >= 0). Throws MessageError.
VirtualObjectSample VirtualObjectFromMsg(const hullpipe_msg_VirtualObjectState& msg);
/// CollisionReport of one object's step.
OwnedSample<hullpipe_msg_CollisionReport> MakeCollisionReportMessage(const CollisionReportSample& r);
/// Validated report: at most kMaxReportEntries triangle ids and collision
/// points, every point and response vector finite, hull_velocity_status a
/// HULL_VELOCITY_* value. The response fields are read only when has_response
/// (zero otherwise, as MakeCollisionReportMessage writes them). Throws
/// MessageError naming the field.
CollisionReportSample CollisionReportFromMsg(const hullpipe_msg_CollisionReport& msg);
/// Most triangle ids or collision points one CollisionReport may carry (the
/// largest mesh VirtualMesh carries: 200,000 vertices).
inline constexpr uint32_t kMaxReportEntries = 2000000;
}  // namespace hullpipe::dds
