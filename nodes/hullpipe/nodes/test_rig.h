// Test helpers of the controller tests: a small synthetic rig with exact maps
// feeding a FramesetAssembler, and sinks that record what controllers emit.
#pragma once

#include <cstdint>
#include <vector>

#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe::nodes::test {

/// Two 64x48 ring cameras around the test sphere, with exact maps.
struct TinyRig {
  std::vector<CameraMap> views = hullpipe::test::SphereViews(2, 64, 48, hullpipe::test::kSphereCentre, 0.3);
  /// Registers the cameras with `a`.
  void Calibrate(FramesetAssembler& a) const {
    for (const auto& v : views) a.SetCamera(v.camera);
    a.SetWorkspace(hullpipe::test::BigBox());
  }
  /// Every camera's map (and a grey image if `images`) of frame `seq`, with
  /// source time seq / 25 s, all captured at capture_ns + seq nanoseconds (framesets
  /// are assembled by capture time: each frame its own instant, however the test's
  /// clock stands).
  /// arrival_ns: when the samples arrived, on the node's clock (0: unknown).
  void AddFrame(FramesetAssembler& a, uint64_t seq, int64_t capture_ns, bool images = false,
                int64_t arrival_ns = 0) const {
    const int64_t t = capture_ns + int64_t(seq);
    for (const auto& v : views) {
      a.AddMap(MapSample{.camera_id = v.camera.id, .seq = seq, .capture_time_ns = t, .camera_count = int(views.size()),
          .map = v.map.clone(), .source_time_s = double(seq) / 25.0, .source_id = 0, .arrival_ns = arrival_ns});
      if (images)
        a.AddImage({.camera_id = v.camera.id, .seq = seq, .capture_time_ns = t,
                    .image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 120, 150)), .arrival_ns = arrival_ns});
    }
  }
};

}  // namespace hullpipe::nodes::test
