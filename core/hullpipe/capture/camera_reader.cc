#include "hullpipe/capture/camera_reader.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/image_file.h"

namespace hullpipe {
namespace {

// Live captures give up a blocking open or read after these, so a reader thread
// notices a stop request within half a second (every process stops within a
// second of SIGINT) and a silent stream is reported rather than waited on forever.
constexpr int kLiveOpenTimeoutMs = 2000, kLiveReadTimeoutMs = 500;

}  // namespace

bool CameraSelected(const std::vector<int>& ids, int id) {
  return ids.empty() || std::find(ids.begin(), ids.end(), id) != ids.end();
}

cv::VideoCapture OpenCameraCapture(const std::string& spec) {
  if (spec.rfind("v4l2:", 0) == 0) {
    int index = -1;
    try {
      index = std::stoi(spec.substr(5));
    } catch (const std::exception&) {
    }
    if (index < 0) throw std::runtime_error("'" + spec + "': expected v4l2:<device index>");
    return cv::VideoCapture(index, cv::CAP_V4L2);
  }
  if (RigCamera::IsLiveSpec(spec)) {
    // FFmpeg probes a network stream for 5 s by default before the first frame
    // (and again after each reopen): a camera joins within half a second instead.
    // A user's own OPENCV_FFMPEG_CAPTURE_OPTIONS is kept.
    setenv("OPENCV_FFMPEG_CAPTURE_OPTIONS", "analyzeduration;500000|probesize;500000|fflags;nobuffer", 0);
    return cv::VideoCapture(spec, cv::CAP_FFMPEG,
                            {cv::CAP_PROP_OPEN_TIMEOUT_MSEC, kLiveOpenTimeoutMs, cv::CAP_PROP_READ_TIMEOUT_MSEC,
                             kLiveReadTimeoutMs});
  }
  // A FIFO, a device or a directory given as a video file would block
  // open() or be probed by every backend: only regular files are opened.
  std::error_code ec;
  const auto st = std::filesystem::status(spec, ec);
  if (!ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st))
    throw std::runtime_error("'" + spec +
                             "': not a regular file (a FIFO or a device is not read as a video; a live camera is "
                             "v4l2:<index> or a stream URL)");
  // A pattern naming no file opens nothing: handed to OpenCV, it is probed by
  // every backend in turn (GStreamer's and the USB cameras' leak as they fail).
  if (NumberedFile(spec, 0) != spec && CheckImageSequence(spec, FirstFileNumber(spec)) == 0) return {};
  return cv::VideoCapture(spec, cv::CAP_ANY);
}

void CheckImageSequence(const std::string& pattern) { CheckImageSequence(pattern, FirstFileNumber(pattern)); }

int CheckImageSequence(const std::string& pattern, int first_number) {
  const ImageLimits limits;
  const bool single = NumberedFile(pattern, 0) == pattern;
  std::optional<ImageHeader> first;
  int count = 0;
  for (int n = first_number; !single || n == first_number; ++n, ++count) {
    const std::string file = NumberedFile(pattern, n);
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) break;  // the sequence ends at its first gap, as OpenCV's
    const auto h = ProbeImageFile(file);
    if (!h)
      throw std::runtime_error("'" + file +
                               "': not a regular file holding a PNG, JPEG, BMP, PNM or TIFF image (its header)");
    if (h->width > limits.max_side || h->height > limits.max_side)
      throw std::runtime_error("'" + file + "': its header says " + std::to_string(h->width) + "x" +
                               std::to_string(h->height) + " px, over " + std::to_string(limits.max_side) +
                               " a side");
    const auto bytes = std::filesystem::file_size(file, ec);
    if (!ec && int64_t(bytes) > limits.max_bytes)
      throw std::runtime_error("'" + file + "': " + std::to_string(bytes) + " bytes, over " +
                               std::to_string(limits.max_bytes >> 20) + " MiB");
    if (!first) {
      first = h;
    } else if (h->width != first->width || h->height != first->height) {
      throw std::runtime_error("'" + file + "': " + std::to_string(h->width) + "x" + std::to_string(h->height) +
                               " px, the sequence's first frame is " + std::to_string(first->width) + "x" +
                               std::to_string(first->height));
    }
  }
  return count;
}

std::optional<ImageSequence> FindImageSequence(const std::string& spec) {
  if (RigCamera::IsLiveSpec(spec) || spec.rfind("v4l2:", 0) == 0) return std::nullopt;
  ImageSequence seq;
  if (NumberedFile(spec, 0) != spec) {
    seq.pattern = spec;
    seq.first = FirstFileNumber(spec);
  } else {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(spec, ec) || !ProbeImageFile(spec)) return std::nullopt;
    // The basename's last run of digits is the frame number ("img_0007.png").
    const size_t base = spec.find_last_of('/') + 1;  // npos + 1 == 0
    size_t end = spec.size();
    while (end > base && !std::isdigit(static_cast<unsigned char>(spec[end - 1]))) --end;
    size_t begin = end;
    while (begin > base && std::isdigit(static_cast<unsigned char>(spec[begin - 1]))) --begin;
    if (begin < end && end - begin <= 9) {
      std::string pattern = spec.substr(0, begin) + "%0" + std::to_string(end - begin) + "d" + spec.substr(end);
      // A literal '%' elsewhere in the name would be read as the conversion.
      if (pattern.find('%') == begin) {
        seq.pattern = std::move(pattern);
        seq.first = std::stoi(spec.substr(begin, end - begin));
      }
    }
    if (seq.pattern.empty()) seq.pattern = spec;  // a still: one file
  }
  seq.count = CheckImageSequence(seq.pattern, seq.first);
  if (seq.count == 0) return std::nullopt;  // a pattern naming no file: "cannot open" below
  return seq;
}

std::string NumberedFile(const std::string& pattern, int n) {
  const size_t p = pattern.find('%');
  if (p == std::string::npos) return pattern;
  size_t q = p + 1;
  int width = 0;
  if (q < pattern.size() && pattern[q] == '0') ++q;
  if (q < pattern.size() && pattern[q] >= '1' && pattern[q] <= '9') width = pattern[q++] - '0';
  if (q >= pattern.size() || pattern[q] != 'd') return pattern;  // not a number conversion: a literal name
  std::string num = std::to_string(n);
  if (int(num.size()) < width) num.insert(0, size_t(width) - num.size(), '0');
  return pattern.substr(0, p) + num + pattern.substr(q + 1);
}

int FirstFileNumber(const std::string& pattern) {
  for (int n = 0; n <= 4; ++n)
    if (std::filesystem::exists(NumberedFile(pattern, n))) return n;
  return 0;
}

FileCameraReader::FileCameraReader(int camera_id, std::string spec) : camera_id_(camera_id), spec_(std::move(spec)) {
  Reopen();
}

FileCameraReader::FileCameraReader(int camera_id, std::string spec, ImageSequence sequence)
    : camera_id_(camera_id), spec_(std::move(spec)), sequence_(std::move(sequence)) {
  declared_frames_ = sequence_->count;
}

void FileCameraReader::Reopen() {
  next_ = 0;
  error_.clear();
  sequence_ = FindImageSequence(spec_);
  if (sequence_) {
    declared_frames_ = sequence_->count;
    fps_ = 0;
    return;
  }
  capture_ = OpenCameraCapture(spec_);
  if (!capture_.isOpened())
    throw std::runtime_error("camera " + std::to_string(camera_id_) + ": cannot open " + spec_);
  const double declared = capture_.get(cv::CAP_PROP_FRAME_COUNT);
  declared_frames_ = std::isfinite(declared) && declared > 0 && declared < 1e9 ? int64_t(declared) : 0;
  const double f = capture_.get(cv::CAP_PROP_FPS);
  fps_ = f > 1 && f < 1000 ? f : 0;
}

bool FileCameraReader::Read(cv::Mat* image) {
  if (sequence_) {
    if (next_ >= sequence_->count) return false;
    *image = ReadImageFile(NumberedFile(sequence_->pattern, sequence_->first + next_++), cv::IMREAD_COLOR, &error_);
    return !image->empty();
  }
  try {
    return capture_.read(*image) && !image->empty();
  } catch (const cv::Exception&) {
    return false;
  }
}

bool FileCameraReader::Grab() {
  if (sequence_) return next_ < sequence_->count && ++next_ > 0;
  try {
    return capture_.grab();
  } catch (const cv::Exception&) {
    return false;
  }
}

struct LiveCameraReader::State {
  int id = 0;
  std::string spec;
  std::shared_ptr<LiveHub> hub;
  std::deque<std::pair<int64_t, cv::Mat>> queue;
  std::atomic<bool> stop{false}, done{false};
};

LiveCameraReader::LiveCameraReader(int camera_id, std::string spec, std::shared_ptr<LiveHub> hub)
    : s_(std::make_shared<State>()) {
  s_->id = camera_id;
  s_->spec = std::move(spec);
  s_->hub = std::move(hub);
  thread_ = std::thread([s = s_] { Run(*s); });
}

LiveCameraReader::~LiveCameraReader() {
  RequestStop();
  if (s_->done)
    thread_.join();
  else
    thread_.detach();
}

void LiveCameraReader::RequestStop() { s_->stop = true; }
bool LiveCameraReader::Done() const { return s_->done; }

bool LiveCameraReader::Pop(cv::Mat* image, int64_t* arrival_ns) {
  if (s_->queue.empty()) return false;
  *image = std::move(s_->queue.front().second);
  *arrival_ns = s_->queue.front().first;
  s_->queue.pop_front();
  return true;
}

bool LiveCameraReader::HasFrame() const { return !s_->queue.empty(); }

void LiveCameraReader::StopAll(const std::vector<LiveCameraReader*>& readers) {
  for (LiveCameraReader* r : readers) r->RequestStop();
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  for (LiveCameraReader* r : readers)
    while (!r->Done() && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

void LiveCameraReader::Run(State& s) {
  cv::VideoCapture cap;
  bool told = false;
  int failures = 0;
  while (!s.stop) {
    if (!cap.isOpened()) {
      try {
        cap = OpenCameraCapture(s.spec);
      } catch (const std::exception& e) {
        spdlog::error("camera {}: {}", s.id, e.what());
        break;
      }
      if (s.stop) break;
      if (!cap.isOpened()) {
        if (!told) spdlog::warn("camera {}: cannot open {} yet; retrying", s.id, s.spec);
        told = true;
        for (int i = 0; i < 10 && !s.stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
        continue;
      }
      if (told) spdlog::info("camera {}: {} opened", s.id, s.spec);
      told = false;
    }
    cv::Mat img;
    bool ok = false;
    try {
      ok = cap.read(img) && !img.empty();
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok) {
      // A read time-out: the stream is silent. FFmpeg's context does not recover
      // from an interrupted read, so a camera silent for two time-outs is
      // reopened (it is found again when it resumes).
      if (++failures >= 2) {
        cap.release();
        failures = 0;
      }
      continue;
    }
    failures = 0;
    const int64_t arrival = NowNs();
    std::lock_guard<std::mutex> lock(s.hub->mu);
    if (s.queue.size() >= kQueue) s.queue.pop_front();
    s.queue.emplace_back(arrival, std::move(img));
    s.hub->cv.notify_all();
  }
  s.done = true;
}

std::vector<cv::Mat> ReadCalibratedFrames(int camera_id, const std::string& what, const std::string& spec, int count,
                                          int width, int height) {
  std::vector<cv::Mat> frames;
  cv::Mat f;
  if (auto sequence = FindImageSequence(spec)) {
    FileCameraReader reader(camera_id, spec, std::move(*sequence));
    while (int(frames.size()) < count && reader.Read(&f))
      if (f.cols == width && f.rows == height && f.type() == CV_8UC3) frames.push_back(f.clone());
    return frames;
  }
  cv::VideoCapture cap = OpenCameraCapture(spec);
  if (!cap.isOpened()) throw std::runtime_error("camera " + std::to_string(camera_id) + ": cannot open " + what);
  while (int(frames.size()) < count && cap.read(f) && !f.empty()) {
    if (f.cols == width && f.rows == height && f.type() == CV_8UC3) frames.push_back(f.clone());
  }
  return frames;
}

}  // namespace hullpipe
