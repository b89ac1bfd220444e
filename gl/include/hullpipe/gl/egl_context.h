// A headless OpenGL 4.5 core context through EGL, no window or display server.
// Where the driver offers EGL devices (EGL_EXT_device_enumeration with
// EGL_EXT_platform_device: NVIDIA's driver, Mesa), each device is a candidate and
// a hardware device is preferred; otherwise Mesa's surfaceless platform
// (EGL_PLATFORM_SURFACELESS_MESA), which on machines without a GPU renders with
// llvmpipe. docs/gpu.md says how a lab picks its GPU. Move-only RAII: the context
// is destroyed with the object.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <EGL/egl.h>

namespace hullpipe::gl {

/// One EGL device as EGL_EXT_device_enumeration lists it.
struct EglDeviceInfo {
  int index = 0;          ///< Position in eglQueryDevicesEXT's list (what --gl-device takes).
  std::string name;       ///< DRM render node or device file, or "software" / "unnamed".
  bool software = false;  ///< EGL_MESA_device_software: Mesa's llvmpipe device.
};

/// Lists the EGL devices. Empty (with *why saying why) where EGL has no device
/// enumeration. Never throws.
std::vector<EglDeviceInfo> ListEglDevices(std::string* why = nullptr);

/// Which GL implementation a context got, for logs, NodeStats and stats.json.
struct GlInfo {
  std::string vendor;    ///< GL_VENDOR, e.g. "NVIDIA Corporation", "Mesa".
  std::string renderer;  ///< GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  std::string version;   ///< GL_VERSION.
  std::string source;    ///< How it was reached: "EGL device 0 (/dev/dri/renderD128)", "surfaceless Mesa".
  /// One line: "renderer | vendor | version | source".
  std::string Summary() const;
};

/// How to pick the EGL device.
struct EglOptions {
  /// -1: the first hardware device, else Mesa's surfaceless platform, else the
  /// first device that gives a context. >= 0: that device only (--gl-device N).
  int device = -1;
};

class EglContext {
 public:
  /// Creates and makes current a GL 4.5 core context as `options` say. Returns
  /// nullopt, with *why naming what failed (e.g. "no EGL display for
  /// EGL_PLATFORM_SURFACELESS_MESA", "--gl-device 3: only 2 EGL devices"), where
  /// none can be made. Never throws.
  static std::optional<EglContext> TryCreate(const EglOptions& options, std::string* why = nullptr);
  static std::optional<EglContext> TryCreate(std::string* why = nullptr) { return TryCreate({}, why); }
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  EglContext(EglContext&& o) noexcept;
  EglContext& operator=(EglContext&& o) noexcept;

  /// Makes this context current on the calling thread.
  void MakeCurrent() const;
  /// The EGL display and context, for an API that shares the context (an
  /// OpenXR runtime's graphics binding, openxr/xr_display.h). Owned here.
  EGLDisplay display() const { return display_; }
  EGLContext context() const { return context_; }
  /// GL_RENDERER string, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  const std::string& renderer() const { return info_.renderer; }
  const GlInfo& info() const { return info_; }
  /// True for software rasterizers (llvmpipe, softpipe, swrast, a device with
  /// EGL_MESA_device_software).
  bool IsSoftware() const;

 private:
  EglContext() = default;
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  GlInfo info_;
  bool software_device_ = false;
};

}  // namespace hullpipe::gl
