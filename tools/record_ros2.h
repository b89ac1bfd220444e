// `hullpipe_record export --ros2` (docs/ros2.md, "Bags"): a recording's
// cameras, maps and frames as the ROS 2 topics hullpipe_ros2 publishes live,
// in an MCAP file written as rosbag2 writes one (profile ros2, schemas
// `ros2msg` with every type they use, messages `cdr`, channels with
// `offered_qos_profiles`), so `ros2 bag play`, Foxglove and Lichtblick open
// it as ROS 2 data. Logged at each sample's arrival time; stamped with its
// capture time.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/geometry/camera.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/ros2/ros2_deriver.h"

namespace hullpipe::record {

/// Writes the ROS 2 MCAP. Not thread-safe.
class Ros2Export {
 public:
  /// Creates `path` (MCAP, zstd chunks, profile ros2; never overwritten);
  /// `participant` (de)serializes samples. Throws RecordingError.
  Ros2Export(const std::string& path, const dds::Participant& participant);
  /// A recorded sample of hullpipe's: what it gives as ROS 2 messages
  /// (ros2_deriver.h: calibrations on /tf_static, maps, frames, the view and
  /// its pose, the hull's points, markers), logged at its arrival. False if it
  /// does not decode or convert (nothing written). Other types are passed over
  /// (true).
  bool Add(const TopicInfo& topic, const Sample& sample);
  /// Messages written, per ROS 2 topic.
  const std::map<std::string, int64_t>& counts() const { return counts_; }
  const std::string& path() const { return path_; }

 private:
  void Write(const std::string& ros_topic, const std::string& type, const dds::QosSpec& qos, const void* msg,
             int64_t log_ns, int64_t stamp_ns);
  const dds::CdrWriter& Codec(const std::string& type);
  std::string path_;
  const dds::Participant& participant_;
  RecordingWriter w_;
  std::map<std::string, std::unique_ptr<dds::CdrWriter>> codecs_;  // by type (hullpipe's and ROS 2's)
  std::map<std::string, int64_t> ids_;                              // ROS 2 topic -> channel id
  std::map<std::string, int64_t> counts_;
  ros2::Ros2Deriver deriver_;
  int64_t appended_ = 0;
  int64_t log_ns_ = 0;  // the arrival of the sample being derived
};

}  // namespace hullpipe::record
