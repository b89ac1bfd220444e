#include "hullpipe/reconstruction/volume_query.h"

#include <algorithm>
#include <limits>
#include <set>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace hullpipe {

void VolumeQueryOptions::Check() const {
  if (min_seen < 1) throw std::invalid_argument("VolumeQueryOptions.min_seen must be >= 1");
}

namespace {

// Does the camera see the whole box (every corner in front, inside the image and
// the valid radius)? Exact for a pinhole camera, whose view is a convex pyramid.
bool SeesWholeBox(const Camera& c, const Aabb& box) {
  if (box.empty()) return true;
  for (const auto& X : box.Corners()) {
    const auto uv = c.Project(X);
    if (!uv || !c.InImage(*uv)) return false;
  }
  return true;
}

// kUnknown's hull box. An inside point X is seen by a set T of at least m cameras
// and lies in each of their silhouette pyramids. For every m-subset S: take the
// box of the pyramids of S; a camera that sees all of that box sees X too, so it
// is in T and its pyramid is added; repeat until none is added. X lies in that
// final box for some S ⊆ T, so the union of the final boxes is conservative.
// Cameras that see the whole workspace join every S (they always vote).
Aabb UnknownPolicyHullBox(const std::vector<Camera>& cams, const std::vector<cv::Rect>& rects, const Aabb& workspace,
                          int m) {
  const size_t n = cams.size();
  Aabb out;
  std::vector<int> pick(n, 0);
  std::fill(pick.end() - m, pick.end(), 1);  // the first combination in next_permutation order
  int subsets = 0;
  // Camera sets already grown from: the growth from a set is the same whatever
  // subset it started from, so each is followed once (many subsets grow into the
  // same few sets).
  std::set<std::vector<char>> followed;
  do {
    if (++subsets > 4096) return workspace;  // too many cameras for the exact union: stay conservative
    std::vector<char> in(pick.begin(), pick.end());
    Aabb box;
    for (;;) {
      if (!followed.insert(in).second) {
        box = Aabb{};  // its final box is in `out` already
        break;
      }
      std::vector<Camera> sc;
      std::vector<cv::Rect> sr;
      for (size_t i = 0; i < n; ++i)
        if (in[i]) sc.push_back(cams[i]), sr.push_back(rects[i]);
      box = HullBoundingBox(sc, sr, workspace);
      if (box.empty()) break;
      bool added = false;
      for (size_t i = 0; i < n; ++i)
        if (!in[i] && SeesWholeBox(cams[i], box)) in[i] = 1, added = true;
      if (!added) break;
    }
    if (!box.empty()) {
      out.Extend(box.min);
      out.Extend(box.max);
    }
  } while (std::next_permutation(pick.begin(), pick.end()));
  return out;
}

}  // namespace

VolumeQuery::VolumeQuery(std::vector<CameraMap> views, const Aabb& workspace, const VolumeQueryOptions& options)
    : views_(std::move(views)), workspace_(workspace), options_(options) {
  if (views_.empty()) throw std::invalid_argument("VolumeQuery: no cameras");
  options_.Check();
  const int n = int(views_.size());
  required_seen_ = options_.out_of_view == OutOfView::kOutside ? n : std::min(options_.min_seen, n);
  std::vector<Camera> cams;
  std::vector<cv::Rect> rects;  // each map's object pixels' bounding rectangle, found once
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
    f.distorted = c.HasDistortion();
    const double r2 = c.MaxValidRadius2();
    f.r2max = r2 > 1e30 ? std::numeric_limits<float>::max() : float(r2);
    f.width = c.width, f.height = c.height;
    f.data = v.map.ptr<uint8_t>(0);
    f.step = v.map.step[0];
    fast_.push_back(f);
    cams.push_back(c);
    rects.push_back(cv::boundingRect(v.map));
  }
  if (options_.out_of_view == OutOfView::kOutside) {
    hull_box_ = HullBoundingBox(cams, rects, workspace_);
    return;
  }
  hull_box_ = UnknownPolicyHullBox(cams, rects, workspace_, required_seen_);
}

Vote VolumeQuery::VoteOf(size_t i, const Eigen::Vector3d& X) const {
  const Camera& c = views_.at(i).camera;
  const auto uv = c.Project(X);
  if (!uv || !c.InImage(*uv)) return Vote::kUnseen;
  return views_[i].map.at<uint8_t>(int(uv->y()), int(uv->x())) != 0 ? Vote::kObject : Vote::kBackground;
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
  int object = 0, unseen = 0;
  for (size_t i = 0; i < views_.size(); ++i) {
    switch (VoteOf(i, X)) {
      case Vote::kBackground: return false;
      case Vote::kObject: ++object; break;
      case Vote::kUnseen: ++unseen; break;
    }
  }
  return Accepts(object, unseen);
}

VolumeQuery VolumeQuery::Subset(const std::vector<int>& indices) const {
  std::vector<CameraMap> sub;
  for (int i : indices) sub.push_back(views_.at(size_t(i)));
  return VolumeQuery(std::move(sub), workspace_, options_);
}

}  // namespace hullpipe
