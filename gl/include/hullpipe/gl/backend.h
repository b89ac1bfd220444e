// Choice of backend for recon_node and the benchmarks: the CPU reference
// (reconstruction/sweep_backend.h) or the GPU through OpenGL (gl_ray_sweep.h,
// gl_plane_sweep.h, gl_texture.h). docs/gpu.md says what `auto` picks and why.
#pragma once

#include <memory>
#include <string>

#include "hullpipe/collision/triangle_query.h"
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

/// The triangle query of sim_node's CAD models (paper §4.1): a GlTriangleQuery
/// on a context of its own (one compute pass over a batch, one read-back), made
/// current on each call (call it from one thread). `name` as
/// BackendOptions::name: "cpu" gives an empty function (the CPU query); "gl"
/// the GL query, or throws std::runtime_error with one line naming what failed;
/// "auto" on a hardware renderer times both queries at the start (two batch
/// sizes of a synthetic frameset, QueryTrianglesCpu with cpu_threads) and
/// answers each batch with the one faster for its size, or is empty where the
/// GL query is never faster, on a software renderer (llvmpipe) or where no
/// context can be made. *description (optional) says which and why (with the
/// measured costs), for the log and NodeStats. Throws std::invalid_argument for
/// an unknown name or cpu_threads < 1.
TriangleQueryFunction MakeTriangleQuery(const std::string& name, const EglOptions& egl = {},
                                        std::string* description = nullptr, int cpu_threads = 1);

/// What "auto" does on a hardware renderer, on any context: times the GL query
/// on `ctx` and QueryTrianglesCpu with cpu_threads on one synthetic frameset (a
/// sphere seen by four 320x240 cameras, an icosphere of 80 and of 5,120
/// triangles cutting it; medians of three), fits each as fixed + per-triangle
/// milliseconds, and returns a function that answers each batch with the one
/// faster for its size, or an empty function (the CPU query) where the GL one
/// is faster for no batch of 1 to 10^6 triangles. *description says which, with
/// both fits. Throws GlError if the GL query cannot be built,
/// std::invalid_argument for cpu_threads < 1.
TriangleQueryFunction MeasuredTriangleQuery(EglContext ctx, int cpu_threads = 1, std::string* description = nullptr);

}  // namespace hullpipe::gl
