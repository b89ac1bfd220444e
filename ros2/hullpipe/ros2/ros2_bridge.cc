#include "hullpipe/ros2/ros2_bridge.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>

#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/ros2/ros2_schemas.h"

namespace hullpipe::ros2 {

namespace {
// The pipeline's topics read newest-first: no writer of the pipeline waits.
constexpr dds::QosSpec kTapQos{false, false, 1};
// Poses and tiles a few deep: a view's points need its pose and every tile.
constexpr dds::QosSpec kTapDeepQos{false, false, 8};

template <typename T>
dds::Reader<T> Tap(const dds::Participant& p, const dds::QosSpec& qos = kTapQos) {
  return dds::Reader<T>(p, dds::TopicTraits<T>::kName, qos);
}
}  // namespace

void Ros2BridgeOptions::Check() const {
  // A ROS 2 topic name (DdsTopicOf's rules), refused naming the flag as given.
  auto check_topic = [](const std::string& topic, const std::string& flag) {
    try {
      DdsTopicOf(topic);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(flag + ": " + e.what());
    }
  };
  if (!head_pose_topic.empty()) check_topic(head_pose_topic, "--head-pose-topic");
  if (!eye_views_topic.empty()) {
    check_topic(eye_views_topic, "--eye-views-topic");
    if (eye_views_topic == head_pose_topic)
      throw std::invalid_argument("--eye-views-topic: the same topic as --head-pose-topic");
  }
  if (!(pose.max_skew_s > 0)) throw std::invalid_argument("--max-pose-skew must be > 0 s");
  if (head_frame.size() > 256) throw std::invalid_argument("--head-frame: longer than 256 characters");
  if (camera_pose_topics.size() + camera_frames.size() > kMaxTrackedCameras)
    throw std::invalid_argument("--camera-pose and --camera-frame: more than " + std::to_string(kMaxTrackedCameras) +
                                " tracked cameras");
  for (const auto& [id, topic] : camera_pose_topics) {
    check_topic(topic, "--camera-pose " + std::to_string(id) + "=" + topic);
    if (camera_frames.count(id))
      throw std::invalid_argument("camera " + std::to_string(id) + ": both --camera-pose and --camera-frame");
  }
  if (!node_name.empty()) {
    bool ok = node_name.size() <= 256 && !std::isdigit(static_cast<unsigned char>(node_name[0]));
    for (const char ch : node_name) ok = ok && (std::isalnum(static_cast<unsigned char>(ch)) || ch == '_');
    if (!ok) throw std::invalid_argument("--ros-node-name '" + node_name + "': [A-Za-z_][A-Za-z0-9_]*, at most 256");
  }
  for (const auto& [id, frame] : camera_frames)
    if (frame.empty() || frame.size() > 256)
      throw std::invalid_argument("--camera-frame " + std::to_string(id) + ": a frame name of 1 to 256 characters");
  if (derive.hull_point_stride < 1 || derive.hull_point_stride > 64)
    throw std::invalid_argument("--hull-point-stride must be in [1, 64]");
}

Ros2Bridge::Ros2Bridge(const dds::Participant& hullpipe, const dds::Participant& ros, Ros2BridgeOptions options,
                       const Clock& clock)
    : ros_(ros),
      o_((options.Check(), std::move(options))),
      clock_(clock),
      deriver_(o_.derive, [this](const Ros2Message& m) { Publish(m); }),
      infos_(hullpipe),
      maps_(Tap<hullpipe_msg_ObjectPixelMap>(hullpipe)),
      images_(Tap<hullpipe_msg_CameraImage>(hullpipe)),
      views_(Tap<hullpipe_msg_ViewPose>(hullpipe, kTapDeepQos)),
      tiles_(Tap<hullpipe_msg_HullView>(hullpipe, kTapDeepQos)),
      composited_(Tap<hullpipe_msg_CompositedView>(hullpipe)),
      objects_(Tap<hullpipe_msg_VirtualObjectState>(hullpipe)),
      reports_(Tap<hullpipe_msg_CollisionReport>(hullpipe)),
      meshes_(Tap<hullpipe_msg_VirtualMesh>(hullpipe)),
      // A part's geometry is sent once, transient-local: read as it is offered.
      model_parts_(hullpipe),
      model_states_(Tap<hullpipe_msg_ModelState>(hullpipe, kTapDeepQos)) {
  if (!o_.head_pose_topic.empty())
    poses_ = std::make_unique<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>>(ros, DdsTopicOf(o_.head_pose_topic),
                                                                                 kPoseReaderQos);
  if (!o_.head_frame.empty() || !o_.camera_frames.empty())
    tf_ = std::make_unique<dds::Reader<tf2_msgs_msg_dds__TFMessage_>>(ros, DdsTopicOf("/tf"), kTfReaderQos);
  if (poses_ || !o_.head_frame.empty()) head_ = std::make_unique<dds::Writer<hullpipe_msg_HeadPose>>(hullpipe);
  if (!o_.eye_views_topic.empty()) {
    eye_views_in_ = std::make_unique<dds::Reader<hullpipe_msgs_msg_dds__EyeViews_>>(
        ros, DdsTopicOf(o_.eye_views_topic), kPoseReaderQos);
    eye_views_ = std::make_unique<dds::Writer<hullpipe_msg_EyeViews>>(hullpipe);
  }
  for (const auto& [id, topic] : o_.camera_pose_topics)
    camera_topics_.push_back(
        {id, std::make_unique<dds::Reader<geometry_msgs_msg_dds__PoseStamped_>>(ros, DdsTopicOf(topic),
                                                                                 kCameraPoseReaderQos)});
  if (!o_.camera_pose_topics.empty() || !o_.camera_frames.empty())
    camera_poses_ = std::make_unique<dds::Writer<hullpipe_msg_CameraPose>>(hullpipe);
  if (!o_.node_name.empty()) {
    discovery_ = std::make_unique<dds::Writer<rmw_dds_common_msg_dds__ParticipantEntitiesInfo_>>(
        ros, "ros_discovery_info", kDiscoveryQos);
    PublishDiscovery();
  }
}

std::vector<dds_entity_t> Ros2Bridge::TrackerConditions() const {
  std::vector<dds_entity_t> c;
  if (poses_) c.push_back(poses_->condition());
  if (eye_views_in_) c.push_back(eye_views_in_->condition());
  if (tf_) c.push_back(tf_->condition());
  for (const auto& t : camera_topics_) c.push_back(t.reader->condition());
  return c;
}

std::vector<dds_entity_t> Ros2Bridge::HullpipeConditions() const {
  return {infos_.condition(),      maps_.condition(),    images_.condition(),
          views_.condition(),      tiles_.condition(),   composited_.condition(),
          objects_.condition(),    reports_.condition(), meshes_.condition(),
          model_parts_.condition(), model_states_.condition()};
}

void Ros2Bridge::Refused(uint64_t* counter, const std::string& kind, const std::string& why) {
  ++*counter;
  if (said_.size() < 64 && said_.insert(kind).second)
    spdlog::warn("{} refused: {} (said once; counted in NodeStats rejected)", kind, why);
}

void Ros2Bridge::Publish(const Ros2Message& m) {
  auto it = publications_.find(m.topic);
  if (it == publications_.end()) {
    const dds::KnownType kt = Ros2KnownType(m.type);
    Publication p;
    p.topic = dds::Entity(dds::Check(
        dds_create_topic(ros_.handle(), kt.descriptor, DdsTopicOf(m.topic).c_str(), nullptr, nullptr),
        "dds_create_topic"));
    p.writer = dds::Entity(
        dds::Check(dds_create_writer(ros_.handle(), p.topic.handle(), dds::Qos(m.qos).get(), nullptr),
                   "dds_create_writer"));
    it = publications_.emplace(m.topic, std::move(p)).first;
    discovery_stale_ = true;
    spdlog::info("publishing {} ({})", m.topic, m.type);
  }
  dds::Check(dds_write(it->second.writer.handle(), m.msg), "dds_write");
  ++counts_.published[m.topic];
}

size_t Ros2Bridge::Step() {
  size_t n = 0;
  auto take = [&](const auto& reader, const char* kind, auto&& derive) {
    n += reader.TakeEach([&](const auto& m, const dds_sample_info_t&) {
      const std::string why = derive(m);
      if (!why.empty()) Refused(&counts_.samples_refused, kind, why);
    });
  };
  take(infos_, "CameraInfo", [&](const auto& m) { return deriver_.OnCameraInfo(m, clock_.WallNs()); });
  take(maps_, "ObjectPixelMap", [&](const auto& m) { return deriver_.OnMap(m); });
  take(images_, "CameraImage", [&](const auto& m) { return deriver_.OnImage(m); });
  take(views_, "ViewPose", [&](const auto& m) { return deriver_.OnViewPose(m); });
  take(tiles_, "HullView", [&](const auto& m) { return deriver_.OnHullView(m); });
  take(composited_, "CompositedView", [&](const auto& m) { return deriver_.OnCompositedView(m); });
  take(objects_, "VirtualObjectState", [&](const auto& m) { return deriver_.OnObjectState(m); });
  take(reports_, "CollisionReport", [&](const auto& m) { return deriver_.OnCollisionReport(m); });
  take(meshes_, "VirtualMesh", [&](const auto& m) { return deriver_.OnMesh(m); });
  take(model_parts_, "ModelPart", [&](const auto& m) { return deriver_.OnModelPart(m); });
  take(model_states_, "ModelState", [&](const auto& m) { return deriver_.OnModelState(m); });
  if (poses_)
    n += poses_->TakeEach([&](const geometry_msgs_msg_dds__PoseStamped_& m, const dds_sample_info_t&) { OnPose(m); });
  if (eye_views_in_)
    n += eye_views_in_->TakeEach(
        [&](const hullpipe_msgs_msg_dds__EyeViews_& m, const dds_sample_info_t&) { OnEyeViews(m); });
  if (tf_) n += tf_->TakeEach([&](const tf2_msgs_msg_dds__TFMessage_& m, const dds_sample_info_t&) { OnTf(m); });
  for (const auto& t : camera_topics_)
    n += t.reader->TakeEach([&](const geometry_msgs_msg_dds__PoseStamped_& m, const dds_sample_info_t&) {
      const std::string what = "camera " + std::to_string(t.camera_id) + "'s pose";
      if (const auto pose = Checked([&](const PoseCheck& check) { return HeadFromPoseStamped(m, check); }, what))
        PassOnCamera(t.camera_id, *pose, m.header.stamp);
    });
  if (discovery_stale_) PublishDiscovery();
  return n;
}

void Ros2Bridge::OnPose(const geometry_msgs_msg_dds__PoseStamped_& m) {
  if (const auto pose =
          Checked([&](const PoseCheck& check) { return HeadFromPoseStamped(m, check); }, "a tracker pose"))
    PassOnHead(*pose, m.header.stamp);
}

void Ros2Bridge::OnEyeViews(const hullpipe_msgs_msg_dds__EyeViews_& m) {
  const auto views = Checked(
      [&](const PoseCheck& check) { return EyeViewsFromRos2(m, check, o_.tracker_id); }, "a headset's eye views");
  if (!views) return;
  eye_views_->Write(dds::EyeViewsToMsg(*views));  // checked: valid
  ++counts_.eye_views;
}

void Ros2Bridge::OnTf(const tf2_msgs_msg_dds__TFMessage_& m) {
  const uint32_t n = std::min(m.transforms._length, kMaxTransformsPerMessage);
  if (m.transforms._length > n) {
    counts_.transforms_skipped += m.transforms._length - n;
    if (said_.size() < 64 && said_.insert("a flood of tf frames").second)
      spdlog::warn("a /tf message of {} transforms: only the first {} are looked at (said once; counted)",
                   m.transforms._length, n);
  }
  for (uint32_t i = 0; i < n; ++i) {
    const auto& t = m.transforms._buffer[i];
    if (!t.child_frame_id) continue;
    const std::string child(t.child_frame_id, strnlen(t.child_frame_id, 257));
    auto check = [&](const PoseCheck& c) { return HeadFromTransform(t, c); };
    if (!o_.head_frame.empty() && child == o_.head_frame) {
      if (const auto pose = Checked(check, "a tracker pose")) PassOnHead(*pose, t.header.stamp);
    }
    for (const auto& [id, frame] : o_.camera_frames)  // at most kMaxTrackedCameras
      if (child == frame)
        if (const auto pose = Checked(check, "camera " + std::to_string(id) + "'s pose"))
          PassOnCamera(id, *pose, t.header.stamp);
  }
}

void Ros2Bridge::PublishDiscovery() {
  discovery_stale_ = false;
  if (!discovery_) return;
  // rmw_cyclonedds' gid: the entity's DDS GUID, zero-padded.
  auto gid = [](dds_entity_t e) {
    rmw_dds_common_msg_dds__Gid_ g{};
    dds_guid_t guid;
    dds::Check(dds_get_guid(e, &guid), "dds_get_guid");
    static_assert(sizeof guid.v <= sizeof g.data);
    std::memcpy(g.data, guid.v, sizeof guid.v);
    return g;
  };
  std::vector<rmw_dds_common_msg_dds__Gid_> readers, writers;
  if (poses_) readers.push_back(gid(poses_->handle()));
  if (eye_views_in_) readers.push_back(gid(eye_views_in_->handle()));
  if (tf_) readers.push_back(gid(tf_->handle()));
  for (const auto& t : camera_topics_) readers.push_back(gid(t.reader->handle()));
  for (const auto& [topic, p] : publications_) writers.push_back(gid(p.writer.handle()));
  rmw_dds_common_msg_dds__NodeEntitiesInfo_ node{};
  std::snprintf(node.node_namespace, sizeof node.node_namespace, "%s", "/");
  std::snprintf(node.node_name, sizeof node.node_name, "%s", o_.node_name.c_str());
  dds::Borrow(&node.reader_gid_seq, readers);
  dds::Borrow(&node.writer_gid_seq, writers);
  rmw_dds_common_msg_dds__ParticipantEntitiesInfo_ info{};
  info.gid = gid(ros_.handle());
  info.node_entities_info_seq._buffer = &node;
  info.node_entities_info_seq._length = info.node_entities_info_seq._maximum = 1;
  info.node_entities_info_seq._release = false;
  discovery_->Write(info);
}

template <typename Convert>
auto Ros2Bridge::Checked(const Convert& convert, const std::string& what)
    -> std::optional<std::invoke_result_t<const Convert&, const PoseCheck&>> {
  PoseCheck check = o_.pose;
  check.now_ns = clock_.WallNs();
  try {
    return convert(check);
  } catch (const dds::MessageError& e) {
    // Named once per kind of fault (the field the message names), per whose pose.
    const std::string text = e.what();
    const std::string kind = text.substr(0, text.find(' ', text.find(": ") + 2));
    Refused(&counts_.poses_refused, what + " (" + kind + ")", text);
    return std::nullopt;
  }
}

void Ros2Bridge::PassOnHead(const Rigid3d& world_from_eye, const builtin_interfaces_msg_dds__Time_& stamp) {
  head_->Write(dds::HeadPoseToMsg(world_from_eye, o_.tracker_id, NanosecondsOf(stamp)));  // checked: valid
  ++counts_.poses;
}

void Ros2Bridge::PassOnCamera(uint32_t camera_id, const Rigid3d& world_from_camera,
                              const builtin_interfaces_msg_dds__Time_& stamp) {
  camera_poses_->Write(dds::CameraPoseToMsg(world_from_camera, camera_id, NanosecondsOf(stamp)));  // checked: valid
  ++counts_.camera_poses;
}

}  // namespace hullpipe::ros2
