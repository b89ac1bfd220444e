// hullpipe_bridge's channels and what they need from DDS, apart from DDS
// readers and sockets (docs/recording.md, "Live view"): the table of channels
// it advertises -- channel i + 1 is hullpipe's type i as it is on the wire
// (cdr, its omgidl schema), then the fixed viewable channels (channels.h) --
// each camera's viewable channels added when its calibration first arrives
// (at most kMaxCameras cameras; the rest refused and counted), and which
// hullpipe types the channels that clients want need a reader for.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/foxglove/bridge_state.h"
#include "hullpipe/geometry/calibration.h"

namespace hullpipe::foxglove {

class BridgeChannels {
 public:
  /// The most cameras whose viewable channels are advertised (a rig's limit).
  static constexpr size_t kMaxCameras = Rig::kMaxCameras;

  /// `types`: hullpipe's topics (dds::KnownTypes()); they must hold
  /// "hullpipe::msg::CameraInfo" and every type a viewable channel is made
  /// from (std::logic_error otherwise).
  explicit BridgeChannels(const std::vector<dds::KnownType>& types);

  /// Every channel known now: the types', the fixed viewable ones, then each
  /// camera's as it was added.
  const std::vector<bridge::Channel>& channels() const { return channels_; }

  /// The channel of a viewable topic. A camera's topic seen first adds that
  /// camera's channels (appended to *added, to advertise) unless kMaxCameras
  /// cameras are known: then nullopt, and refused() counts it. nullopt also for
  /// a topic that is neither fixed nor a camera's.
  std::optional<uint32_t> ChannelOf(const std::string& topic, std::vector<bridge::Channel>* added);
  /// Viewable messages of cameras past kMaxCameras, refused.
  uint64_t refused() const { return refused_; }
  /// The camera id refused first (-1: none), for the one log line.
  int64_t first_refused_camera() const { return first_refused_; }

  /// What the wanted channels (BridgeState::Wanted) need read: `raw`, types
  /// routed as they are (their own channels); `derived`, types the viewable
  /// channels are made from, but CameraInfo, which is always read; `all`, both.
  struct Needs {
    std::set<size_t> raw, derived, all;  ///< Indexes into the types given.
  };
  Needs ReadersFor(const std::set<uint32_t>& wanted) const;
  /// Whether a viewable topic's channel is among `wanted`.
  bool IsWanted(const std::string& topic, const std::set<uint32_t>& wanted) const;

  /// The index of CameraInfo among the types given.
  size_t camera_info() const { return camera_info_; }

 private:
  bridge::Channel AddViewable(const std::string& topic, const std::string& schema_name, const std::string& schema);
  /// The index of `type_name` among the types; std::logic_error if it is none.
  size_t TypeIndex(const std::string& type_name) const;

  const std::vector<dds::KnownType>& types_;
  std::vector<bridge::Channel> channels_;
  std::map<std::string, uint32_t> viewable_;         // topic -> channel
  std::map<uint32_t, std::vector<size_t>> sources_;  // viewable channel -> the types it is made from
  std::set<int64_t> cameras_;
  size_t camera_info_ = 0;
  uint32_t next_id_ = 0;
  uint64_t refused_ = 0;
  int64_t first_refused_ = -1;
};

}  // namespace hullpipe::foxglove
