#include "hullpipe/evaluation/synthetic_rig.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/util/parallel.h"

namespace fs = std::filesystem;

namespace hullpipe {
namespace {

constexpr double kPi = 3.14159265358979323846;

void Require(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("synthetic rig: " + what);
}

// The figure's frame is AnimatedFigure's (z down, floor z = 0). Camera i sits on
// the ring at azimuth 2 pi i / n (a quarter step turned, so no camera looks along
// an axis), at 1.1 m or 2.4 m above the floor in turn, looking at the figure's
// middle (0.9 m up) with image-up along the figure's up.
std::vector<Camera> FigureFrameCameras(const SyntheticRigFilesOptions& o) {
  std::vector<Camera> cams;
  const Eigen::Vector3d target(0, 0, -0.9), up(0, 0, -1);
  Distortion d{};
  d[0] = o.k1;
  for (int i = 0; i < o.cameras; ++i) {
    const double a = 2 * kPi * (i + 0.25) / o.cameras;
    const double h = i % 2 ? 2.4 : 1.1;
    const Eigen::Vector3d eye(o.ring_radius * std::cos(a), o.ring_radius * std::sin(a), -h);
    cams.push_back(LookingCamera(i + 1, eye, target, up, o.width, o.height, 62.0 * kPi / 180, d));
    cams.back().skew = o.skew;
  }
  return cams;
}

cv::Mat Noisy(const cv::Mat& img, double sigma, unsigned seed, int camera, int frame) {
  if (sigma <= 0) return img.clone();
  cv::RNG rng(uint64_t(seed) * 1000003ull + uint64_t(camera) * 100003ull + uint64_t(frame));
  cv::Mat noise(img.size(), CV_16SC3);
  rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
  cv::Mat out;
  cv::add(img, noise, out, cv::noArray(), CV_8UC3);
  return out;
}

cv::VideoWriter OpenVideo(const fs::path& path, double fps, cv::Size size) {
  cv::VideoWriter w(path.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), fps, size, true);
  if (!w.isOpened()) throw std::runtime_error(path.string() + ": cannot open for writing (MJPG .avi)");
  return w;
}

void WriteColmapText(const std::vector<Camera>& cams, const fs::path& model) {
  std::ofstream c(model / "cameras.txt"), im(model / "images.txt"), pts(model / "points3D.txt");
  if (!c || !im || !pts) throw std::runtime_error(model.string() + ": cannot write the COLMAP text model");
  c.precision(17);
  im.precision(17);
  c << "# Camera list with one line of data per camera:\n"
       "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  im << "# Image list with two lines of data per image:\n"
        "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
        "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  pts << "# 3D point list (empty: the rig was not reconstructed from points)\n";
  for (const Camera& k : cams) {
    // COLMAP's pixel centres are hullpipe's (+0.5): cx, cy as they are.
    c << k.id << " OPENCV " << k.width << ' ' << k.height << ' ' << k.fx << ' ' << k.fy << ' ' << k.cx << ' ' << k.cy
      << ' ' << k.distortion[0] << ' ' << k.distortion[1] << ' ' << k.distortion[2] << ' ' << k.distortion[3]
      << '\n';
    const Eigen::Quaterniond q(k.cam_from_world.rotation);
    const Eigen::Vector3d& t = k.cam_from_world.translation;
    im << k.id << ' ' << q.w() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << t.x() << ' ' << t.y() << ' '
       << t.z() << ' ' << k.id << " cam" << k.id << ".png\n\n";
  }
  if (!c || !im || !pts) throw std::runtime_error(model.string() + ": writing the COLMAP text model failed");
}

}  // namespace

void SyntheticRigFilesOptions::Check() const {
  Require(cameras >= 3 && cameras <= 64, "cameras must be in [3, 64]");
  Require(width >= 16 && width <= 2048 && height >= 16 && height <= 2048, "each image side must be in [16, 2048]");
  Require(frames >= 1 && frames <= 10000, "frames must be in [1, 10000]");
  Require(fps > 0 && fps <= 120, "fps must be in (0, 120]");
  Require(background_frames >= 1 && background_frames <= 1000, "background frames must be in [1, 1000]");
  Require(noise_sigma >= 0 && noise_sigma <= 50, "noise sigma must be in [0, 50] grey levels");
  Require(k1 >= -0.5 && k1 <= 0.5, "k1 must be in [-0.5, 0.5]");
  Require(ring_radius >= 1.5 && ring_radius <= 20, "ring radius must be in [1.5, 20] m");
  Require(format == "colmap" || format == "yaml", "format must be colmap or yaml, not '" + format + "'");
  // fx of these 62-degree cameras is 0.83 width: 0.2 fx is 0.16 width.
  Require(std::isfinite(skew) && std::abs(skew) <= 0.16 * width, "skew must be at most 0.16 x the width in pixels");
  Require(skew == 0 || format == "yaml", "skew needs format yaml: COLMAP's camera models have no skew");
  Require(threads >= 1 && threads <= 64, "threads must be in [1, 64]");
}

Rigid3d SyntheticRigWorldFromFigure() {
  const Eigen::Matrix3d flip = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(kPi / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return {yaw * flip, Eigen::Vector3d(1.5, -0.8, 0)};
}

SyntheticRigFiles WriteSyntheticRigFiles(const SyntheticRigFilesOptions& o, const std::string& dir) {
  o.Check();
  const fs::path root(dir), videos = root / "videos";
  std::error_code ec;
  fs::create_directories(videos, ec);
  if (ec) throw std::runtime_error(videos.string() + ": cannot create: " + ec.message());

  SyntheticRigFiles out;
  out.world_from_figure = SyntheticRigWorldFromFigure();
  out.frames_pattern = "videos/cam{id}.avi";
  out.background_pattern = "videos/cam{id}_background.avi";
  const std::vector<Camera> figure_cams = FigureFrameCameras(o);
  const Rigid3d figure_from_world = out.world_from_figure.Inverse();
  for (Camera c : figure_cams) {
    c.cam_from_world = c.cam_from_world * figure_from_world;
    out.cameras.push_back(c);
  }

  std::vector<cv::Mat> first(figure_cams.size());
  std::vector<std::string> errors(figure_cams.size());
  ForEachRowDynamic(int(figure_cams.size()), o.threads, [&](int i, int) {
    try {
      const Camera& cam = figure_cams[size_t(i)];
      const cv::Size size(cam.width, cam.height);
      const std::string id = std::to_string(cam.id);
      cv::VideoWriter bg = OpenVideo(videos / ("cam" + id + "_background.avi"), o.fps, size);
      const cv::Mat empty = RenderColour(cam, SyntheticScene{});
      for (int k = 0; k < o.background_frames; ++k) bg.write(Noisy(empty, o.noise_sigma, o.seed, cam.id, -1 - k));
      cv::VideoWriter video = OpenVideo(videos / ("cam" + id + ".avi"), o.fps, size);
      for (int k = 0; k < o.frames; ++k) {
        const cv::Mat img = Noisy(RenderColour(cam, AnimatedFigure(k / o.fps)), o.noise_sigma, o.seed, cam.id, k);
        if (k == 0) first[size_t(i)] = img;
        video.write(img);
      }
    } catch (const std::exception& e) {
      errors[size_t(i)] = e.what();
    }
  });
  for (const auto& e : errors)
    if (!e.empty()) throw std::runtime_error(e);

  if (o.format == "colmap") {
    const fs::path model = root / "sparse" / "0", images = root / "images";
    fs::create_directories(model, ec);
    if (!ec) fs::create_directories(images, ec);
    if (ec) throw std::runtime_error(model.string() + ": cannot create: " + ec.message());
    WriteColmapText(out.cameras, model);
    for (size_t i = 0; i < out.cameras.size(); ++i) {
      const fs::path png = images / ("cam" + std::to_string(out.cameras[i].id) + ".png");
      if (!cv::imwrite(png.string(), first[i])) throw std::runtime_error(png.string() + ": cannot write");
    }
    out.calibration = model.string();
  } else {
    Rig rig;
    rig.source = (root / "rig.yaml").string();
    for (const Camera& c : out.cameras) {
      RigCamera rc;
      rc.camera = c;
      rc.frames = "videos/cam" + std::to_string(c.id) + ".avi";
      rc.background = "videos/cam" + std::to_string(c.id) + "_background.avi";
      rig.cameras.push_back(rc);
    }
    CompleteRig(&rig);  // the world and workspace derived and stated, as hullpipe_rig import writes them
    WriteRigYaml(rig, rig.source);
    out.calibration = rig.source;
  }
  return out;
}

}  // namespace hullpipe
