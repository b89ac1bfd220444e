// A headless OpenGL 4.5 core context through EGL, no window or display server:
// Mesa's surfaceless platform (EGL_PLATFORM_SURFACELESS_MESA), which on machines
// without a GPU renders with llvmpipe. Move-only RAII: the context is destroyed
// with the object.
#pragma once

#include <optional>
#include <string>

#include <EGL/egl.h>

namespace hullpipe::gl {

class EglContext {
 public:
  /// Creates and makes current a GL 4.5 core context. Returns nullopt (and *why
  /// says why, e.g. "no EGL display") where no EGL display or GL 4.5 is available.
  static std::optional<EglContext> TryCreate(std::string* why = nullptr);
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  EglContext(EglContext&& o) noexcept;
  EglContext& operator=(EglContext&& o) noexcept;

  /// Makes this context current on the calling thread.
  void MakeCurrent() const;
  /// GL_RENDERER string, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
  const std::string& renderer() const { return renderer_; }
  /// True for Mesa's software rasterizers (llvmpipe, softpipe, swrast).
  bool IsSoftware() const;

 private:
  EglContext() = default;
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string renderer_;
};

}  // namespace hullpipe::gl
