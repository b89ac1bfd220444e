#include "hullpipe/dds/frameset_input.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/parallel.h"

#include "hullpipe/dds/convert.h"

namespace hullpipe::dds {

namespace {
/// The fewest decoded maps (and images) the input thread may hold for Poll.
constexpr size_t kMinQueued = 64;
}  // namespace

int64_t FramesetInput::ArrivalNs() const { return counters_ ? counters_->clock().WallNs() : NowNs(); }

void AddFramesetOptions(CLI::App& app, FramesetOptions& options) {
  app.add_option("--skew-tolerance", options.skew_tolerance_ms,
                 "Largest |capture time - reference time| of a frameset's maps, ms (0: half the slowest camera's "
                 "frame period)")
      ->check(FiniteRange(0.0, 1000.0))
      ->capture_default_str();
  app.add_flag("--input-thread,!--no-input-thread", options.input_thread,
               "Take and decode maps and images on a thread of their own while the node works on the last "
               "frameset")
      ->capture_default_str();
}

FramesetInput::FramesetInput(const Participant& p, const WaitSet& ws, size_t max_pending, bool with_images,
                             const FramesetOptions& options)
    : info_(p),
      maps_(p),
      assembler_(max_pending, with_images),
      sizes_(1, false),
      max_pending_(std::max<size_t>(1, max_pending)),
      participant_(p),
      caller_waitset_(ws) {
  assembler_.SetTolerance(options.skew_tolerance_ms * 1e-3);
  ws.Attach(info_);
  ws.Attach(maps_);
  if (with_images) {
    images_ = std::make_unique<Reader<hullpipe_msg_CameraImage>>(p);
    ws.Attach(*images_);
  }
}

FramesetInput::~FramesetInput() {
  if (!thread_.joinable()) return;
  stop_ = true;
  drained_.notify_all();
  try {
    wake_thread_->Trigger();
  } catch (const DdsError&) {  // the thread still sees stop_ within its wait's 50 ms
  }
  thread_.join();
}

void FramesetInput::StartInputThread() {
  if (thread_.joinable()) return;
  wake_caller_ = std::make_unique<GuardCondition>(participant_);
  wake_thread_ = std::make_unique<GuardCondition>(participant_);
  thread_waitset_ = std::make_unique<WaitSet>(participant_);
  caller_waitset_.DetachCondition(info_.condition());
  caller_waitset_.DetachCondition(maps_.condition());
  thread_waitset_->Attach(info_);
  thread_waitset_->Attach(maps_);
  if (images_) {
    caller_waitset_.DetachCondition(images_->condition());
    thread_waitset_->Attach(*images_);
  }
  thread_waitset_->AttachCondition(wake_thread_->handle());
  caller_waitset_.AttachCondition(wake_caller_->handle());
  thread_ = std::thread([this] { Run(); });
}

size_t FramesetInput::queued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.samples();
}

bool FramesetInput::QueueFull() const {
  // As many as the assembler keeps: max_pending framesets of the cameras seen.
  const size_t cameras = std::max<size_t>(1, sizes_.camera_count());
  const size_t bound = std::max(kMinQueued, max_pending_ * cameras);
  return queue_.maps.size() >= bound || queue_.images.size() >= bound;
}

void FramesetInput::Run() {
  while (!stop_) {
    {
      // Full: wait for Poll (the samples wait in the readers' history meanwhile).
      std::unique_lock<std::mutex> lock(mutex_);
      if (QueueFull()) ++paused_;
      drained_.wait_for(lock, std::chrono::milliseconds(50), [&] { return stop_ || !QueueFull(); });
      if (stop_) return;
      if (QueueFull()) continue;
    }
    try {
      thread_waitset_->Wait(0.05);
      wake_thread_->Take();
      if (stop_) return;
      Received r;
      Take(&r);
      const uint64_t refused = info_.refused() + maps_.refused() + (images_ ? images_->refused() : 0);
      bool any = false;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        any = r.samples() > 0 || r.malformed > 0 || refused != queue_refused_;
        for (auto& c : r.cameras) queue_.cameras.push_back(std::move(c));
        for (auto& m : r.maps) queue_.maps.push_back(std::move(m));
        for (auto& i : r.images) queue_.images.push_back(std::move(i));
        queue_.decode_ms.insert(queue_.decode_ms.end(), r.decode_ms.begin(), r.decode_ms.end());
        queue_.malformed += r.malformed;
        queue_refused_ = refused;
      }
      if (any) wake_caller_->Trigger();
    } catch (const std::exception& e) {
      // A DDS call that fails here fails for good (the participant is gone):
      // the next Poll throws it, and the node exits non-zero.
      {
        std::lock_guard<std::mutex> lock(mutex_);
        failure_ = e.what();
      }
      try {
        wake_caller_->Trigger();
      } catch (const DdsError&) {  // the caller's loop polls within its wait's timeout
      }
      return;
    }
  }
}

void FramesetInput::Poll() {
  if (!thread_.joinable()) {
    Received r;
    Take(&r);
    refused_ = info_.refused() + maps_.refused() + (images_ ? images_->refused() : 0);
    Apply(std::move(r));
    return;
  }
  Received r;
  wake_caller_->Take();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!failure_.empty()) throw std::runtime_error("input thread: " + failure_);
    std::swap(r, queue_);
    refused_ = queue_refused_;
  }
  drained_.notify_all();
  Apply(std::move(r));
}

void FramesetInput::Take(Received* r) {
  info_.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) {
    try {
      Aabb box;
      const Camera camera = CameraFromMsg(m, &box);
      sizes_.SetCamera(camera);  // refused as the assembler will refuse it
      r->cameras.emplace_back(camera, box);
    } catch (const MessageError& e) {
      ++r->malformed;
      reject_log_.Log(e.what(), MonotonicSeconds());
    }
  });
  maps_.TakeEach([&](const hullpipe_msg_ObjectPixelMap& m, const dds_sample_info_t& info) {
    try {
      std::string why;
      // The size against the calibration first: decoding allocates it.
      if (!sizes_.CheckMapSize(int(m.camera_id), int(std::min(m.width, 1u << 30)),
                               int(std::min(m.height, 1u << 30)), &why)) {
        ++r->malformed;
        reject_log_.Log(why, MonotonicSeconds());
        return;
      }
      // The writer's handle tells a restarted capture node from a live one; the
      // arrival time, on this node's clock, checks the capture host's clock. The
      // runs are decoded once, with the object pixels' rectangle they give.
      MapSample sample;
      sample.arrival_ns = ArrivalNs();
      DecodedMap decoded = DecodedMapFromMsg(m);
      sample.camera_id = int(m.camera_id);
      sample.seq = m.frame_seq;
      sample.capture_time_ns = m.capture_time_ns;
      sample.camera_count = int(m.camera_count);
      sample.map = std::move(decoded.map);
      sample.object_rect = decoded.bounds;
      sample.source_time_s = m.source_time;
      sample.source_id = info.publication_handle;
      sample.cam_from_world = MapPoseFromMsg(m);
      r->maps.emplace_back(std::move(sample), info.source_timestamp);
    } catch (const MessageError& e) {
      ++r->malformed;
      reject_log_.Log(e.what(), MonotonicSeconds());
    }
  });
  if (!images_) return;
  // Raw images are copied as they are taken; JPEGs are copied out of DDS's
  // buffers here and decoded below on several threads at once: twenty JPEG
  // decodes in a row held this loop (and the samples behind them) for tens
  // of ms.
  struct Deferred {
    ImageSample sample;
    int64_t source_timestamp = 0;
    hullpipe_msg_CameraImage msg;
    std::vector<uint8_t> bytes;
    std::string error;
  };
  std::vector<Deferred> jpegs;
  images_->TakeEach([&](const hullpipe_msg_CameraImage& m, const dds_sample_info_t& info) {
    try {
      // The whole image's size against the calibration first: decoding (or a
      // region's whole image) allocates it.
      std::string why;
      const cv::Size whole = WholeImageSize(m);
      if (!sizes_.CheckImageSize(int(m.camera_id), whole.width, whole.height, &why)) {
        ++r->malformed;
        reject_log_.Log(why, MonotonicSeconds());
        return;
      }
      // (Images and maps come from different writers: only maps name the sender.)
      ImageSample image;
      image.camera_id = int(m.camera_id);
      image.seq = m.frame_seq;
      image.capture_time_ns = m.capture_time_ns;
      image.arrival_ns = ArrivalNs();
      if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
        Deferred& d = jpegs.emplace_back();
        d.sample = std::move(image);
        d.source_timestamp = info.source_timestamp;
        d.msg = m;
        d.bytes.assign(m.data._buffer, m.data._buffer + m.data._length);
        d.msg.data._buffer = nullptr;  // pointed at below, once `jpegs` stops growing
        d.msg.data._release = false;
        return;
      }
      image.image = ImageFromMsg(m);
      r->images.emplace_back(std::move(image), info.source_timestamp);
    } catch (const MessageError& e) {
      ++r->malformed;
      reject_log_.Log(e.what(), MonotonicSeconds());
    }
  });
  if (jpegs.empty()) return;
  for (Deferred& d : jpegs) d.msg.data._buffer = d.bytes.data();
  const double t0 = MonotonicSeconds();
  ForEachRowDynamic(int(jpegs.size()), ThreadsOrCores(decode_threads_), [&](int i, int) {
    Deferred& d = jpegs[size_t(i)];
    try {
      d.sample.image = ImageFromMsg(d.msg);
    } catch (const MessageError& e) {
      d.error = e.what();
    }
  });
  r->decode_ms.push_back((MonotonicSeconds() - t0) * 1e3);
  for (Deferred& d : jpegs) {
    if (!d.error.empty()) {
      ++r->malformed;
      reject_log_.Log(d.error, MonotonicSeconds());
      continue;
    }
    r->images.emplace_back(std::move(d.sample), d.source_timestamp);
  }
}

void FramesetInput::Apply(Received&& r) {
  malformed_ += r.malformed;
  for (const auto& [camera, box] : r.cameras) {
    std::string why;
    bool ok = assembler_.SetCamera(camera, &why);
    if (ok && !box.empty()) ok = assembler_.SetWorkspace(box, &why);
    // Named once per camera; every refusal is counted by the assembler.
    if (!ok && calibration_warned_.size() < 64 && calibration_warned_.insert(camera.id).second)
      spdlog::warn("{}", why);
  }
  // Transport: the take's time less the writer's source timestamp.
  auto transport = [&](const char* stage, int64_t arrival_ns, int64_t source_ns) {
    if (counters_ && source_ns != 0) counters_->Stage(stage, double(arrival_ns - source_ns) * 1e-6);
  };
  for (auto& [sample, source_ns] : r.maps) {
    transport("transport_map", sample.arrival_ns, source_ns);
    std::string why;
    const uint64_t rejected_before = assembler_.rejected();
    if (!assembler_.AddMap(std::move(sample), &why) && assembler_.rejected() > rejected_before)
      reject_log_.Log(why, MonotonicSeconds());
  }
  for (double ms : r.decode_ms)
    if (counters_) counters_->Stage("image_decode", ms);
  for (auto& [sample, source_ns] : r.images) {
    transport("transport_image", sample.arrival_ns, source_ns);
    assembler_.AddImage(std::move(sample));
  }
}

}  // namespace hullpipe::dds
