#include "hullpipe/gl/egl_context.h"

#include <utility>

#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>

namespace hullpipe::gl {

std::optional<EglContext> EglContext::TryCreate(std::string* why) {
  auto fail = [&](const std::string& w) -> std::optional<EglContext> {
    if (why) *why = w;
    return std::nullopt;
  };
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) return fail("no eglGetPlatformDisplayEXT (no EGL display)");
  EGLDisplay dpy = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (dpy == EGL_NO_DISPLAY) return fail("no EGL display for EGL_PLATFORM_SURFACELESS_MESA");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(dpy, &major, &minor)) return fail("eglInitialize failed (no EGL display)");
  if (!eglBindAPI(EGL_OPENGL_API)) {
    eglTerminate(dpy);
    return fail("eglBindAPI(EGL_OPENGL_API) failed");
  }
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                   EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(dpy, config_attribs, &config, 1, &count) || count < 1) {
    eglTerminate(dpy);
    return fail("no EGL config with OpenGL");
  }
  const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, ctx_attribs);
  if (ctx == EGL_NO_CONTEXT) {
    eglTerminate(dpy);
    return fail("eglCreateContext for OpenGL 4.5 core failed");
  }
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    eglDestroyContext(dpy, ctx);
    eglTerminate(dpy);
    return fail("eglMakeCurrent without surface failed (no EGL_KHR_surfaceless_context)");
  }
  EglContext c;
  c.display_ = dpy;
  c.context_ = ctx;
  const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  c.renderer_ = r ? r : "unknown";
  return c;
}

EglContext::~EglContext() {
  if (context_ != EGL_NO_CONTEXT) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
  }
  // The display is shared process-wide by EGL; it is not terminated here so
  // other contexts on it stay valid.
}

EglContext::EglContext(EglContext&& o) noexcept
    : display_(std::exchange(o.display_, EGL_NO_DISPLAY)),
      context_(std::exchange(o.context_, EGL_NO_CONTEXT)),
      renderer_(std::move(o.renderer_)) {}

EglContext& EglContext::operator=(EglContext&& o) noexcept {
  if (this != &o) {
    this->~EglContext();
    display_ = std::exchange(o.display_, EGL_NO_DISPLAY);
    context_ = std::exchange(o.context_, EGL_NO_CONTEXT);
    renderer_ = std::move(o.renderer_);
  }
  return *this;
}

void EglContext::MakeCurrent() const { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_); }

bool EglContext::IsSoftware() const {
  for (const char* s : {"llvmpipe", "softpipe", "swrast", "Software"})
    if (renderer_.find(s) != std::string::npos) return true;
  return false;
}

}  // namespace hullpipe::gl
