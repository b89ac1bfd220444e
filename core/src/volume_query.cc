#include "hullpipe/volume_query.h"

#include <limits>
#include <stdexcept>
#include <string>

namespace hullpipe {

VolumeQuery::VolumeQuery(std::vector<CameraMap> views, const Aabb& workspace)
    : views_(std::move(views)), workspace_(workspace) {
  if (views_.empty()) throw std::invalid_argument("VolumeQuery: no cameras");
  std::vector<Camera> cams;
  std::vector<cv::Mat> maps;
  for (const auto& v : views_) {
    const Camera& c = v.camera;
    if (v.map.type() != CV_8UC1 || v.map.cols != c.width || v.map.rows != c.height)
      throw std::invalid_argument("VolumeQuery: map of camera " + std::to_string(c.id) +
                                  " must be CV_8UC1 " + std::to_string(c.width) + "x" +
                                  std::to_string(c.height));
    detail::FastCamera f{};
    for (int i = 0; i < 9; ++i) f.r[i] = float(c.cam_from_world.rotation(i / 3, i % 3));
    for (int i = 0; i < 3; ++i) f.t[i] = float(c.cam_from_world.translation[i]);
    f.fx = float(c.fx), f.fy = float(c.fy), f.cx = float(c.cx), f.cy = float(c.cy);
    f.k1 = float(c.distortion[0]), f.k2 = float(c.distortion[1]);
    f.p1 = float(c.distortion[2]), f.p2 = float(c.distortion[3]), f.k3 = float(c.distortion[4]);
    f.distorted = false;
    for (double d : c.distortion) f.distorted |= d != 0.0;
    const double r2 = c.MaxValidRadius2();
    f.r2max = r2 > 1e30 ? std::numeric_limits<float>::max() : float(r2);
    f.width = c.width, f.height = c.height;
    f.data = v.map.ptr<uint8_t>(0);
    f.step = v.map.step[0];
    fast_.push_back(f);
    cams.push_back(c);
    maps.push_back(v.map);
  }
  hull_box_ = HullBoundingBox(cams, maps, workspace_);
}

int VolumeQuery::Count(const Eigen::Vector3d& X) const {
  int count = 0;
  for (size_t i = 0; i < views_.size(); ++i) {
    const Camera& c = views_[i].camera;
    const auto uv = c.Project(X);
    if (!uv || !c.InImage(*uv)) continue;
    if (views_[i].map.at<uint8_t>(int(uv->y()), int(uv->x())) != 0) ++count;
  }
  return count;
}

bool VolumeQuery::Inside(const Eigen::Vector3d& X) const {
  if (!workspace_.Contains(X)) return false;
  for (size_t i = 0; i < views_.size(); ++i) {
    const Camera& c = views_[i].camera;
    const auto uv = c.Project(X);
    if (!uv || !c.InImage(*uv)) return false;
    if (views_[i].map.at<uint8_t>(int(uv->y()), int(uv->x())) == 0) return false;
  }
  return true;
}

VolumeQuery VolumeQuery::Subset(const std::vector<int>& indices) const {
  std::vector<CameraMap> sub;
  for (int i : indices) sub.push_back(views_.at(size_t(i)));
  return VolumeQuery(std::move(sub), workspace_);
}

}  // namespace hullpipe
