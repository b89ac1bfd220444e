// Choice of plane-sweep backend for recon_node and the benchmarks: the CPU
// reference (plane_sweep.h) or the GL sweep (gl_plane_sweep.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hullpipe/reconstruction/plane_sweep.h"

namespace hullpipe::gl {

/// A plane sweep implementation.
class SweepBackend {
 public:
  virtual ~SweepBackend() = default;
  /// Same contract as PlaneSweepCpu.
  virtual cv::Mat Sweep(const VolumeQuery& query, const NovelView& view, const std::vector<double>& depths,
                        const cv::Rect& tile) = 0;
  virtual std::string Name() const = 0;
};

/// name: "cpu", "gl" or "auto". auto takes GL on a hardware renderer and the CPU
/// on a software one (Mesa's llvmpipe), where the CPU path is faster; and the CPU
/// where no EGL display exists. "gl" without a usable EGL context throws
/// std::runtime_error saying why. threads: CPU sweep threads. refine: depth
/// refinement bisections after the sweep (PlaneSweepCpu, RefineSweepDepth; 0 = the
/// paper's plane-quantised depth); throws std::invalid_argument if negative.
std::unique_ptr<SweepBackend> MakeSweepBackend(const std::string& name, int threads = 1, int refine = 0);

}  // namespace hullpipe::gl
