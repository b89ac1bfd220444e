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
  /// source time seq / 25 s.
  void AddFrame(FramesetAssembler& a, uint64_t seq, int64_t capture_ns, bool images = false) const {
    for (const auto& v : views) {
      a.AddMap(v.camera.id, seq, capture_ns, int(views.size()), v.map.clone(), nullptr, double(seq) / 25.0);
      if (images) a.AddImage(v.camera.id, seq, capture_ns, cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 120, 150)));
    }
  }
};

}  // namespace hullpipe::nodes::test
