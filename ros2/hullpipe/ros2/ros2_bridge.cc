#include "hullpipe/ros2/ros2_bridge.h"

#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"

namespace hullpipe::ros2 {

namespace {
// The pipeline's topics read newest-first: no writer of the pipeline waits.
constexpr dds::QosSpec kTapQos{false, false, 1};
}  // namespace

void Ros2BridgeOptions::Check() const {
  if (!head_pose_topic.empty()) {
    try {
      DdsTopicOf(head_pose_topic);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--head-pose-topic: ") + e.what());
    }
  }
  if (!(pose.max_skew_s > 0)) throw std::invalid_argument("--max-pose-skew must be > 0 s");
}

Ros2Bridge::Ros2Bridge(const dds::Participant& hullpipe, const dds::Participant& ros, Ros2BridgeOptions options,
                       const Clock& clock)
    : ros_(ros),
      o_((options.Check(), std::move(options))),
      clock_(clock),
      infos_(hullpipe),
      maps_(hullpipe, dds::TopicTraits<hullpipe_msg_ObjectPixelMap>::kName, kTapQos),
      images_(hullpipe, dds::TopicTraits<hullpipe_msg_CameraImage>::kName, kTapQos),
      tf_static_(ros, DdsTopicOf("/tf_static"), kTfStaticQos) {
  if (!o_.head_pose_topic.empty()) {
    poses_ = std::make_unique<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>>(ros, DdsTopicOf(o_.head_pose_topic),
                                                                                 kPoseReaderQos);
    head_ = std::make_unique<dds::Writer<hullpipe_msg_HeadPose>>(hullpipe);
  }
}

std::vector<dds_entity_t> Ros2Bridge::Conditions() const {
  std::vector<dds_entity_t> c = {infos_.condition(), maps_.condition(), images_.condition()};
  if (poses_) c.push_back(poses_->condition());
  return c;
}

void Ros2Bridge::Refuse(uint64_t* counter, const std::string& kind, const std::string& why) {
  ++*counter;
  if (said_.size() < 64 && said_.insert(kind).second)
    spdlog::warn("{} refused: {} (said once; counted in NodeStats rejected)", kind, why);
}

size_t Ros2Bridge::Step() {
  size_t n = 0;
  n += infos_.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) { OnCameraInfo(m); });
  n += maps_.TakeEach([&](const hullpipe_msg_ObjectPixelMap& m, const dds_sample_info_t&) { OnMap(m); });
  n += images_.TakeEach([&](const hullpipe_msg_CameraImage& m, const dds_sample_info_t&) { OnImage(m); });
  if (poses_)
    n += poses_->TakeEach([&](const geometry_msgs_msg_dds__PoseStamped_& m, const dds_sample_info_t&) { OnPose(m); });
  return n;
}

void Ros2Bridge::OnCameraInfo(const hullpipe_msg_CameraInfo& m) {
  Camera c;
  try {
    c = dds::CameraFromMsg(m, nullptr);
  } catch (const dds::MessageError& e) {
    Refuse(&counts_.samples_refused, "CameraInfo", e.what());
    return;
  }
  auto it = cameras_.find(c.id);
  if (it == cameras_.end()) {
    if (cameras_.size() >= kMaxCameras) {
      Refuse(&counts_.cameras_refused, "camera " + std::to_string(c.id),
             "more than " + std::to_string(kMaxCameras) + " cameras");
      return;
    }
    const std::string base = "/hullpipe/cam" + std::to_string(c.id);
    CameraTopics t;
    t.info = std::make_unique<dds::Writer<sensor_msgs_msg_dds__CameraInfo_>>(ros_, DdsTopicOf(base + "/camera_info"),
                                                                             kDefaultQos);
    if (o_.maps)
      t.map = std::make_unique<dds::Writer<sensor_msgs_msg_dds__Image_>>(ros_, DdsTopicOf(base + "/object_pixel_map"),
                                                                         kDefaultQos);
    if (o_.images) {
      t.jpeg = std::make_unique<dds::Writer<sensor_msgs_msg_dds__CompressedImage_>>(
          ros_, DdsTopicOf(base + "/image/compressed"), kDefaultQos);
      t.raw = std::make_unique<dds::Writer<sensor_msgs_msg_dds__Image_>>(ros_, DdsTopicOf(base + "/image"), kDefaultQos);
    }
    it = cameras_.emplace(c.id, std::move(t)).first;
    spdlog::info("camera {}: publishing {}/camera_info{}{}", c.id, base, o_.maps ? ", object_pixel_map" : "",
                 o_.images ? ", image (raw frames), image/compressed (JPEG frames)" : "");
  }
  it->second.camera = c;
  PublishTfStatic();
}

void Ros2Bridge::PublishTfStatic() {
  std::vector<Camera> cams;
  for (const auto& [id, t] : cameras_) cams.push_back(t.camera);
  const auto tf = MakeCameraTransforms(cams, clock_.WallNs());
  tf_static_.Write(tf.msg);
  ++counts_.tf_static;
}

void Ros2Bridge::OnMap(const hullpipe_msg_ObjectPixelMap& m) {
  const auto it = cameras_.find(int(m.camera_id));
  if (it == cameras_.end()) return;  // its calibration first (transient-local: it comes)
  const int64_t stamp = m.capture_time_ns;
  const auto info = MakeCameraInfo(it->second.camera, stamp);
  it->second.info->Write(info.msg);
  ++counts_.camera_infos;
  if (!it->second.map) return;
  cv::Mat map;
  try {
    map = dds::MapFromMsg(m);
  } catch (const dds::MessageError& e) {
    Refuse(&counts_.samples_refused, "ObjectPixelMap", e.what());
    return;
  }
  const auto image = MakeMono8Image(map, stamp, CameraFrameId(int(m.camera_id)));
  it->second.map->Write(image.msg);
  ++counts_.maps;
}

void Ros2Bridge::OnImage(const hullpipe_msg_CameraImage& m) {
  const auto it = cameras_.find(int(m.camera_id));
  if (it == cameras_.end() || !it->second.jpeg) return;
  const std::string frame = CameraFrameId(int(m.camera_id));
  try {
    if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
      // Passed on as they are (checked to be a JPEG of the stated size).
      dds::CheckJpegOfSize("CameraImage: ", m.data._buffer, m.data._length, m.width, m.height);
      const auto image = MakeCompressedImage(std::vector<uint8_t>(m.data._buffer, m.data._buffer + m.data._length),
                                             m.capture_time_ns, frame);
      it->second.jpeg->Write(image.msg);
    } else {
      const auto image = MakeBgr8Image(dds::ImageFromMsg(m), m.capture_time_ns, frame);
      it->second.raw->Write(image.msg);
    }
  } catch (const dds::MessageError& e) {
    Refuse(&counts_.samples_refused, "CameraImage", e.what());
    return;
  }
  ++counts_.images;
}

void Ros2Bridge::OnPose(const geometry_msgs_msg_dds__PoseStamped_& m) {
  PoseCheck check = o_.pose;
  check.now_ns = clock_.WallNs();
  Rigid3d world_from_eye;
  try {
    world_from_eye = HeadFromPoseStamped(m, check);
  } catch (const dds::MessageError& e) {
    // Named once per kind of fault (the field the message names).
    const std::string what = e.what();
    const std::string kind = what.substr(0, what.find(' ', what.find(": ") + 2));
    Refuse(&counts_.poses_refused, "a tracker pose (" + kind + ")", what);
    return;
  }
  head_->Write(dds::HeadPoseToMsg(world_from_eye, o_.tracker_id, NanosecondsOf(m.header.stamp)));
  ++counts_.poses;
}

}  // namespace hullpipe::ros2
