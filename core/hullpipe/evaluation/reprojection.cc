#include "hullpipe/evaluation/reprojection.h"

#include <cmath>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/util/parallel.h"

namespace hullpipe {

cv::Mat ReprojectHull(const VolumeQuery& q, const Camera& camera, double step, int threads) {
  cv::Mat out(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  const Aabb& box = q.hull_box();
  if (box.empty()) return out;
  const auto& cams = q.fast();
  const size_t n = cams.size();
  const Eigen::Vector3d O = camera.Center();
  std::vector<Eigen::Vector3f> A(n);
  for (size_t c = 0; c < n; ++c) A[c] = (q.views()[c].camera.cam_from_world * O).cast<float>();
  // A camera of the query centred where this one is sees every ray of this camera
  // as a single point: if that point is not on its object pixels the whole ray is
  // outside, so it is tested once before marching (the iou_all case).
  std::vector<size_t> same_centre;
  for (size_t c = 0; c < n; ++c)
    if ((q.views()[c].camera.Center() - O).norm() < 1e-9) same_centre.push_back(c);
  auto rows = [&](int r0, int r1) {
    std::vector<Eigen::Vector3f> B(n);
    for (int r = r0; r < r1; ++r) {
      for (int col = 0; col < camera.width; ++col) {
        const Eigen::Vector3d D = camera.PixelRayWorld({col + 0.5, r + 0.5});
        double s0 = 0, s1 = 1e9;
        if (!box.ClipRay(O, D, &s0, &s1)) continue;
        for (size_t c = 0; c < n; ++c) B[c] = (q.views()[c].camera.cam_from_world.rotation * D).cast<float>();
        bool possible = true;
        for (size_t c : same_centre) {
          const Eigen::Vector3f X = A[c] + float(0.5 * (s0 + s1)) * B[c];
          const Vote v = VolumeQuery::VoteFast(cams[c], X.x(), X.y(), X.z());
          possible = possible && !q.Vetoes(v);
        }
        if (!possible) continue;
        for (double s = s0; s <= s1; s += step) {
          int object = 0, unseen = 0;
          bool rejected = false;
          for (size_t c = 0; c < n && !rejected; ++c) {
            const Eigen::Vector3f X = A[c] + float(s) * B[c];
            const Vote v = VolumeQuery::VoteFast(cams[c], X.x(), X.y(), X.z());
            rejected = q.Vetoes(v);
            object += v == Vote::kObject;
            unseen += v == Vote::kUnseen;
          }
          const bool inside = !rejected && q.Accepts(object, unseen);
          if (inside) {
            out.at<uint8_t>(r, col) = 255;
            break;
          }
        }
      }
    }
  };
  ForEachRowBand(camera.height, threads, [&](int r0, int r1, int) { rows(r0, r1); });
  return out;
}

double MaskIoU(const cv::Mat& a, const cv::Mat& b) {
  CV_Assert(a.size() == b.size() && a.type() == CV_8UC1 && b.type() == CV_8UC1);
  const int inter = cv::countNonZero(a & b), uni = cv::countNonZero(a | b);
  return uni == 0 ? 1.0 : double(inter) / double(uni);
}

}  // namespace hullpipe
