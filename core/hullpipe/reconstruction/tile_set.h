// Joining the tiles of one novel view (paper §3.3 with §5's split of the view:
// each recon node renders one rectangle of it for the same head pose). The
// renderer, the recording's export and the live viewable channels all paste
// the same tiles into one view; the ones that see only traffic (export, the
// Foxglove channels) also gather them by pose here. Transport-free: tested
// with made-up tiles.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/pipeline/messages.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// The largest view, pixels a side, a tile may lie in (as render_node's
/// --width/--height and the HullView message's own bound).
constexpr int kMaxViewSide = 8192;

/// The hull as seen from the view: eye-z depth (CV_32FC1 metres, kNoDepth where
/// no hull) and colour (CV_8UC3 BGR), both of the view's size.
struct HullViewImage {
  cv::Mat depth, colour;
};

/// Pastes `tiles` into a view of `size` pixels: pixels no tile covers have depth
/// kNoDepth and colour black. A tile whose rectangle does not lie inside the
/// view, or whose depth or colour is not of its rectangle's size and type, is
/// left out (callers validate tiles as they arrive; see TileSet::Add). Null
/// pointers are left out. Overlapping tiles: the later one wins. `stop`
/// (util/interrupt.h) is polled per row while the view is filled and per tile:
/// once set, throws Interrupted (an 8192x8192 view is 448 MB to fill).
HullViewImage PasteTiles(const std::vector<const HullTile*>& tiles, cv::Size size, StopFlag stop = nullptr);

/// Gathers tiles by pose (HullTile::pose_seq) until a pose has all its
/// tile_count tiles, then returns the joined view. Bounded: at most kMaxTiles
/// tiles a pose; a pose still incomplete when kPendingPoses newer poses have
/// been seen (a recon node's tile lost) is dropped, and so are the oldest
/// poses while the waiting tiles hold more than max_pending_pixels (by default
/// two views of the largest size): counted in dropped(). A tile repeated (same pose and
/// index) replaces the earlier one.
class TileSet {
 public:
  static constexpr uint32_t kMaxTiles = 64;      ///< render_node's --tiles bound.
  static constexpr uint64_t kPendingPoses = 64;
  static constexpr int64_t kMaxPendingPixels = 2 * int64_t(kMaxViewSide) * kMaxViewSide;

  TileSet() = default;
  /// max_pending_pixels: the bound on the waiting tiles' summed areas (> 0).
  explicit TileSet(int64_t max_pending_pixels) : max_pending_pixels_(max_pending_pixels) {}

  /// Adds one tile. Returns the pose's whole view, of the size of the union of
  /// its tiles' rectangles and (0, 0), when `t` completes it; nullopt otherwise.
  /// A tile with tile_count 0 or above kMaxTiles, tile_index >= tile_count, a
  /// count differing from its pose's earlier tiles, a pose more than
  /// kPendingPoses older than the newest, a rectangle outside kMaxViewSide
  /// square or images not of its rectangle's size is refused and counted.
  std::optional<HullViewImage> Add(HullTile t);

  int64_t refused() const { return refused_; }  ///< Tiles refused by Add.
  int64_t dropped() const { return dropped_; }  ///< Incomplete poses given up on.
  size_t pending() const { return pending_.size(); }  ///< Poses waiting for tiles.

 private:
  std::map<uint64_t, std::map<uint32_t, HullTile>> pending_;  // pose_seq -> tile_index -> tile
  int64_t max_pending_pixels_ = kMaxPendingPixels;
  int64_t pending_pixels_ = 0;  // the waiting tiles' rectangles' areas, summed
  int64_t refused_ = 0, dropped_ = 0;
};

}  // namespace hullpipe
