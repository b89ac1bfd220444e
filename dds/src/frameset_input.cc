#include "hullpipe/dds/frameset_input.h"

#include <algorithm>
#include <vector>

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/util/cli_range.h"
#include "hullpipe/util/parallel.h"

#include "hullpipe/dds/convert.h"

namespace hullpipe::dds {

int64_t FramesetInput::ArrivalNs() const { return counters_ ? counters_->clock().WallNs() : NowNs(); }

void AddFramesetOptions(CLI::App& app, FramesetOptions& options) {
  app.add_option("--skew-tolerance", options.skew_tolerance_ms,
                 "Largest |capture time - reference time| of a frameset's maps, ms (0: half the slowest camera's "
                 "frame period)")
      ->check(FiniteRange(0.0, 1000.0))
      ->capture_default_str();
}

FramesetInput::FramesetInput(const Participant& p, const WaitSet& ws, size_t max_pending, bool with_images,
                             const FramesetOptions& options)
    : info_(p), maps_(p), assembler_(max_pending, with_images) {
  assembler_.SetTolerance(options.skew_tolerance_ms * 1e-3);
  ws.Attach(info_);
  ws.Attach(maps_);
  if (with_images) {
    images_ = std::make_unique<Reader<hullpipe_msg_CameraImage>>(p);
    ws.Attach(*images_);
  }
}

void FramesetInput::Reject(const char* what) {
  ++malformed_;
  spdlog::warn("rejected: {}", what);
}

void FramesetInput::Poll() {
  info_.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) {
    try {
      Aabb box;
      std::string why;
      const Camera camera = CameraFromMsg(m, &box);
      bool ok = assembler_.SetCamera(camera, &why);
      if (ok && !box.empty()) ok = assembler_.SetWorkspace(box, &why);
      // Named once per camera; every refusal is counted by the assembler.
      if (!ok && calibration_warned_.size() < 64 && calibration_warned_.insert(camera.id).second)
        spdlog::warn("{}", why);
    } catch (const MessageError& e) {
      Reject(e.what());
    }
  });
  maps_.TakeEach([&](const hullpipe_msg_ObjectPixelMap& m, const dds_sample_info_t& info) {
    try {
      std::string why;
      // The size against the calibration first: decoding allocates it.
      if (!assembler_.CheckMapSize(int(m.camera_id), int(std::min(m.width, 1u << 30)),
                                   int(std::min(m.height, 1u << 30)), &why)) {
        spdlog::warn("rejected: {}", why);
        return;
      }
      const uint64_t rejected_before = assembler_.rejected();
      if (counters_) counters_->StageSince("transport_map", info.source_timestamp);
      // The writer's handle tells a restarted capture node from a live one; the
      // arrival time, on this node's clock, checks the capture host's clock. The
      // runs are decoded once, with the object pixels' rectangle they give.
      DecodedMap decoded = DecodedMapFromMsg(m);
      MapSample sample;
      sample.camera_id = int(m.camera_id);
      sample.seq = m.frame_seq;
      sample.capture_time_ns = m.capture_time_ns;
      sample.camera_count = int(m.camera_count);
      sample.map = std::move(decoded.map);
      sample.object_rect = decoded.bounds;
      sample.source_time_s = m.source_time;
      sample.source_id = info.publication_handle;
      sample.arrival_ns = ArrivalNs();
      sample.cam_from_world = MapPoseFromMsg(m);
      if (!assembler_.AddMap(std::move(sample), &why) && assembler_.rejected() > rejected_before)
        spdlog::warn("rejected: {}", why);
    } catch (const MessageError& e) {
      Reject(e.what());
    }
  });
  if (images_) {
    // Raw images are copied as they are taken; JPEGs are copied out of DDS's
    // buffers here and decoded below on several threads at once: twenty JPEG
    // decodes in a row held this loop (and the samples behind them) for tens
    // of ms.
    struct Deferred {
      ImageSample sample;
      hullpipe_msg_CameraImage msg;
      std::vector<uint8_t> bytes;
      std::string error;
    };
    std::vector<Deferred> jpegs;
    images_->TakeEach([&](const hullpipe_msg_CameraImage& m, const dds_sample_info_t& info) {
      try {
        if (counters_) counters_->StageSince("transport_image", info.source_timestamp);
        // (Images and maps come from different writers: only maps name the sender.)
        ImageSample image;
        image.camera_id = int(m.camera_id);
        image.seq = m.frame_seq;
        image.capture_time_ns = m.capture_time_ns;
        image.arrival_ns = ArrivalNs();
        if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
          Deferred& d = jpegs.emplace_back();
          d.sample = std::move(image);
          d.msg = m;
          d.bytes.assign(m.data._buffer, m.data._buffer + m.data._length);
          d.msg.data._buffer = nullptr;  // pointed at below, once `jpegs` stops growing
          d.msg.data._release = false;
          return;
        }
        image.image = ImageFromMsg(m);
        assembler_.AddImage(std::move(image));
      } catch (const MessageError& e) {
        Reject(e.what());
      }
    });
    if (!jpegs.empty()) {
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
      if (counters_) counters_->Stage("image_decode", (MonotonicSeconds() - t0) * 1e3);
      for (Deferred& d : jpegs) {
        if (!d.error.empty()) {
          Reject(d.error.c_str());
          continue;
        }
        assembler_.AddImage(std::move(d.sample));
      }
    }
  }
}

}  // namespace hullpipe::dds
