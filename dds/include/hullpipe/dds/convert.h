// Conversion between hullpipe's core types and its DDS messages, with validation
// of everything that arrives from outside: a sample of the wrong size, a bad
// encoding or non-finite numbers raise MessageError (the node logs, counts it as
// rejected and goes on).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe.h"
#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/reconstruction/compositor.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/nodes/messages.h"
#include "hullpipe/nodes/node_counters.h"

namespace hullpipe::dds {

/// A received sample that cannot be used; what() says why in one line.
class MessageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Fills a CameraInfo from a camera and the rig's workspace (may be empty).
hullpipe_msg_CameraInfo CameraToMsg(const Camera& camera, const Aabb& workspace);
/// Validated Camera from a CameraInfo; *workspace (optional) gets its box.
Camera CameraFromMsg(const hullpipe_msg_CameraInfo& msg, Aabb* workspace = nullptr);

/// An outgoing sample that owns the buffers its sequences point at. Move-only
/// (moving keeps the heap buffers, so the pointers stay valid).
template <typename Msg>
struct OwnedSample {
  Msg msg{};
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> words;
  std::vector<float> floats;
  std::vector<hullpipe_msg_Vec3> vec3s;
  std::vector<hullpipe_msg_StageTiming> stages;
  std::vector<hullpipe_msg_CameraSkew> cameras;
  std::vector<std::string> strings;  ///< Reserved before use: their c_str() stay put.
  OwnedSample() = default;
  OwnedSample(const OwnedSample&) = delete;
  OwnedSample& operator=(const OwnedSample&) = delete;
  OwnedSample(OwnedSample&&) = default;
  OwnedSample& operator=(OwnedSample&&) = default;
};

/// Points an outgoing message's sequence (idlc's _maximum/_length/_buffer/
/// _release) at a vector's elements, without copying and without handing
/// Cyclone ownership: the vector must outlive the write.
template <typename Seq, typename T>
void Borrow(Seq* seq, std::vector<T>& v) {
  seq->_buffer = v.data();
  seq->_length = seq->_maximum = uint32_t(v.size());
  seq->_release = false;
}

/// ObjectPixelMap of one camera's map (CV_8UC1), run-length encoded.
/// cam_from_world: a tracked camera's pose at this frame (nullptr: a fixed camera).
OwnedSample<hullpipe_msg_ObjectPixelMap> MakeMapMessage(uint32_t camera_id, uint64_t frame_seq,
                                                        int64_t capture_time_ns, double source_time_s,
                                                        uint32_t camera_count, const cv::Mat& map,
                                                        const Rigid3d* cam_from_world = nullptr);
/// A tracked camera's pose of this frame; nullopt for a fixed camera. Throws
/// MessageError if the rotation is not orthonormal (1e-6) or a value not finite.
std::optional<Rigid3d> MapPoseFromMsg(const hullpipe_msg_ObjectPixelMap& msg);
/// Decoded map (CV_8UC1 0/255). Throws MessageError on a bad encoding or size.
cv::Mat MapFromMsg(const hullpipe_msg_ObjectPixelMap& msg);

/// CameraImage of a BGR image, raw (jpeg_quality <= 0) or JPEG.
OwnedSample<hullpipe_msg_CameraImage> MakeImageMessage(uint32_t camera_id, uint64_t frame_seq,
                                                       int64_t capture_time_ns, const cv::Mat& bgr,
                                                       int jpeg_quality);
/// Decoded BGR image. Throws MessageError on a bad encoding or size.
cv::Mat ImageFromMsg(const hullpipe_msg_CameraImage& msg);

/// ViewPose for a novel view, of run `run_id` (docs/reliability.md, "run id").
hullpipe_msg_ViewPose ViewToMsg(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq,
                                int64_t stamp_ns, uint64_t run_id = 0);
/// Validated NovelView (size 1..8192, finite, orthonormal rotation).
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

/// A head pose message of world_from_eye (metres, OpenCV eye frame).
hullpipe_msg_HeadPose HeadPoseToMsg(const Rigid3d& world_from_eye, uint32_t tracker_id, int64_t stamp_ns);
/// Validated world_from_eye (finite, rotation orthonormal with det +1 to 1e-6).
/// Throws MessageError.
Rigid3d HeadPoseFromMsg(const hullpipe_msg_HeadPose& msg);

/// VirtualObjectState of a sphere's state.
hullpipe_msg_VirtualObjectState VirtualObjectToMsg(const VirtualObjectSample& s);
/// Validated state (finite position, velocity and radius >= 0). Throws MessageError.
VirtualObjectSample VirtualObjectFromMsg(const hullpipe_msg_VirtualObjectState& msg);
/// CollisionReport of one object's step.
OwnedSample<hullpipe_msg_CollisionReport> MakeCollisionReportMessage(const CollisionReportSample& r);
/// NodeStats of a node's report.
OwnedSample<hullpipe_msg_NodeStats> MakeNodeStatsMessage(const nodes::NodeStatsSample& s, int64_t stamp_ns);
/// The report in a NodeStats sample (a missing stage name becomes "?"). Throws
/// MessageError for an empty node name, a name or stage name over 64 bytes, a
/// backend over 512, any of them not valid UTF-8 (or with NUL), or over 64 stages.
nodes::NodeStatsSample NodeStatsFromMsg(const hullpipe_msg_NodeStats& msg);

inline hullpipe_msg_Vec3 ToMsg(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
inline Eigen::Vector3d FromMsg(const hullpipe_msg_Vec3& v) { return {v.x, v.y, v.z}; }

}  // namespace hullpipe::dds
