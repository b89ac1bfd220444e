// Reading one camera's frames, and nothing else (as COLMAP's ImageReader): a
// video file, a printf pattern of images, "v4l2:<index>" or a network stream
// (RigCamera::IsLiveSpec). File readers are pulled frame by frame; live readers
// run a thread that takes frames as the camera delivers them and stamps them on
// arrival. Segmenting the frames into object-pixel maps is the caller's
// (segmentation/video_rig.h), so a new kind of camera is one reader here and
// gets background learning, masks and pacing for free.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace hullpipe {

/// Opens a camera's frames: "v4l2:<index>" through V4L2, a stream URL through
/// FFmpeg with open and read time-outs (and FFmpeg's stream probing cut to half a
/// second unless OPENCV_FFMPEG_CAPTURE_OPTIONS is set), anything else as a video
/// file or image pattern. The capture may be closed (not found, not yet up, an
/// image pattern naming no file): callers check isOpened(). Throws std::runtime_error for a malformed
/// "v4l2:" spec, a file spec that is not a regular file, and an image sequence
/// that CheckImageSequence refuses.
cv::VideoCapture OpenCameraCapture(const std::string& spec);

/// Checks every file of an image sequence (`pattern` as NumberedFile takes it,
/// from file number `first` to the first gap; a pattern without a conversion is
/// one file) from its header alone (util/image_file.h, ProbeImageFile) before
/// any is decoded: each must be a regular file holding a PNG, JPEG, BMP, PNM or
/// TIFF image within ImageLimits (16384 px a side, 256 MiB) and of the first
/// frame's size. Returns the number of files. Throws std::runtime_error naming
/// the first file that is not. Reads the start of every file once (up to 4 MiB
/// each).
int CheckImageSequence(const std::string& pattern, int first);
/// As above from FirstFileNumber(pattern).
void CheckImageSequence(const std::string& pattern);

/// An image sequence a camera spec names, checked (CheckImageSequence).
struct ImageSequence {
  std::string pattern;  ///< as NumberedFile takes it; a single file's own name when it has no digits
  int first = 0;        ///< the first file's number
  int count = 0;        ///< files from `first` to the first gap (>= 1)
};

/// The image sequence `spec` names, or std::nullopt when it names none (a video
/// file, a live camera, a missing file). A pattern ("img_%04d.png") starts at
/// FirstFileNumber; a regular file whose header is an image names the sequence
/// it starts: its basename's last run of digits becomes the number
/// ("cam1/img_0007.png" is "cam1/img_%04d.png" from 7), and a name without
/// digits is a single still image (count 1). Either way every file is checked
/// as CheckImageSequence does, which throws naming the file.
std::optional<ImageSequence> FindImageSequence(const std::string& spec);

/// The file of number `n` of a printf-style pattern ("mask_%04d.png"): one
/// integer conversion, "%d" or "%0Nd" (N <= 9); a pattern without one names a
/// single file for every frame (no printf on a file's text).
std::string NumberedFile(const std::string& pattern, int n);

/// The number of the first file of a pattern that exists, 0..4 (as OpenCV's
/// image sequences count), so that file k goes with frame k; 0 if none does.
int FirstFileNumber(const std::string& pattern);

/// A video file or image sequence read frame by frame. Image sequences
/// (FindImageSequence) are read file by file here with the header checks of
/// ReadImageFile, not through OpenCV's capture: its sequences start only at
/// file 0 or 1, and a sequence's first file given by name is opened by FFmpeg as
/// one still frame.
class FileCameraReader {
 public:
  /// Opens `spec` from its first frame. Throws std::runtime_error naming the
  /// camera and the spec when it cannot be opened.
  FileCameraReader(int camera_id, std::string spec);
  /// Reads the image sequence FindImageSequence found for `spec`, not checked
  /// again (a Reopen checks it again).
  FileCameraReader(int camera_id, std::string spec, ImageSequence sequence);
  /// Back to the first frame (reopens). Throws as the constructor.
  void Reopen();
  /// The next frame (as decoded, any type and size); false at its end or on a
  /// decoder error.
  bool Read(cv::Mat* image);
  /// Passes over the next frame without decoding it; false at its end.
  bool Grab();
  /// Frames the container declares (estimates; 0 when unknown or absurd); an
  /// image sequence's file count.
  int64_t declared_frames() const { return declared_frames_; }
  /// Why the last Read failed before the end, naming the file (image
  /// sequences), or empty.
  const std::string& error() const { return error_; }
  /// The image sequence read, or std::nullopt for a video.
  const std::optional<ImageSequence>& sequence() const { return sequence_; }
  /// The container's frame rate, or 0 when it gives none in (1, 1000).
  double fps() const { return fps_; }
  const std::string& spec() const { return spec_; }

 private:
  int camera_id_;
  std::string spec_;
  cv::VideoCapture capture_;
  std::optional<ImageSequence> sequence_;
  int next_ = 0;  ///< the sequence's next frame index
  std::string error_;
  int64_t declared_frames_ = 0;
  double fps_ = 0;
};

/// What live readers share: one lock and one wake-up for "a frame arrived from
/// any camera".
struct LiveHub {
  std::mutex mu;
  std::condition_variable cv;
};

/// Reads one live camera on its own thread, as fast as it delivers, stamping
/// each frame on arrival (CLOCK_REALTIME ns, before it waits for the capture
/// loop) into a short queue (latest wins: the oldest of kQueue frames is
/// dropped). A camera not up yet is retried; a stream silent for two read
/// time-outs is reopened. The thread owns its state with the reader: a reader
/// destroyed while its thread is blocked in FFmpeg (an open or read time-out,
/// at most 2 s) lets it finish alone, so the node stops at once.
class LiveCameraReader {
 public:
  static constexpr size_t kQueue = 4;
  LiveCameraReader(int camera_id, std::string spec, std::shared_ptr<LiveHub> hub);
  /// Joins a finished thread; one still blocked in FFmpeg is left to finish.
  ~LiveCameraReader();
  LiveCameraReader(const LiveCameraReader&) = delete;
  LiveCameraReader& operator=(const LiveCameraReader&) = delete;
  /// Asks the thread to stop; it notices within a read time-out (0.5 s).
  void RequestStop();
  /// The thread has ended (stopped, or a malformed spec).
  bool Done() const;
  /// Under the hub's mutex: takes the oldest queued frame and its arrival time.
  bool Pop(cv::Mat* image, int64_t* arrival_ns);
  /// Under the hub's mutex: a frame is queued.
  bool HasFrame() const;
  /// Asks every reader to stop, then gives them together up to 0.5 s to finish
  /// (each in turn would add their time-outs past the second a node has to stop).
  static void StopAll(const std::vector<LiveCameraReader*>& readers);

 private:
  struct State;
  static void Run(State& s);
  std::shared_ptr<State> s_;
  std::thread thread_;
};

/// Up to `count` frames of `spec` (video, image or live) that have the
/// calibrated size and type CV_8UC3 (frames of another size are passed over).
/// Throws std::runtime_error "camera <id>: cannot open <what>" if it cannot be
/// opened (what: e.g. "background <spec>").
std::vector<cv::Mat> ReadCalibratedFrames(int camera_id, const std::string& what, const std::string& spec, int count,
                                          int width, int height);

}  // namespace hullpipe
