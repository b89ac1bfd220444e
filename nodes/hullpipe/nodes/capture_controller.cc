#include "hullpipe/nodes/capture_controller.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

void CaptureOptions::Check() const {
  if (frames < 0) throw std::invalid_argument("--frames must be >= 0");
  if (!(fps == 0 || (std::isfinite(fps) && fps > 0 && fps <= 1000)))
    throw std::invalid_argument("--fps must be in (0, 1000] (0: the source's rate)");
  if (!(image_scale >= 0.05 && image_scale <= 1.0)) throw std::invalid_argument("--image-scale must be in [0.05, 1]");
}

CaptureController::CaptureController(CaptureOptions options, const Clock& clock, RigSource& source,
                                     CaptureSink& sink)
    : o_((options.Check(), options)), clock_(clock), source_(source), sink_(sink), counters_(clock) {
  rate_ = o_.fps > 0 ? o_.fps : source_.fps();
  if (!(std::isfinite(rate_) && rate_ > 0 && rate_ <= 1000))
    throw std::invalid_argument("the source's frame rate is " + std::to_string(rate_) + ": give --fps");
  start_s_ = clock_.Now();
}

void CaptureController::PublishCalibration() {
  for (const auto& c : source_.cameras()) sink_.PublishCameraInfo(c, source_.workspace());
}

void CaptureController::Start() { start_s_ = clock_.Now(); }

bool CaptureController::Step() {
  while (o_.frames <= 0 || published_ < o_.frames) {
    // The frame's capture time is when it is due (paced) and read: latency
    // downstream includes reading and segmenting it.
    if (!o_.fast) clock_.SleepUntil(start_s_ + double(published_) / rate_);
    const int64_t t_ns = clock_.WallNs();
    bool ok;
    {
      StageTimer t(counters_, "read+segment");
      ok = source_.Next(&frame_);
    }
    for (const auto& e : frame_.errors) {
      spdlog::warn("{}", e);
      if (ok) counters_.Rejected();  // a skipped frame; the end of input is no rejection
    }
    if (!ok) {
      if (o_.loop && source_.Rewind()) continue;
      spdlog::info("end of input after {} frames", published_);
      return false;
    }
    ++seq_;
    counters_.FrameIn();
    {
      StageTimer t(counters_, "publish");
      const uint32_t camera_count = uint32_t(source_.rig_camera_count());
      for (size_t i = 0; i < source_.cameras().size(); ++i) {
        if (frame_.maps[i].empty()) continue;
        cv::Mat img = frame_.images[i];
        if (o_.image_scale < 1.0) cv::resize(img, img, cv::Size(), o_.image_scale, o_.image_scale, cv::INTER_AREA);
        sink_.PublishFrame(uint32_t(source_.cameras()[i].id), seq_, t_ns, frame_.time_s, camera_count,
                           frame_.maps[i], img);
      }
    }
    ++published_;
    counters_.FrameOut(t_ns);
    return true;
  }
  return false;
}

}  // namespace hullpipe::nodes
