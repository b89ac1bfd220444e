#include "hullpipe/ros2/ros2_bridge.h"

#include <algorithm>
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
  if (!head_pose_topic.empty()) {
    try {
      DdsTopicOf(head_pose_topic);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--head-pose-topic: ") + e.what());
    }
  }
  if (!(pose.max_skew_s > 0)) throw std::invalid_argument("--max-pose-skew must be > 0 s");
  if (head_frame.size() > 256) throw std::invalid_argument("--head-frame: longer than 256 characters");
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
  if (!o_.head_frame.empty())
    tf_ = std::make_unique<dds::Reader<tf2_msgs_msg_dds__TFMessage_>>(ros, DdsTopicOf("/tf"), kTfReaderQos);
  if (poses_ || tf_) head_ = std::make_unique<dds::Writer<hullpipe_msg_HeadPose>>(hullpipe);
}

std::vector<dds_entity_t> Ros2Bridge::TrackerConditions() const {
  std::vector<dds_entity_t> c;
  if (poses_) c.push_back(poses_->condition());
  if (tf_) c.push_back(tf_->condition());
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
  if (tf_) n += tf_->TakeEach([&](const tf2_msgs_msg_dds__TFMessage_& m, const dds_sample_info_t&) { OnTf(m); });
  return n;
}

void Ros2Bridge::OnPose(const geometry_msgs_msg_dds__PoseStamped_& m) {
  PassOn([&](const PoseCheck& check) { return HeadFromPoseStamped(m, check); }, m.header.stamp);
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
    if (!t.child_frame_id || std::strncmp(t.child_frame_id, o_.head_frame.c_str(), o_.head_frame.size() + 1) != 0)
      continue;  // another frame: not ours to check
    PassOn([&](const PoseCheck& check) { return HeadFromTransform(t, check); }, t.header.stamp);
  }
}

void Ros2Bridge::PassOn(const std::function<Rigid3d(const PoseCheck&)>& head,
                        const builtin_interfaces_msg_dds__Time_& stamp) {
  PoseCheck check = o_.pose;
  check.now_ns = clock_.WallNs();
  Rigid3d world_from_eye;
  try {
    world_from_eye = head(check);
  } catch (const dds::MessageError& e) {
    // Named once per kind of fault (the field the message names).
    const std::string what = e.what();
    const std::string kind = what.substr(0, what.find(' ', what.find(": ") + 2));
    Refused(&counts_.poses_refused, "a tracker pose (" + kind + ")", what);
    return;
  }
  head_->Write(dds::HeadPoseToMsg(world_from_eye, o_.tracker_id, NanosecondsOf(stamp)));  // checked: valid
  ++counts_.poses;
}

}  // namespace hullpipe::ros2
