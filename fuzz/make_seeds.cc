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
#include "hullpipe/dds/valid_samples.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_schemas.h"
#include "hullpipe/segmentation/object_pixel_map.h"
#include "hullpipe/testing/fixtures.h"

namespace fs = std::filesystem;
using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

void WriteFile(const fs::path& path, const std::vector<uint8_t>& bytes) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: fuzz_make_seeds OUT_DIR\n");
    return 1;
  }
  const fs::path out = argv[1];
  try {
    fs::create_directories(out);
    if (!std::getenv("CYCLONEDDS_URI") || !*std::getenv("CYCLONEDDS_URI")) {
      const std::string cfg = launch::WriteCycloneConfig((out / "cyclonedds.xml").string(), {});
      setenv("CYCLONEDDS_URI", ("file://" + cfg).c_str(), 1);
    }
    launch::DomainLease domain;
    Participant p(domain.id());
    const auto sphere = test::SphereViews(1, 64, 48, Eigen::Vector3d(0, 0, -1), 0.3)[0];
    const auto samples = ValidSampleOfEachTopic(p, sphere.camera, test::BigBox(), sphere.map);
    const auto& types = KnownTypes();
    fs::create_directories(out / "fuzz_recordings");
    fs::remove(out / "fuzz_recordings" / "seed.hullrec");
    fs::remove(out / "fuzz_recordings" / "seed_zstd.hullrec");
    record::RecordingWriter rec((out / "fuzz_recordings" / "seed.hullrec").string());
    // The same samples zstd-compressed, so the fuzzer reaches the decoder.
    record::WriterOptions zstd;
    zstd.compression = record::Compression::kZstd;
    record::RecordingWriter rec_zstd((out / "fuzz_recordings" / "seed_zstd.hullrec").string(), zstd);
    // MCAP, uncompressed, lz4 and zstd chunks (the reader picks the storage by
    // the magic, so the same target fuzzes the MCAP reader, its chunk path with
    // both decompressors and the expansion bounds, and its repair).
    for (const char* f : {"seed.mcap", "seed_lz4.mcap", "seed_zstd.mcap"}) fs::remove(out / "fuzz_recordings" / f);
    record::WriterOptions mcap;
    mcap.storage = record::Storage::kMcap;
    record::RecordingWriter rec_mcap((out / "fuzz_recordings" / "seed.mcap").string(), mcap);
    mcap.compression = record::Compression::kLz4;
    record::RecordingWriter rec_lz4((out / "fuzz_recordings" / "seed_lz4.mcap").string(), mcap);
    mcap.compression = record::Compression::kZstd;
    record::RecordingWriter rec_mcap_zstd((out / "fuzz_recordings" / "seed_zstd.mcap").string(), mcap);
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
      topic.type_description = IdlText();
      const int64_t id = rec.AddTopic(topic);
      rec.Append({id, int64_t(i) * 1'000'000, 1'000'000'000 + int64_t(i) * 1'000'000, it->second});
      for (record::RecordingWriter* w : {&rec_zstd, &rec_mcap, &rec_lz4, &rec_mcap_zstd}) {
        w->AddTopic(topic);
        w->Append({id, int64_t(i) * 1'000'000, 1'000'000'000 + int64_t(i) * 1'000'000, it->second});
        if (i % 4 == 3) w->Commit();  // several chunks
      }
    }
    rec.Commit();
    for (record::RecordingWriter* w : {&rec_zstd, &rec_mcap, &rec_lz4, &rec_mcap_zstd}) w->Commit();
    // The ROS 2 types hullpipe_ros2 reads (first byte 200 on: fuzz_wire_samples).
    {
      Rigid3d head;
      head.translation = Eigen::Vector3d(0.3, 0.2, -1.6);
      const auto pose = ros2::MakePoseStamped(head, 1'000'000'000, ros2::kWorldFrame);
      const auto tf = ros2::MakeCameraTransforms({sphere.camera}, 1'000'000'000);
      EyeViewsSample views;
      views.stamp_ns = 1'000'000'000;
      views.world_from_eye[1].translation = Eigen::Vector3d(0.064, 0, 0);
      views.fov[1] = views.fov[0].Mirrored();
      const auto eyes = ros2::MakeEyeViews(views, ros2::kWorldFrame);
      int k = 0;
      for (const auto& [name, msg] : std::vector<std::pair<std::string, const void*>>{
               {"geometry_msgs/msg/PoseStamped", &pose.msg},
               {"tf2_msgs/msg/TFMessage", &tf.msg},
               {"hullpipe_msgs/msg/EyeViews", &eyes.msg}}) {
        const KnownType kt = ros2::Ros2KnownType(name);
        std::vector<uint8_t> seed{uint8_t(200 + k)};
        const auto cdr = CdrWriter(p, kt, kt.qos, CdrWriter::Scope::kDecodeOnly).Encode(msg);
        seed.insert(seed.end(), cdr.begin(), cdr.end());
        WriteFile(out / "fuzz_wire_samples" / ("ros2_" + std::to_string(k++)), seed);
      }
    }
    // Maps: a silhouette of the sphere fixture, and the all-empty map.
    for (const auto& [name, map] :
         {std::pair{"sphere", sphere.map}, {"empty", cv::Mat(cv::Mat::zeros(48, 64, CV_8UC1))}}) {
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
