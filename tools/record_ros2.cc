#include "record_ros2.h"

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/ros2/ros2_messages.h"
#include "hullpipe/ros2/ros2_schemas.h"
#include "hullpipe/ros2/ros2_topics.h"

namespace hullpipe::record {
namespace {

WriterOptions McapRos2() {
  WriterOptions o;
  o.storage = Storage::kMcap;
  o.compression = Compression::kZstd;
  o.mcap.profile = "ros2";
  return o;
}

// Decodes `data` as hullpipe's T and calls f with it; false if it does not decode.
template <typename T, typename F>
bool With(const dds::CdrWriter& codec, const std::vector<uint8_t>& data, F&& f) {
  T m{};
  if (!codec.Decode(data, &m)) return false;
  struct Free {
    T* m;
    ~Free() { dds_sample_free(m, dds::TopicTraits<T>::Descriptor(), DDS_FREE_CONTENTS); }
  } free_it{&m};
  f(m);
  return true;
}

}  // namespace

Ros2Export::Ros2Export(const std::string& path, const dds::Participant& participant)
    : path_(path), participant_(participant), w_(path, McapRos2()) {
  w_.SetMeta("ros2", "hullpipe's topics as ROS 2 Humble messages, by hullpipe_record export --ros2 (docs/ros2.md)");
}

const dds::CdrWriter& Ros2Export::Codec(const std::string& type) {
  auto& c = codecs_[type];
  if (!c) {
    const dds::KnownType* hullpipe = dds::FindKnownType(type);
    const dds::KnownType kt = hullpipe ? *hullpipe : ros2::Ros2KnownType(type);
    c = std::make_unique<dds::CdrWriter>(participant_, kt, kt.qos, dds::CdrWriter::Scope::kDecodeOnly);
  }
  return *c;
}

void Ros2Export::Write(const std::string& ros_topic, const std::string& type, const dds::QosSpec& qos,
                       const void* msg, int64_t log_ns, int64_t stamp_ns) {
  auto it = ids_.find(ros_topic);
  if (it == ids_.end()) {
    TopicInfo t;
    t.name = ros_topic;  // rosbag2 keeps the ROS name
    t.type = type;
    t.reliable = qos.reliable;
    t.transient_local = qos.transient_local;
    t.depth = qos.depth;
    t.type_description = ros2::Ros2MsgSchema(type);
    t.schema_encoding = "ros2msg";
    t.message_encoding = "cdr";
    t.offered_qos_profiles = ros2::OfferedQosProfiles(qos);
    it = ids_.emplace(ros_topic, w_.AddTopic(t)).first;
  }
  Sample s;
  s.topic_id = it->second;
  s.arrival_ns = log_ns;
  s.source_ns = stamp_ns;
  s.data = Codec(type).Encode(msg);
  w_.Append(s);
  ++counts_[ros_topic];
  if (++appended_ % 64 == 0) w_.Commit();
}

bool Ros2Export::Add(const TopicInfo& topic, const Sample& sample) {
  const std::string& type = topic.type;
  const int64_t log_ns = sample.arrival_ns;
  if (type == "hullpipe::msg::CameraInfo") {
    return With<hullpipe_msg_CameraInfo>(Codec(type), sample.data, [&](const hullpipe_msg_CameraInfo& m) {
      const Camera c = dds::CameraFromMsg(m, nullptr);
      cameras_[c.id] = c;
      std::vector<Camera> all;
      for (const auto& [id, cam] : cameras_) all.push_back(cam);
      const auto tf = ros2::MakeCameraTransforms(all, log_ns);
      Write("/tf_static", "tf2_msgs/msg/TFMessage", ros2::kTfStaticQos, &tf.msg, log_ns, log_ns);
    });
  }
  if (type == "hullpipe::msg::ObjectPixelMap") {
    return With<hullpipe_msg_ObjectPixelMap>(Codec(type), sample.data, [&](const hullpipe_msg_ObjectPixelMap& m) {
      const auto cam = cameras_.find(int(m.camera_id));
      if (cam == cameras_.end()) return;  // before its calibration: nothing to say where it is
      const std::string base = "/hullpipe/cam" + std::to_string(m.camera_id);
      const auto info = ros2::MakeCameraInfo(cam->second, m.capture_time_ns);
      Write(base + "/camera_info", "sensor_msgs/msg/CameraInfo", ros2::kDefaultQos, &info.msg, log_ns,
            m.capture_time_ns);
      const auto map = ros2::MakeMono8Image(dds::MapFromMsg(m), m.capture_time_ns, ros2::CameraFrameId(cam->first));
      Write(base + "/object_pixel_map", "sensor_msgs/msg/Image", ros2::kDefaultQos, &map.msg, log_ns,
            m.capture_time_ns);
    });
  }
  if (type == "hullpipe::msg::CameraImage") {
    return With<hullpipe_msg_CameraImage>(Codec(type), sample.data, [&](const hullpipe_msg_CameraImage& m) {
      const std::string base = "/hullpipe/cam" + std::to_string(m.camera_id), frame = ros2::CameraFrameId(int(m.camera_id));
      if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
        dds::CheckJpegOfSize("CameraImage: ", m.data._buffer, m.data._length, m.width, m.height);
        const auto jpeg = ros2::MakeCompressedImage(std::vector<uint8_t>(m.data._buffer, m.data._buffer + m.data._length),
                                                    m.capture_time_ns, frame);
        Write(base + "/image/compressed", "sensor_msgs/msg/CompressedImage", ros2::kDefaultQos, &jpeg.msg, log_ns,
              m.capture_time_ns);
      } else {
        const auto raw = ros2::MakeBgr8Image(dds::ImageFromMsg(m), m.capture_time_ns, frame);
        Write(base + "/image", "sensor_msgs/msg/Image", ros2::kDefaultQos, &raw.msg, log_ns, m.capture_time_ns);
      }
    });
  }
  return true;  // no ROS 2 form (yet): docs/ros2.md, "Not yet"
}

}  // namespace hullpipe::record
