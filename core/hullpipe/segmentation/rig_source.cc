#include "hullpipe/segmentation/rig_source.h"

#include <algorithm>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/evaluation/synthetic.h"

namespace hullpipe {
namespace {

bool Selected(const std::vector<int>& ids, int id) {
  return ids.empty() || std::find(ids.begin(), ids.end(), id) != ids.end();
}

cv::VideoCapture OpenCapture(const std::string& spec) {
  if (spec.rfind("v4l2:", 0) == 0) return cv::VideoCapture(std::stoi(spec.substr(5)), cv::CAP_V4L2);
  return cv::VideoCapture(spec, cv::CAP_ANY);
}

class VideoRig final : public RigSource {
 public:
  VideoRig(const std::string& path, const VideoRigOptions& o) : options_(o) {
    o.segmentation.Check();
    const Rig rig = LoadRig(path);
    workspace_ = rig.workspace;
    rig_camera_count_ = int(rig.cameras.size());
    for (const auto& rc : rig.cameras) {
      if (!Selected(o.camera_ids, rc.camera.id)) continue;
      Cam cam;
      cam.camera = rc.camera;
      cam.frames_spec = rc.frames;
      cam.masks_spec = rc.masks;
      if (rc.masks.empty()) cam.background = LearnBackground(rc);
      cams_.push_back(std::move(cam));
      cameras_.push_back(rc.camera);
    }
    if (cams_.empty()) throw std::runtime_error(path + ": none of the selected cameras is in the rig");
    OpenAll();
  }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return rig_camera_count_; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return fps_; }

  bool Next(RigFrame* f) override {
    f->images.assign(cams_.size(), cv::Mat());
    f->maps.assign(cams_.size(), cv::Mat());
    f->errors.clear();
    f->time_s = double(index_) / fps_;
    int alive = 0;
    for (size_t i = 0; i < cams_.size(); ++i) {
      Cam& c = cams_[i];
      if (c.ended) continue;
      cv::Mat img;
      bool ok = false;
      try {
        ok = c.frames.read(img);
      } catch (const cv::Exception& e) {
        ok = false;
      }
      if (!ok || img.empty()) {
        c.ended = true;
        f->errors.push_back("camera " + std::to_string(c.camera.id) + ": no more frames after frame " +
                            std::to_string(index_) + " (end of input or unreadable video)");
        continue;
      }
      ++alive;
      if (img.type() != CV_8UC3 || img.cols != c.camera.width || img.rows != c.camera.height) {
        f->errors.push_back("camera " + std::to_string(c.camera.id) + ": frame " + std::to_string(index_) +
                            " is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) +
                            ", calibration says " + std::to_string(c.camera.width) + "x" +
                            std::to_string(c.camera.height) + "; skipped");
        continue;
      }
      cv::Mat map;
      if (!c.masks_spec.empty()) {
        cv::Mat m;
        if (c.masks.read(m) && !m.empty()) {
          if (m.channels() == 3) cv::cvtColor(m, m, cv::COLOR_BGR2GRAY);
          if (m.size() == img.size()) map = m > 0;
        }
        if (map.empty()) {
          f->errors.push_back("camera " + std::to_string(c.camera.id) + ": mask of frame " +
                              std::to_string(index_) + " unreadable or of the wrong size; skipped");
          continue;
        }
      } else {
        map = c.background.Segment(img, options_.segmentation);
      }
      f->images[i] = img;
      f->maps[i] = map;
    }
    ++index_;
    return alive > 0;
  }

  bool Rewind() override {
    OpenAll();
    return true;
  }

 private:
  struct Cam {
    Camera camera;
    std::string frames_spec, masks_spec;
    cv::VideoCapture frames, masks;
    BackgroundModel background;
    bool ended = false;
  };

  BackgroundModel LearnBackground(const RigCamera& rc) {
    if (rc.background.empty())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": no background and no masks");
    cv::VideoCapture cap = OpenCapture(rc.background);
    if (!cap.isOpened())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": cannot open background " +
                               rc.background);
    std::vector<cv::Mat> frames;
    cv::Mat f;
    while (int(frames.size()) < options_.background_frames && cap.read(f) && !f.empty()) {
      if (f.cols == rc.camera.width && f.rows == rc.camera.height && f.type() == CV_8UC3)
        frames.push_back(f.clone());
    }
    if (frames.empty())
      throw std::runtime_error("camera " + std::to_string(rc.camera.id) + ": background " + rc.background +
                               " has no readable frame of the calibrated size");
    return BackgroundModel(frames);
  }

  void OpenAll() {
    index_ = 0;
    for (Cam& c : cams_) {
      c.frames = OpenCapture(c.frames_spec);
      if (!c.frames.isOpened())
        throw std::runtime_error("camera " + std::to_string(c.camera.id) + ": cannot open " + c.frames_spec);
      if (!c.masks_spec.empty()) c.masks = cv::VideoCapture(c.masks_spec, cv::CAP_IMAGES);
      c.ended = false;
      const double f = c.frames.get(cv::CAP_PROP_FPS);
      if (f > 1 && f < 1000) fps_ = f;
    }
  }

  VideoRigOptions options_;
  std::vector<Cam> cams_;
  std::vector<Camera> cameras_;
  Aabb workspace_;
  int rig_camera_count_ = 0;
  double fps_ = 25;
  int64_t index_ = 0;
};

class SyntheticRig final : public RigSource {
 public:
  explicit SyntheticRig(const SyntheticRigOptions& o) : options_(o) {
    if (o.cameras < 1 || o.width < 8 || o.height < 8 || !(o.fps > 0))
      throw std::invalid_argument("synthetic rig: need >= 1 camera, size >= 8, fps > 0");
    (void)NamedScene(o.scene, 0);  // throws on an unknown name
    if (o.placement != "ring" && o.placement != "dome")
      throw std::invalid_argument("synthetic rig: placement must be ring or dome, not '" + o.placement + "'");
    const Eigen::Vector3d target = o.scene == "figure" ? Eigen::Vector3d(0, 0, -0.9) : Eigen::Vector3d(0, 0, -1.0);
    const auto all = o.placement == "dome"
                         ? DomeCameras(o.cameras, 3.0, target, o.width, o.height, o.hfov, o.distortion)
                         : RingCameras(o.cameras, 4.0, 2.0, target, o.width, o.height, o.hfov, o.distortion);
    for (const auto& c : all)
      if (Selected(o.camera_ids, c.id)) cameras_.push_back(c);
    if (cameras_.empty()) throw std::invalid_argument("synthetic rig: no camera selected");
    workspace_.min = Eigen::Vector3d(-2, -2, -2.5);
    workspace_.max = Eigen::Vector3d(2, 2, 0.02);
  }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return options_.cameras; }
  Aabb workspace() const override { return workspace_; }
  double fps() const override { return options_.fps; }
  bool Next(RigFrame* f) override {
    if (index_ >= options_.frames) return false;
    f->time_s = double(index_) / options_.fps;
    const SyntheticScene scene = NamedScene(options_.scene, f->time_s);
    f->images.clear();
    f->maps.clear();
    f->errors.clear();
    for (const auto& c : cameras_) {
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

 private:
  SyntheticRigOptions options_;
  std::vector<Camera> cameras_;
  Aabb workspace_;
  int64_t index_ = 0;
};

}  // namespace

std::unique_ptr<RigSource> OpenVideoRig(const std::string& rig_path, const VideoRigOptions& options) {
  return std::make_unique<VideoRig>(rig_path, options);
}

std::unique_ptr<RigSource> OpenSyntheticRig(const SyntheticRigOptions& options) {
  return std::make_unique<SyntheticRig>(options);
}

}  // namespace hullpipe
