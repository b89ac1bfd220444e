// render_node's files and window: the composited video (MPEG-4), every K-th frame
// as PNG (with the hull's depth and its view on request), a window where a
// display exists, and at the end stats.json and the latency budget's rows. A
// file that cannot be written is said once, counted, and fails the run
// (docs/reliability.md): no exit 0 with missing output.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "hullpipe/nodes/render_controller.h"
#include "hullpipe/reconstruction/plane_sweep.h"

namespace hullpipe::nodes {

/// What render_node writes, and where (its flags).
struct RenderOutputOptions {
  std::string out_dir = "out";  ///< Created if missing.
  double video_fps = 15;        ///< Written into the video's header.
  int png_every = 0;            ///< Every K-th composited frame as PNG (0: none).
  bool save_depth = false;      ///< With each PNG, frame_N_depth.tiff (float eye z, metres) and views.csv.
  bool show = false;            ///< A window (cv::imshow); turned off with a warning if none opens.
};

class RenderOutputs {
 public:
  /// Creates options.out_dir (std::filesystem::filesystem_error if it cannot).
  /// The video is opened with the first frame.
  explicit RenderOutputs(RenderOutputOptions options);
  /// The `count`-th composited frame (CV_8UC3) of frameset frame_seq, as
  /// RenderSink::WriteFrame: appended to the video, written as PNG when due
  /// (with hull_depth, CV_32FC1 metres, and the view's K and world_from_eye in
  /// views.csv under save_depth), shown. With `right` (render --stereo: the
  /// frame holds both eyes side by side), view and hull_depth are the left
  /// eye's, and the right eye's go to frame_N_right_depth.tiff and
  /// views_right.csv (the same columns).
  void WriteFrame(const cv::Mat& frame, uint64_t frame_seq, uint64_t count, const NovelView& view,
                  const cv::Mat& hull_depth, double path_time_s, const RenderSink::RightEye* right = nullptr);
  /// Finishes the video.
  void Close() { video_.release(); }
  /// out_dir/hullpipe.mp4.
  std::string video_path() const;
  int64_t video_frames() const { return video_frames_; }
  /// Output files that could not be written (the video, PNGs, depth TIFFs), and the first.
  int64_t failures() const { return failures_; }
  const std::string& first_failure() const { return first_failure_; }
  /// Writes `text` to out_dir/name; false (and counted as a failure) if it could not.
  bool WriteTextFile(const std::string& name, const std::string& text);

 private:
  void Write(const std::string& path, const cv::Mat& image);
  void Failed(const std::string& path);
  RenderOutputOptions o_;
  cv::VideoWriter video_;
  bool video_failed_ = false;
  int64_t video_frames_ = 0;
  std::ofstream views_, views_right_;
  // One row of views.csv (opened with its header on the first).
  void WriteView(std::ofstream& out, const std::string& name, uint64_t frame_seq, double path_time_s,
                 const NovelView& view);
  int64_t failures_ = 0;
  std::string first_failure_;
};

}  // namespace hullpipe::nodes
