#include "hullpipe/openxr/eye_images.h"

#include <stdexcept>

namespace hullpipe::openxr {

EyeImagePairs::EyeImagePairs(size_t pose_history) : history_(pose_history) {
  if (history_ < 2) throw std::invalid_argument("EyeImagePairs keeps at least 2 poses");
}

void EyeImagePairs::AddPose(uint64_t run_id, uint64_t pose_seq, ViewEye eye, const NovelView& view) {
  if (eye == ViewEye::kMono) {
    ++counts_.not_an_eye;
    return;
  }
  if (run_ != run_id) {
    // A restarted render_node numbers its poses from 1 again: the last run's
    // poses, unpaired images and last pair say nothing about this one's.
    if (run_) ++counts_.run_changes;
    run_ = run_id;
    poses_.clear();
    pose_order_.clear();
    newest_[0].reset();
    newest_[1].reset();
    last_pair_left_seq_.reset();
  }
  const std::pair<uint64_t, int> key{pose_seq, int(eye) - 1};
  if (poses_.emplace(key, view).second) pose_order_.push_back(key);
  while (pose_order_.size() > history_) {
    poses_.erase(pose_order_.front());
    pose_order_.pop_front();
  }
  // An image that came first.
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (it->first == key.second && it->second.pose_seq == pose_seq && it->second.run_id == run_id) {
      EyeImage image = std::move(it->second);
      image.view = view;
      it = pending_.erase(it);
      Keep(std::move(image), key.second);
    } else {
      ++it;
    }
  }
}

void EyeImagePairs::Keep(EyeImage image, int k) {
  std::optional<EyeImage>& newest = newest_[size_t(k)];
  if (newest) {
    ++counts_.superseded;  // the older of the two
    if (newest->pose_seq > image.pose_seq) return;
  }
  newest = std::move(image);
}

std::string EyeImagePairs::AddImage(uint64_t run_id, uint64_t pose_seq, ViewEye eye, uint64_t frame_seq,
                                    DecodeImageFn decode) {
  if (eye == ViewEye::kMono) {
    ++counts_.not_an_eye;
    return "a composited view of the one view, not an eye (render_node runs without --stereo or "
           "--view eyes-topic)";
  }
  const int k = int(eye) - 1;
  const auto pose = run_ == run_id ? poses_.find({pose_seq, k}) : poses_.end();
  if (pose != poses_.end()) {
    Keep(EyeImage{cv::Mat(), pose->second, pose_seq, run_id, frame_seq, std::move(decode)}, k);
    return "";
  }
  pending_.emplace_back(k, EyeImage{cv::Mat(), NovelView{}, pose_seq, run_id, frame_seq, std::move(decode)});
  if (pending_.size() <= kPendingImages) return "";
  const uint64_t dropped = pending_.front().second.pose_seq;
  pending_.pop_front();
  ++counts_.no_pose;
  return "no ViewPose " + std::to_string(dropped) + " for its eye";
}

std::optional<std::array<EyeImage, 2>> EyeImagePairs::TakeNewPair() {
  if (!newest_[0] || !newest_[1]) return std::nullopt;
  const EyeImage& l = *newest_[0];
  const EyeImage& r = *newest_[1];
  if (r.pose_seq != l.pose_seq + 1 || r.frame_seq != l.frame_seq) return std::nullopt;
  if (last_pair_left_seq_ && l.pose_seq <= *last_pair_left_seq_) return std::nullopt;
  // Decoded now, once handed out: an image superseded before is never decoded.
  bool decoded = true;
  for (std::optional<EyeImage>& e : newest_) {
    if (e->bgr.empty() && e->decode) {
      e->bgr = e->decode();
      ++counts_.decoded;
      e->decode = nullptr;
    }
    if (e->bgr.empty()) {
      ++counts_.undecodable;
      e.reset();
      decoded = false;
    }
  }
  if (!decoded) return std::nullopt;
  std::array<EyeImage, 2> pair{std::move(*newest_[0]), std::move(*newest_[1])};
  newest_[0].reset();
  newest_[1].reset();
  last_pair_left_seq_ = pair[0].pose_seq;
  ++counts_.paired;
  return pair;
}

}  // namespace hullpipe::openxr
