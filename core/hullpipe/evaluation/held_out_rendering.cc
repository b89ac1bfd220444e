#include "hullpipe/evaluation/held_out_rendering.h"

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualityssim.hpp>

#include "hullpipe/evaluation/reprojection.h"


namespace hullpipe {

PinholeTruth UndistortToPinhole(const Camera& camera, const cv::Mat& image, const cv::Mat& map) {
  const cv::Size size(camera.width, camera.height);
  if (image.type() != CV_8UC3 || image.size() != size || map.type() != CV_8UC1 || map.size() != size)
    throw std::invalid_argument("UndistortToPinhole: camera " + std::to_string(camera.id) +
                                " needs a CV_8UC3 image and a CV_8UC1 map of " + std::to_string(camera.width) + "x" +
                                std::to_string(camera.height));
  PinholeTruth t;
  t.view.width = camera.width, t.view.height = camera.height;
  t.view.fx = camera.fx, t.view.fy = camera.fy, t.view.cx = camera.cx, t.view.cy = camera.cy;
  t.view.world_from_eye = camera.cam_from_world.Inverse();
  if (!camera.HasDistortion() && camera.skew == 0) {
    t.image = image.clone();
    t.map = map.clone();
    return t;
  }
  // cv::remap samples at OpenCV pixel coordinates (centres on integers): the
  // hullpipe coordinate minus 0.5. Off the valid radius: far outside, so black.
  cv::Mat mx(size, CV_32FC1), my(size, CV_32FC1);
  const double r2_max = camera.MaxValidRadius2();
  for (int r = 0; r < camera.height; ++r)
    for (int c = 0; c < camera.width; ++c) {
      const Eigen::Vector2d xn((c + 0.5 - camera.cx) / camera.fx, (r + 0.5 - camera.cy) / camera.fy);
      float u = -10, v = -10;
      if (xn.squaredNorm() < r2_max) {
        const Eigen::Vector2d uv = camera.PixelFromImagePlane(camera.Distort(xn));
        u = float(uv.x() - 0.5);
        v = float(uv.y() - 0.5);
      }
      mx.at<float>(r, c) = u, my.at<float>(r, c) = v;
    }
  cv::remap(image, t.image, mx, my, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  cv::remap(map, t.map, mx, my, cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  return t;
}

ImageError MaskedImageError(const cv::Mat& truth, const cv::Mat& rendered, const cv::Mat& mask) {
  if (truth.type() != CV_8UC3 || rendered.type() != CV_8UC3 || mask.type() != CV_8UC1 ||
      truth.size() != rendered.size() || mask.size() != truth.size())
    throw std::invalid_argument("MaskedImageError: needs two CV_8UC3 images and a CV_8UC1 mask of one size");
  ImageError e;
  e.pixels = cv::countNonZero(mask);
  if (e.pixels == 0) {
    e.psnr_db = ImageError::kMaxPsnrDb;
    return e;
  }
  double sum_sq = 0;
  for (int r = 0; r < truth.rows; ++r)
    for (int c = 0; c < truth.cols; ++c) {
      if (!mask.at<uint8_t>(r, c)) continue;
      const cv::Vec3b a = truth.at<cv::Vec3b>(r, c), b = rendered.at<cv::Vec3b>(r, c);
      for (int k = 0; k < 3; ++k) sum_sq += double(int(a[k]) - int(b[k])) * double(int(a[k]) - int(b[k]));
    }
  const double mse = sum_sq / (3.0 * double(e.pixels));
  e.psnr_db =
      mse > 0 ? std::min(ImageError::kMaxPsnrDb, 10.0 * std::log10(255.0 * 255.0 / mse)) : ImageError::kMaxPsnrDb;
  cv::Mat a = cv::Mat::zeros(truth.size(), CV_8UC3), b = cv::Mat::zeros(truth.size(), CV_8UC3);
  truth.copyTo(a, mask);
  rendered.copyTo(b, mask);
  cv::Mat quality;
  cv::quality::QualitySSIM::compute(a, b, quality);
  const cv::Scalar mean = cv::mean(quality, mask);
  e.ssim = (mean[0] + mean[1] + mean[2]) / 3.0;
  return e;
}

void HeldOutOptions::Check() const {
  sweep.Check();
  texture.Check();
  if (refine_iterations < 0 || refine_iterations > 30)
    throw std::invalid_argument("HeldOutOptions: refine_iterations must be 0..30");
  if (visibility_width < 0 || visibility_width > 4096)
    throw std::invalid_argument("HeldOutOptions: visibility_width must be 0..4096");
  if (threads < 1) throw std::invalid_argument("HeldOutOptions: threads must be >= 1");
}

HeldOutResult RenderHeldOut(const std::vector<CameraMap>& views, const std::vector<cv::Mat>& images,
                            const Aabb& workspace, size_t held_out, const HeldOutOptions& options) {
  options.Check();
  if (views.size() < 3 || images.size() != views.size() || held_out >= views.size())
    throw std::invalid_argument("RenderHeldOut: needs >= 3 cameras, one image per map, and a held-out index below " +
                                std::to_string(views.size()) + " (got " + std::to_string(views.size()) +
                                " maps, " + std::to_string(images.size()) + " images, index " +
                                std::to_string(held_out) + ")");
  HeldOutResult res;
  res.truth = UndistortToPinhole(views[held_out].camera, images[held_out], views[held_out].map);
  std::vector<CameraMap> other_views;
  std::vector<CameraImage> other_images;
  std::vector<Camera> other_cameras;
  for (size_t i = 0; i < views.size(); ++i) {
    if (i == held_out) continue;
    const Camera& cam = views[i].camera;
    if (images[i].type() != CV_8UC3 || images[i].cols != cam.width || images[i].rows != cam.height)
      throw std::invalid_argument("RenderHeldOut: camera " + std::to_string(cam.id) + "'s image must be CV_8UC3 " +
                                  std::to_string(cam.width) + "x" + std::to_string(cam.height));
    other_views.push_back(views[i]);
    other_images.push_back({cam, images[i]});
    other_cameras.push_back(cam);
  }
  const VolumeQuery query(other_views, workspace);
  const NovelView& view = res.truth.view;
  const cv::Rect whole(0, 0, view.width, view.height);
  const cv::Mat depth = PlaneSweepCpu(query, view, SweepPlaneDepths(query, view, options.sweep), whole, nullptr,
                                      options.threads, options.refine_iterations);
  std::optional<HullVisibility> vis;
  if (options.visibility_width > 0) {
    PlaneSweepOptions vis_sweep = options.sweep;
    vis_sweep.num_planes = std::min(options.sweep.num_planes, 48);  // as recon_node
    vis = ComputeHullVisibility(query, other_cameras, options.visibility_width, vis_sweep,
                                options.refine_iterations, options.threads);
  }
  res.rendered = TextureHull(depth, whole, view, other_images, options.texture, vis ? &*vis : nullptr);
  res.hull = cv::Mat(depth.size(), CV_8UC1);
  for (int r = 0; r < depth.rows; ++r)
    for (int c = 0; c < depth.cols; ++c) res.hull.at<uint8_t>(r, c) = std::isfinite(depth.at<float>(r, c)) ? 255 : 0;
  res.error = MaskedImageError(res.truth.image, res.rendered, res.truth.map);
  res.error_covered = MaskedImageError(res.truth.image, res.rendered, res.truth.map & res.hull);
  res.iou = MaskIoU(res.hull, res.truth.map);
  return res;
}

}  // namespace hullpipe
