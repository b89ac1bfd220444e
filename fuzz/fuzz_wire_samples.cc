// libFuzzer: samples on the wire. The first byte picks one of the topics of
// idl/hullpipe.idl (dds/cdr.h KnownTypes; bytes below kRos2First), or from
// kRos2First on one of the ROS 2 types hullpipe_ros2 reads from a ROS 2
// network (a tracker's PoseStamped, /tf's TFMessage, a headset's EyeViews:
// docs/ros2.md); the rest is
// that sample's CDR with its 4-byte header, as a writer on the domain (or a
// recording) could send it.
// Cyclone deserializes it (its own checks); what it accepts goes through the
// same converters the nodes use (dds/convert.h: sizes, lengths, finiteness,
// run-length decoding, UTF-8), which may only refuse with MessageError.
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_schemas.h"

namespace {

using namespace hullpipe;
using namespace hullpipe::dds;

struct Decoders {
  launch::DomainLease domain;  // a domain of our own, as every multi-process run
  std::unique_ptr<Participant> participant;
  std::vector<std::unique_ptr<CdrWriter>> writers;  // one per known type, for its sertype
  std::vector<KnownType> ros2_types;                 // what hullpipe_ros2 reads
  std::vector<std::unique_ptr<CdrWriter>> ros2_writers;
};

constexpr uint8_t kRos2First = 200;

// hullpipe_ros2's checks of a tracker's pose (the clock at its own stamp, so
// the skew check passes and the rest is reached).
void ConvertRos2(const std::string& type, const void* sample) {
  ros2::PoseCheck check;
  if (type == "geometry_msgs/msg/PoseStamped") {
    const auto& m = *static_cast<const geometry_msgs_msg_dds__PoseStamped_*>(sample);
    check.now_ns = m.header.stamp.nanosec < 1000000000u ? ros2::NanosecondsOf(m.header.stamp) : 0;
    ros2::HeadFromPoseStamped(m, check);
  } else if (type == "hullpipe_msgs/msg/EyeViews") {
    const auto& m = *static_cast<const hullpipe_msgs_msg_dds__EyeViews_*>(sample);
    check.now_ns = m.header.stamp.nanosec < 1000000000u ? ros2::NanosecondsOf(m.header.stamp) : 0;
    const EyeViewsSample views = ros2::EyeViewsFromRos2(m, check, 20);
    dds::EyeViewsFromMsg(dds::EyeViewsToMsg(views));  // what the bridge passes on is valid
  } else if (type == "tf2_msgs/msg/TFMessage") {
    const auto& m = *static_cast<const tf2_msgs_msg_dds__TFMessage_*>(sample);
    const uint32_t n = std::min(m.transforms._length, ros2::kMaxTransformsPerMessage);
    for (uint32_t i = 0; i < n; ++i) {
      try {
        ros2::HeadFromTransform(m.transforms._buffer[i], check);
      } catch (const MessageError&) {
      }
    }
  }
}

Decoders* g = nullptr;

void Convert(const std::string& type, const void* sample) {
  if (type == "hullpipe::msg::CameraInfo") {
    Aabb ws;
    CameraFromMsg(*static_cast<const hullpipe_msg_CameraInfo*>(sample), &ws);
  } else if (type == "hullpipe::msg::ObjectPixelMap") {
    const auto& m = *static_cast<const hullpipe_msg_ObjectPixelMap*>(sample);
    MapPoseFromMsg(m);
    MapFromMsg(m);
  } else if (type == "hullpipe::msg::CameraImage") {
    // As every reader does (the frameset input, the bridges, the export): a
    // region's whole image is bounded by its camera's calibration before it is
    // made. A 1024x1024 calibration (the published dome's width) keeps each
    // execution cheap; without it a region's two numbers make canvases of
    // 800 MB. (A whole image's size is bounded by its own data.)
    const auto& m = *static_cast<const hullpipe_msg_CameraImage*>(sample);
    if (ImageHasRegion(m)) CheckImageWithin(m, 1024, 1024);
    ImageFromMsg(m);
  } else if (type == "hullpipe::msg::ViewPose") {
    ViewFromMsg(*static_cast<const hullpipe_msg_ViewPose*>(sample));
  } else if (type == "hullpipe::msg::HullView") {
    TileFromMsg(*static_cast<const hullpipe_msg_HullView*>(sample));
  } else if (type == "hullpipe::msg::VirtualMesh") {
    VirtualMeshFromMsg(*static_cast<const hullpipe_msg_VirtualMesh*>(sample));
  } else if (type == "hullpipe::msg::HeadPose") {
    HeadPoseFromMsg(*static_cast<const hullpipe_msg_HeadPose*>(sample));
  } else if (type == "hullpipe::msg::VirtualObjectState") {
    VirtualObjectFromMsg(*static_cast<const hullpipe_msg_VirtualObjectState*>(sample));
  } else if (type == "hullpipe::msg::NodeStats") {
    NodeStatsFromMsg(*static_cast<const hullpipe_msg_NodeStats*>(sample));
  } else if (type == "hullpipe::msg::ModelPart") {
    ModelPartFromMsg(*static_cast<const hullpipe_msg_ModelPart*>(sample));
  } else if (type == "hullpipe::msg::ModelState") {
    ModelStateFromMsg(*static_cast<const hullpipe_msg_ModelState*>(sample));
  } else if (type == "hullpipe::msg::CompositedView") {
    CompositedViewFromMsg(*static_cast<const hullpipe_msg_CompositedView*>(sample));
  } else if (type == "hullpipe::msg::CameraPose") {
    CameraPoseFromMsg(*static_cast<const hullpipe_msg_CameraPose*>(sample));
  } else if (type == "hullpipe::msg::EyeViews") {
    EyeViewsFromMsg(*static_cast<const hullpipe_msg_EyeViews*>(sample));
  } else if (type == "hullpipe::msg::CollisionReport") {
    // hullpipe_ros2 and the bag export read it whole, then make ROS 2's.
    const CollisionReportSample r = CollisionReportFromMsg(*static_cast<const hullpipe_msg_CollisionReport*>(sample));
    (void)ros2::MakeCollisionReport(r);
  }
  // SceneCommand: only range-checked by sim_node; Cyclone's deserialization
  // above is what it relies on.
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (!std::getenv("CYCLONEDDS_URI") || !*std::getenv("CYCLONEDDS_URI")) {
    // Loopback only, no multicast: nothing leaves the machine.
    launch::CycloneConfigOptions o;
    const std::string path = launch::WriteCycloneConfig(
        (std::string(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp") + "/hullpipe_fuzz_cyclonedds.xml"), o);
    setenv("CYCLONEDDS_URI", ("file://" + path).c_str(), 1);
  }
  g = new Decoders;
  g->participant = std::make_unique<Participant>(g->domain.id());
  for (const KnownType& t : KnownTypes()) g->writers.push_back(std::make_unique<CdrWriter>(*g->participant, t, t.qos));
  for (const char* name : {"geometry_msgs/msg/PoseStamped", "tf2_msgs/msg/TFMessage", "hullpipe_msgs/msg/EyeViews"}) {
    g->ros2_types.push_back(ros2::Ros2KnownType(name));
    g->ros2_types.back().type_name = name;
    g->ros2_writers.push_back(std::make_unique<CdrWriter>(*g->participant, g->ros2_types.back(),
                                                          g->ros2_types.back().qos, CdrWriter::Scope::kDecodeOnly));
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool ros = data[0] >= kRos2First;
  const auto& types = ros ? g->ros2_types : KnownTypes();
  const size_t which = (ros ? data[0] - kRos2First : data[0]) % types.size();
  const KnownType& type = types[which];
  const CdrWriter& decoder = ros ? *g->ros2_writers[which] : *g->writers[which];
  const std::vector<uint8_t> cdr(data + 1, data + size);
  // A zeroed sample of the type, aligned for any of its members.
  std::vector<std::max_align_t> storage((type.descriptor->m_size + sizeof(std::max_align_t) - 1) /
                                        sizeof(std::max_align_t));
  void* sample = storage.data();
  std::memset(sample, 0, type.descriptor->m_size);
  if (decoder.Decode(cdr, sample)) {
    try {
      if (ros)
        ConvertRos2(type.type_name, sample);
      else
        Convert(type.type_name, sample);
    } catch (const MessageError&) {
    }
  }
  dds_sample_free(sample, type.descriptor, DDS_FREE_CONTENTS);
  return 0;
}
