#include "hullpipe/reconstruction/tile_set.h"

#include <algorithm>

#include "hullpipe/geometry/conventions.h"

namespace hullpipe {
namespace {

bool Fits(const HullTile& t, cv::Size size) {
  const cv::Rect& r = t.rect;
  return r.x >= 0 && r.y >= 0 && r.width > 0 && r.height > 0 && r.width <= size.width - r.x &&
         r.height <= size.height - r.y && t.depth.type() == CV_32FC1 && t.depth.size() == r.size() &&
         t.colour.type() == CV_8UC3 && t.colour.size() == r.size();
}

}  // namespace

HullViewImage PasteTiles(const std::vector<const HullTile*>& tiles, cv::Size size, StopFlag stop) {
  HullViewImage v;
  // Filled row by row, not by the constructor: a large view's first touch of
  // its pages takes most of a second on some machines, and a stop is polled.
  v.depth.create(size, CV_32FC1);
  v.colour.create(size, CV_8UC3);
  for (int r = 0; r < size.height; ++r) {
    ThrowIfStopped(stop, "pasting the tiles");
    std::fill_n(v.depth.ptr<float>(r), size.width, kNoDepth);
    std::fill_n(v.colour.ptr<uint8_t>(r), size_t(size.width) * 3, uint8_t{0});
  }
  for (const HullTile* t : tiles) {
    ThrowIfStopped(stop, "pasting the tiles");
    if (!t || !Fits(*t, size)) continue;
    t->depth.copyTo(v.depth(t->rect));
    t->colour.copyTo(v.colour(t->rect));
  }
  return v;
}

std::optional<HullViewImage> TileSet::Add(HullTile t) {
  if (t.tile_count == 0 || t.tile_count > kMaxTiles || t.tile_index >= t.tile_count ||
      !Fits(t, {kMaxViewSide, kMaxViewSide})) {
    ++refused_;
    return std::nullopt;
  }
  const uint64_t pose = t.pose_seq;
  const uint64_t newest = pending_.empty() ? pose : std::max(pose, pending_.rbegin()->first);
  if (newest - pose > kPendingPoses) {  // older than every pose still waited for
    ++refused_;
    return std::nullopt;
  }
  // Poses that never completed: dropped once kPendingPoses newer ones are seen,
  // or, oldest first, when the tiles waiting would hold more than
  // max_pending_pixels_.
  auto drop_oldest = [&] {
    for (const auto& [index, tile] : pending_.begin()->second) pending_pixels_ -= tile.rect.area();
    pending_.erase(pending_.begin());
    ++dropped_;
  };
  while (!pending_.empty() && newest - pending_.begin()->first > kPendingPoses) drop_oldest();
  auto& set = pending_[pose];
  if (!set.empty() && set.begin()->second.tile_count != t.tile_count) {
    ++refused_;
    return std::nullopt;
  }
  const auto same = set.find(t.tile_index);
  if (same != set.end()) {
    pending_pixels_ -= same->second.rect.area();
    set.erase(same);
  }
  pending_pixels_ += t.rect.area();
  const uint32_t count = t.tile_count;
  set[t.tile_index] = std::move(t);
  while (pending_pixels_ > max_pending_pixels_) drop_oldest();
  if (!pending_.count(pose) || set.size() < count) return std::nullopt;  // (set is gone if its pose was dropped)
  cv::Rect all;
  std::vector<const HullTile*> tiles;
  for (const auto& [index, tile] : set) {
    all |= tile.rect;
    tiles.push_back(&tile);
  }
  HullViewImage v = PasteTiles(tiles, {all.br().x, all.br().y});
  for (const HullTile* tile : tiles) pending_pixels_ -= tile->rect.area();
  pending_.erase(pose);
  return v;
}

}  // namespace hullpipe
