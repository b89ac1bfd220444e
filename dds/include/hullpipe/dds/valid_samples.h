// One valid sample of every topic of idl/hullpipe.idl, serialized as a writer
// sends it: the seeds of the wire fuzz test (tests/fuzz_test.cc) and of the
// wire fuzzer (fuzz/make_seeds.cc). Header-only; for tests and tools.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"

namespace hullpipe::dds {

/// By type name (KnownType::type_name), the XCDR1 bytes (4-byte header first)
/// of one valid sample of each known type. `camera` and `workspace` make the
/// CameraInfo; `map` (CV_8UC1) the ObjectPixelMap of camera 1. Times are fixed
/// (1 s after the epoch), so the bytes do not change between runs. Throws
/// DdsError if Cyclone cannot serialize a sample.
inline std::map<std::string, std::vector<uint8_t>> ValidSampleOfEachTopic(const Participant& p, const Camera& camera,
                                                                          const Aabb& workspace, const cv::Mat& map) {
  constexpr int64_t kStampNs = 1'000'000'000;
  std::map<std::string, std::vector<uint8_t>> out;
  auto encode = [&](const char* type, const void* sample) {
    for (const KnownType& t : KnownTypes())
      if (t.type_name == type) out[type] = CdrWriter(p, t, t.qos).Encode(sample);
  };
  const auto info = CameraToMsg(camera, workspace);
  encode("hullpipe::msg::CameraInfo", &info);
  const auto map_msg = MakeMapMessage({1, 1, kStampNs, 0.04}, 2, map);
  encode("hullpipe::msg::ObjectPixelMap", &map_msg.msg);
  // A region of its image (capture_node --image-region), so that every field is in play.
  const auto image =
      MakeImageMessage(1, 1, kStampNs, cv::Mat(12, 16, CV_8UC3, cv::Scalar(1, 2, 3)), 0, cv::Rect(2, 3, 8, 6));
  encode("hullpipe::msg::CameraImage", &image.msg);
  NovelView view;
  view.width = 32, view.height = 24, view.fx = view.fy = 30, view.cx = 16, view.cy = 12;
  const auto pose = ViewToMsg(view, 1, 1, kStampNs);
  encode("hullpipe::msg::ViewPose", &pose);
  HullTile tile;
  tile.rect = {0, 0, 8, 8};
  tile.depth = cv::Mat(8, 8, CV_32FC1, cv::Scalar(1));
  tile.colour = cv::Mat(8, 8, CV_8UC3, cv::Scalar(9));
  const auto hull = MakeHullViewMessage(tile, 1);
  encode("hullpipe::msg::HullView", &hull.msg);
  VirtualObjectSample obj;
  obj.object_id = 1, obj.frame_seq = 1, obj.radius = 0.1, obj.position = {0, 0, -1};
  const auto state = VirtualObjectToMsg(obj);
  encode("hullpipe::msg::VirtualObjectState", &state);
  CollisionReportSample report;
  report.object_id = 1, report.frame_seq = 1, report.triangle_ids = {3};
  report.collision_points = {{0, 0, -1}};
  const auto rep = MakeCollisionReportMessage(report);
  encode("hullpipe::msg::CollisionReport", &rep.msg);
  NodeStatsSample stats;
  stats.name = "recon0", stats.fps = 25, stats.frames_in = 10, stats.backend = "cpu";
  stats.stages["sweep"] = {4.0, 3.5, 6.0, 120};
  stats.host = "lab-pc-1";
  const auto st = MakeNodeStatsMessage(stats, kStampNs);
  encode("hullpipe::msg::NodeStats", &st.msg);
  VirtualMeshSample mesh;
  mesh.object_id = 100, mesh.kind = hullpipe_msg_MESH_KIND_CLOTH, mesh.frame_seq = 1;
  mesh.draw.vertices = {{0, 0, -1}, {0.1, 0, -1}, {0, 0.1, -1}};
  mesh.draw.triangles = {{0, 1, 2}};
  mesh.draw.colliding = {1};
  const auto m = MakeVirtualMeshMessage(mesh);
  encode("hullpipe::msg::VirtualMesh", &m.msg);
  hullpipe_msg_SceneCommand command{};
  command.command = hullpipe_msg_SCENE_COMMAND_SET_SPACING, command.value = 0.2;
  encode("hullpipe::msg::SceneCommand", &command);
  const auto head = HeadPoseToMsg(Rigid3d{}, 1, kStampNs);
  encode("hullpipe::msg::HeadPose", &head);
  const auto camera_pose = CameraPoseToMsg(camera.cam_from_world.Inverse(), uint32_t(camera.id), kStampNs);
  encode("hullpipe::msg::CameraPose", &camera_pose);
  const StereoViews stereo = MakeStereoViews(Rigid3d{}, StereoOptions{});
  EyeViewsSample eyes;
  eyes.tracker_id = 1, eyes.stamp_ns = kStampNs;
  eyes.world_from_eye = {stereo.eye[0].world_from_eye, stereo.eye[1].world_from_eye};
  eyes.fov = {StereoOptions{}.left, StereoOptions{}.right};
  const auto eye_views = EyeViewsToMsg(eyes);
  encode("hullpipe::msg::EyeViews", &eye_views);
  ModelPartSample part;
  part.object_id = 1000, part.model_id = 1000, part.name = "part", part.file = "model.glb";
  part.vertices = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}};
  part.triangles = {{0, 1, 2}};
  const auto mp = MakeModelPartMessage(part);
  encode("hullpipe::msg::ModelPart", &mp.msg);
  ModelStateSample model;
  model.model_id = 1000, model.frame_seq = 1, model.triangles = 1;
  model.parts.push_back({{0, 0, -1}, {1, 0, 0, 0}, kPartNear, 0.02});
  const auto ms = MakeModelStateMessage(model);
  encode("hullpipe::msg::ModelState", &ms.msg);
  const auto composited = MakeCompositedViewMessage(cv::Mat(24, 32, CV_8UC3, cv::Scalar(40, 80, 120)), 1, 1,
                                                    kStampNs, 7, {1280, 90});
  encode("hullpipe::msg::CompositedView", &composited.msg);
  return out;
}

}  // namespace hullpipe::dds
