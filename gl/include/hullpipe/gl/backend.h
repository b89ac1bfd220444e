// Choice of backend for recon_node and the benchmarks: the CPU reference
// (reconstruction/sweep_backend.h) or the GPU through OpenGL (gl_ray_sweep.h,
// gl_plane_sweep.h, gl_texture.h). docs/gpu.md says what `auto` picks and why.
#pragma once

#include <memory>
#include <string>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/reconstruction/sweep_backend.h"

namespace hullpipe::gl {

/// Makes the backend `options` ask for. "gl" without a usable GL context throws
/// std::runtime_error with one line naming what failed; "auto" then falls back to
/// the CPU and says why in reason(). Throws std::invalid_argument if options fail
/// Check().
std::unique_ptr<SweepBackend> MakeSweepBackend(const BackendOptions& options);

/// Shorthand: MakeSweepBackend({name, threads, refine}).
std::unique_ptr<SweepBackend> MakeSweepBackend(const std::string& name, int threads = 1, int refine = 0);

/// The GL implementation behind a backend made by MakeSweepBackend, or nullptr
/// for the CPU backend.
const GlInfo* GlInfoOf(const SweepBackend& backend);

}  // namespace hullpipe::gl
