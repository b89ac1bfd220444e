#include "hullpipe/reconstruction/frameset.h"

namespace hullpipe {

FramesetAssembler::FramesetAssembler(size_t max_pending, bool want_images)
    : max_pending_(std::max<size_t>(1, max_pending)), want_images_(want_images) {}

void FramesetAssembler::SetCamera(const Camera& camera) {
  // Maps of this camera evicted before its first CameraInfo were a start-up race
  // (DDS does not order samples across topics), not bad input: dropped, not rejected.
  if (!cameras_.count(camera.id)) {
    const auto e = evicted_uncalibrated_.find(camera.id);
    if (e != evicted_uncalibrated_.end()) {
      rejected_ -= e->second;
      dropped_ += e->second;
      evicted_uncalibrated_.erase(e);
    }
  }
  cameras_[camera.id] = camera;
  // Check maps that arrived before this calibration.
  for (auto& [seq, p] : pending_) {
    const auto m = p.maps.find(camera.id);
    if (m != p.maps.end() && (m->second.cols != camera.width || m->second.rows != camera.height)) {
      ++rejected_;
      p.maps.erase(m);
    }
  }
}

void FramesetAssembler::Evict(std::map<uint64_t, Pending>::iterator it) {
  for (const auto& [id, map] : it->second.maps)
    if (!cameras_.count(id)) {
      ++rejected_;  // no CameraInfo (yet): rejected unless one comes later
      ++evicted_uncalibrated_[id];
    }
  pending_.erase(it);
}

bool FramesetAssembler::Reject(std::string* why, std::string text) {
  ++rejected_;
  if (why) *why = std::move(text);
  return false;
}

FramesetAssembler::Pending* FramesetAssembler::Slot(uint64_t seq, int64_t t, int camera_count) {
  auto it = pending_.find(seq);
  if (it == pending_.end()) {
    it = pending_.emplace(seq, Pending{}).first;
    it->second.capture_time_ns = t;
    it->second.expected = camera_count;
    // Latest wins: evict the oldest frames beyond the bound.
    while (pending_.size() > max_pending_) {
      const auto oldest = pending_.begin();
      ++dropped_;
      taken_up_to_ = std::max(taken_up_to_, oldest->first);
      Evict(oldest);
    }
    it = pending_.find(seq);
    if (it == pending_.end()) return nullptr;  // it was the oldest itself
  }
  return &it->second;
}

void FramesetAssembler::CheckRestart(uint64_t seq) {
  if (taken_up_to_ > kRestartGap && seq + kRestartGap < taken_up_to_) {
    pending_.clear();
    taken_up_to_ = 0;
    ++restarts_;
  }
}

bool FramesetAssembler::AddMap(int camera_id, uint64_t seq, int64_t t, int camera_count, cv::Mat map,
                               std::string* why, double source_time_s) {
  const auto cam = cameras_.find(camera_id);
  if (map.type() != CV_8UC1 || map.empty())
    return Reject(why, "map of camera " + std::to_string(camera_id) + " is not a CV_8UC1 image");
  if (cam != cameras_.end() && (map.cols != cam->second.width || map.rows != cam->second.height))
    return Reject(why, "map of camera " + std::to_string(camera_id) + " is " + std::to_string(map.cols) +
                           "x" + std::to_string(map.rows) + ", calibration says " +
                           std::to_string(cam->second.width) + "x" + std::to_string(cam->second.height));
  if (camera_count < 1 || camera_count > 64)
    return Reject(why, "map of camera " + std::to_string(camera_id) + " states " +
                           std::to_string(camera_count) + " cameras");
  CheckRestart(seq);
  if (IsGone(seq)) {
    ++dropped_;
    if (why) *why = "frame " + std::to_string(seq) + " arrived after a newer frame was used";
    return false;
  }
  Pending* p = Slot(seq, t, camera_count);
  if (!p) return false;
  if (p->expected == 0) p->expected = camera_count, p->capture_time_ns = t;
  p->source_time_s = source_time_s;
  p->maps[camera_id] = std::move(map);
  return true;
}

bool FramesetAssembler::AddImage(int camera_id, uint64_t seq, int64_t t, cv::Mat image, std::string* why) {
  if (image.empty() || image.type() != CV_8UC3)
    return Reject(why, "image of camera " + std::to_string(camera_id) + " is not BGR8");
  CheckRestart(seq);
  if (IsGone(seq)) {
    ++dropped_;
    return false;
  }
  Pending* p = Slot(seq, t, 0);
  if (!p) return false;
  p->images[camera_id] = std::move(image);
  return true;
}

bool FramesetAssembler::Complete(const Pending& p) const {
  if (p.expected < 1 || int(p.maps.size()) < p.expected) return false;
  for (const auto& [id, map] : p.maps)
    if (!cameras_.count(id)) return false;  // parked until its CameraInfo arrives
  if (want_images_ && int(p.images.size()) < p.expected) return false;
  return true;
}

std::optional<uint64_t> FramesetAssembler::NewestComplete() const {
  for (auto it = pending_.rbegin(); it != pending_.rend(); ++it)
    if (Complete(it->second)) return it->first;
  return std::nullopt;
}

bool FramesetAssembler::IsComplete(uint64_t seq) const {
  const auto it = pending_.find(seq);
  return it != pending_.end() && Complete(it->second);
}

std::optional<Frameset> FramesetAssembler::Take(uint64_t seq) {
  const auto it = pending_.find(seq);
  if (it == pending_.end() || !Complete(it->second)) return std::nullopt;
  Frameset f;
  f.seq = seq;
  f.capture_time_ns = it->second.capture_time_ns;
  f.source_time_s = it->second.source_time_s;
  for (auto& [id, map] : it->second.maps) {
    f.maps.push_back({cameras_.at(id), map});
    const auto img = it->second.images.find(id);
    if (img != it->second.images.end()) f.images.push_back({cameras_.at(id), img->second});
  }
  while (pending_.begin() != it) {
    if (Complete(pending_.begin()->second)) ++dropped_;
    Evict(pending_.begin());
  }
  pending_.erase(it);
  taken_up_to_ = std::max(taken_up_to_, seq);
  return f;
}

std::optional<Frameset> FramesetAssembler::TakeNewest() {
  const auto seq = NewestComplete();
  if (!seq) return std::nullopt;
  return Take(*seq);
}

}  // namespace hullpipe

namespace hullpipe {

Aabb FramesetAssembler::workspace() const {
  if (!workspace_.empty()) return workspace_;
  std::vector<Camera> cams;
  for (const auto& [id, c] : cameras_) cams.push_back(c);
  return DefaultWorkspace(cams);
}

}  // namespace hullpipe
