// What every conversion between hullpipe's samples and its DDS messages shares
// (convert.h, node_stats_convert.h): the error a bad received sample raises, an
// outgoing sample that owns its sequences' buffers, and Vec3 conversions.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe.h"  // idlc-generated

namespace hullpipe::dds {

/// A received sample that cannot be used; what() says why in one line.
class MessageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An outgoing sample that owns the buffers its sequences point at. Move-only
/// (moving keeps the heap buffers, so the pointers stay valid).
template <typename Msg>
struct OwnedSample {
  Msg msg{};
  std::vector<uint8_t> bytes;
  std::vector<uint32_t> words;
  std::vector<float> floats;
  std::vector<hullpipe_msg_Vec3> vec3s;
  std::vector<hullpipe_msg_StageTiming> stages;
  std::vector<hullpipe_msg_CameraSkew> cameras;
  std::vector<hullpipe_msg_PartState> part_states;
  std::vector<std::string> strings;  ///< Reserved before use: their c_str() stay put.
  OwnedSample() = default;
  OwnedSample(const OwnedSample&) = delete;
  OwnedSample& operator=(const OwnedSample&) = delete;
  OwnedSample(OwnedSample&&) = default;
  OwnedSample& operator=(OwnedSample&&) = default;
};

/// Points an outgoing message's sequence (idlc's _maximum/_length/_buffer/
/// _release) at a vector's elements, without copying and without handing
/// Cyclone ownership: the vector must outlive the write.
template <typename Seq, typename T>
void Borrow(Seq* seq, std::vector<T>& v) {
  seq->_buffer = v.data();
  seq->_length = seq->_maximum = uint32_t(v.size());
  seq->_release = false;
}

inline hullpipe_msg_Vec3 ToMsg(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
inline Eigen::Vector3d FromMsg(const hullpipe_msg_Vec3& v) { return {v.x, v.y, v.z}; }

}  // namespace hullpipe::dds
