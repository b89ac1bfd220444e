// fuzz_make_seeds OUT_DIR: writes the seeds that need code to make into
// OUT_DIR/<target>/: a valid sample of every topic for fuzz_wire_samples (its
// first byte picks the topic), a small recording of them for fuzz_recordings,
// and valid maps for fuzz_map_runs. The file seeds (rig, scenes, CSVs) are
// copied by scripts/sanitize.sh.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/segmentation/object_pixel_map.h"
#include "hullpipe/testing/fixtures.h"

namespace fs = std::filesystem;
using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

void WriteFile(const fs::path& path, const std::vector<uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

// One valid sample of each known type, by type name.
std::map<std::string, std::vector<uint8_t>> Samples(const Participant& p) {
  std::map<std::string, std::vector<uint8_t>> out;
  auto encode = [&](const char* type, const void* sample) {
    for (const KnownType& t : KnownTypes())
      if (t.type_name == type) out[type] = CdrWriter(p, t, t.qos).Encode(sample);
  };
  const auto views = test::SphereViews(2, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3);
  const auto info = CameraToMsg(views[0].camera, test::BigBox());
  encode("hullpipe::msg::CameraInfo", &info);
  const auto map = MakeMapMessage(1, 1, 1'000'000'000, 0.04, 2, views[0].map);
  encode("hullpipe::msg::ObjectPixelMap", &map.msg);
  const auto image = MakeImageMessage(1, 1, 1'000'000'000, cv::Mat(12, 16, CV_8UC3, cv::Scalar(1, 2, 3)), 0);
  encode("hullpipe::msg::CameraImage", &image.msg);
  NovelView view;
  view.width = 32, view.height = 24, view.fx = view.fy = 30, view.cx = 16, view.cy = 12;
  const auto pose = ViewToMsg(view, 1, 1, 1'000'000'000);
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
  nodes::NodeStatsSample stats;
  stats.name = "recon0", stats.fps = 25, stats.frames_in = 10, stats.backend = "cpu";
  stats.stages["sweep"] = {4.0, 6.0};
  const auto st = MakeNodeStatsMessage(stats, 1'000'000'000);
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
  const auto head = HeadPoseToMsg(Rigid3d{}, 1, 1'000'000'000);
  encode("hullpipe::msg::HeadPose", &head);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR\n");
    return 1;
  }
  const fs::path out = argv[1];
  try {
    if (!std::getenv("CYCLONEDDS_URI") || !*std::getenv("CYCLONEDDS_URI")) {
      const std::string cfg = launch::WriteCycloneConfig((out / "cyclonedds.xml").string(), {});
      setenv("CYCLONEDDS_URI", ("file://" + cfg).c_str(), 1);
    }
    launch::DomainLease domain;
    Participant p(domain.id());
    const auto samples = Samples(p);
    const auto& types = KnownTypes();
    fs::create_directories(out / "fuzz_recordings");
    fs::remove(out / "fuzz_recordings" / "seed.hullrec");
    record::RecordingWriter rec((out / "fuzz_recordings" / "seed.hullrec").string());
    for (size_t i = 0; i < types.size(); ++i) {
      const auto it = samples.find(types[i].type_name);
      if (it == samples.end()) {
        std::fprintf(stderr, "fuzz_make_seeds: no seed sample of %s\n", types[i].type_name.c_str());
        return 1;
      }
      std::vector<uint8_t> seed{uint8_t(i)};
      seed.insert(seed.end(), it->second.begin(), it->second.end());
      WriteFile(out / "fuzz_wire_samples" / (std::to_string(i) + "_" + types[i].topic_name.substr(9)), seed);
      record::TopicInfo topic;
      topic.name = types[i].topic_name, topic.type = types[i].type_name, topic.keyed = types[i].keyed;
      topic.reliable = types[i].qos.reliable, topic.transient_local = types[i].qos.transient_local;
      topic.depth = types[i].qos.depth;
      const int64_t id = rec.AddTopic(topic);
      rec.Append({id, int64_t(i) * 1'000'000, 1'000'000'000 + int64_t(i) * 1'000'000, it->second});
    }
    rec.Commit();
    // Maps: a silhouette of the sphere fixture, and the all-empty map.
    const auto views = test::SphereViews(1, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3);
    for (const auto& [name, map] : {std::pair{"sphere", views[0].map}, {"empty", cv::Mat(cv::Mat::zeros(48, 64, CV_8UC1))}}) {
      const auto runs = RunLengthEncode(map);
      std::vector<uint8_t> bytes(8 + runs.size() * 4);
      const int32_t w = map.cols, h = map.rows;
      std::memcpy(bytes.data(), &w, 4);
      std::memcpy(bytes.data() + 4, &h, 4);
      std::memcpy(bytes.data() + 8, runs.data(), runs.size() * 4);
      WriteFile(out / "fuzz_map_runs" / name, bytes);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz_make_seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
