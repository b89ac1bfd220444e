#include "hullpipe/evaluation/synthetic_source.h"

#include <cmath>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

class SyntheticRig final : public RigSource {
 public:
  explicit SyntheticRig(const SyntheticRigOptions& o) : options_(o) {
    if (o.cameras < 1 || o.cameras > SyntheticRigOptions::kMaxCameras)
      throw std::invalid_argument("synthetic rig: --cameras must be in [1, 64]");
    if (o.width < 8 || o.height < 8 || o.width > SyntheticRigOptions::kMaxSide ||
        o.height > SyntheticRigOptions::kMaxSide)
      throw std::invalid_argument("synthetic rig: --synthetic-size must be in [8, 4096] x [8, 4096] pixels");
    if (!(o.fps > 0 && o.fps <= 1000)) throw std::invalid_argument("synthetic rig: --fps must be in (0, 1000]");
    if (o.frames < 0) throw std::invalid_argument("synthetic rig: --frames must be >= 0");
    (void)NamedScene(o.scene, 0);  // throws on an unknown name
    if (o.placement != "ring" && o.placement != "dome")
      throw std::invalid_argument("synthetic rig: placement must be ring or dome, not '" + o.placement + "'");
    const Eigen::Vector3d target = o.scene == "figure" ? Eigen::Vector3d(0, 0, -0.9) : Eigen::Vector3d(0, 0, -1.0);
    target_ = target;
    if (o.tracked_camera < 0 || o.tracked_camera > o.cameras)
      throw std::invalid_argument("synthetic rig: the tracked camera must be one of 1.." + std::to_string(o.cameras));
    const auto all = o.placement == "dome"
                         ? DomeCameras(o.cameras, 3.0, target, o.width, o.height, o.hfov, o.distortion)
                         : RingCameras(o.cameras, 4.0, 2.0, target, o.width, o.height, o.hfov, o.distortion);
    for (const auto& c : all)
      if (CameraSelected(o.camera_ids, c.id)) cameras_.push_back(c);
    if (cameras_.empty()) throw std::invalid_argument("synthetic rig: no camera selected");
    workspace_.min = Eigen::Vector3d(-2, -2, -2.5);
    workspace_.max = Eigen::Vector3d(2, 2, 0.02);
  }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return options_.cameras; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return options_.fps; }
  int64_t frame_count() const override { return options_.frames; }
  bool Next(RigFrame* f) override {
    if (index_ >= options_.frames) return false;
    f->time_s = double(index_) / options_.fps;
    const SyntheticScene scene = NamedScene(options_.scene, f->time_s);
    f->images.clear();
    f->maps.clear();
    f->errors.clear();
    f->poses.assign(cameras_.size(), std::nullopt);
    for (size_t i = 0; i < cameras_.size(); ++i) {
      Camera c = cameras_[i];
      if (c.id == options_.tracked_camera) {
        c.cam_from_world = SyntheticTrackedPose(cameras_[i], target_, f->time_s);
        f->poses[i] = c.cam_from_world;
      }
      f->maps.push_back(RenderExactMap(c, scene));
      f->images.push_back(RenderColour(c, scene));
    }
    ++index_;
    return true;
  }
  bool Rewind() override {
    index_ = 0;
    return true;
  }
  bool Skip() override {
    if (index_ >= options_.frames) return false;
    ++index_;  // nothing to render
    return true;
  }

 private:
  SyntheticRigOptions options_;
  std::vector<Camera> cameras_;
  Eigen::Vector3d target_ = Eigen::Vector3d::Zero();
  Aabb workspace_;
  int64_t index_ = 0;
};

}  // namespace

Rigid3d SyntheticTrackedPose(const Camera& calibrated, const Eigen::Vector3d& target, double t) {
  const Rigid3d world_from_cam = calibrated.cam_from_world.Inverse();
  Rigid3d move;  // about the vertical through the target, then up (-z)
  move.rotation = Eigen::AngleAxisd(0.35 * std::sin(t), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  move.translation = target - move.rotation * target + Eigen::Vector3d(0.4 * std::sin(t), 0, -0.1 * std::sin(2 * t));
  return (move * world_from_cam).Inverse();
}

std::unique_ptr<RigSource> OpenSyntheticRig(const SyntheticRigOptions& options) {
  return std::make_unique<SyntheticRig>(options);
}

}  // namespace hullpipe
