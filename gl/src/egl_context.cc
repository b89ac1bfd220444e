#include "hullpipe/gl/egl_context.h"

#include <cstring>
#include <utility>

#include <EGL/eglext.h>
#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>

namespace hullpipe::gl {
namespace {

template <class F>
F Proc(const char* name) {
  return reinterpret_cast<F>(eglGetProcAddress(name));
}

bool HasExtension(const char* list, const char* ext) {
  if (!list) return false;
  const size_t n = std::strlen(ext);
  for (const char* p = list; (p = std::strstr(p, ext)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

std::string GlString(GLenum e) {
  const auto* s = reinterpret_cast<const char*>(glGetString(e));
  return s ? s : "unknown";
}

// The raw devices (EGLDeviceEXT handles are owned by EGL for the process's life).
std::vector<EGLDeviceEXT> QueryDevices(std::string* why) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!HasExtension(client, "EGL_EXT_device_enumeration") && !HasExtension(client, "EGL_EXT_device_base")) {
    if (why) *why = "EGL has no EGL_EXT_device_enumeration";
    return {};
  }
  auto query = Proc<PFNEGLQUERYDEVICESEXTPROC>("eglQueryDevicesEXT");
  if (!query) {
    if (why) *why = "no eglQueryDevicesEXT";
    return {};
  }
  EGLint n = 0;
  if (!query(0, nullptr, &n) || n <= 0) {
    if (why) *why = "eglQueryDevicesEXT lists no device";
    return {};
  }
  std::vector<EGLDeviceEXT> devices(static_cast<size_t>(n));
  if (!query(n, devices.data(), &n)) {
    if (why) *why = "eglQueryDevicesEXT failed";
    return {};
  }
  devices.resize(size_t(n));
  return devices;
}

EglDeviceInfo Describe(EGLDeviceEXT dev, int index) {
  EglDeviceInfo d;
  d.index = index;
  auto str = Proc<PFNEGLQUERYDEVICESTRINGEXTPROC>("eglQueryDeviceStringEXT");
  const char* ext = str ? str(dev, EGL_EXTENSIONS) : nullptr;
  d.software = HasExtension(ext, "EGL_MESA_device_software");
  const char* file = nullptr;
  if (str && HasExtension(ext, "EGL_EXT_device_drm_render_node")) file = str(dev, EGL_DRM_RENDER_NODE_FILE_EXT);
  if (!file && str && HasExtension(ext, "EGL_EXT_device_drm")) file = str(dev, EGL_DRM_DEVICE_FILE_EXT);
  d.name = file ? file : d.software ? "software" : "unnamed";
  return d;
}

// Initialises `dpy` and makes a GL 4.5 core context current on it without a
// surface. Returns EGL_NO_CONTEXT and sets *why on failure.
EGLContext MakeContext(EGLDisplay dpy, std::string* why) {
  auto fail = [&](const std::string& w) {
    *why = w;
    return EGL_NO_CONTEXT;
  };
  EGLint major = 0, minor = 0;
  if (!eglInitialize(dpy, &major, &minor)) return fail("eglInitialize failed");
  if (!eglBindAPI(EGL_OPENGL_API)) return fail("eglBindAPI(EGL_OPENGL_API) failed");
  // A pbuffer-capable config where there is one (Mesa's surfaceless platform);
  // a device display may offer none, and then any OpenGL config or, with
  // EGL_KHR_no_config_context, none at all (the context renders to FBOs only).
  EGLConfig config = EGL_NO_CONFIG_KHR;
  EGLint count = 0;
  const EGLint pbuffer_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                    EGL_NONE};
  const EGLint any_attribs[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  if (!(eglChooseConfig(dpy, pbuffer_attribs, &config, 1, &count) && count >= 1) &&
      !(eglChooseConfig(dpy, any_attribs, &config, 1, &count) && count >= 1)) {
    if (!HasExtension(eglQueryString(dpy, EGL_EXTENSIONS), "EGL_KHR_no_config_context"))
      return fail("no EGL config with OpenGL");
    config = EGL_NO_CONFIG_KHR;
  }
  const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, ctx_attribs);
  if (ctx == EGL_NO_CONTEXT) return fail("eglCreateContext for OpenGL 4.5 core failed");
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    eglDestroyContext(dpy, ctx);
    return fail("eglMakeCurrent without surface failed (no EGL_KHR_surfaceless_context)");
  }
  return ctx;
}

}  // namespace

std::string GlInfo::Summary() const { return renderer + " | " + vendor + " | " + version + " | " + source; }

std::vector<EglDeviceInfo> ListEglDevices(std::string* why) {
  std::vector<EglDeviceInfo> out;
  const std::vector<EGLDeviceEXT> devices = QueryDevices(why);
  for (size_t i = 0; i < devices.size(); ++i) out.push_back(Describe(devices[i], int(i)));
  return out;
}

std::optional<EglContext> EglContext::TryCreate(const EglOptions& options, std::string* why) {
  std::string list_why;
  const std::vector<EGLDeviceEXT> devices = QueryDevices(&list_why);
  auto get_platform_display = Proc<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  std::string failures;
  auto note = [&](const std::string& w) { failures += (failures.empty() ? "" : "; ") + w; };

  std::vector<EglDeviceInfo> infos;
  for (size_t i = 0; i < devices.size(); ++i) infos.push_back(Describe(devices[i], int(i)));
  auto try_device = [&](size_t i) -> std::optional<EglContext> {
    const EglDeviceInfo& d = infos[i];
    const std::string label = "EGL device " + std::to_string(i) + " (" + d.name + ")";
    EGLDisplay dpy = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
    if (dpy == EGL_NO_DISPLAY) {
      note(label + ": no display");
      return std::nullopt;
    }
    std::string w;
    EGLContext ctx = MakeContext(dpy, &w);
    if (ctx == EGL_NO_CONTEXT) {
      note(label + ": " + w);
      return std::nullopt;
    }
    EglContext c;
    c.display_ = dpy;
    c.context_ = ctx;
    c.software_device_ = d.software;
    c.info_ = {GlString(GL_VENDOR), GlString(GL_RENDERER), GlString(GL_VERSION), label};
    return c;
  };
  auto try_surfaceless = [&]() -> std::optional<EglContext> {
    EGLDisplay dpy = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy == EGL_NO_DISPLAY) {
      note("no EGL display for EGL_PLATFORM_SURFACELESS_MESA");
      return std::nullopt;
    }
    std::string w;
    EGLContext ctx = MakeContext(dpy, &w);
    if (ctx == EGL_NO_CONTEXT) {
      note("surfaceless Mesa: " + w);
      return std::nullopt;
    }
    EglContext c;
    c.display_ = dpy;
    c.context_ = ctx;
    c.info_ = {GlString(GL_VENDOR), GlString(GL_RENDERER), GlString(GL_VERSION), "surfaceless Mesa"};
    return c;
  };
  auto fail = [&](const std::string& w) -> std::optional<EglContext> {
    if (why) *why = w;
    return std::nullopt;
  };

  if (!get_platform_display) return fail("no eglGetPlatformDisplayEXT (no EGL display)");
  if (options.device >= 0) {
    if (size_t(options.device) >= devices.size())
      return fail("--gl-device " + std::to_string(options.device) + ": " +
                  (devices.empty() ? list_why : "only " + std::to_string(devices.size()) + " EGL devices"));
    auto c = try_device(size_t(options.device));
    return c ? std::move(c) : fail(failures);
  }
  // Hardware devices first, then Mesa's surfaceless platform, then any device.
  for (size_t i = 0; i < devices.size(); ++i)
    if (!infos[i].software)
      if (auto c = try_device(i)) return c;
  if (auto c = try_surfaceless()) return c;
  for (size_t i = 0; i < devices.size(); ++i)
    if (infos[i].software)
      if (auto c = try_device(i)) return c;
  if (devices.empty()) note(list_why);
  return fail(failures.empty() ? "no EGL display" : failures);
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
      info_(std::move(o.info_)),
      software_device_(o.software_device_) {}

EglContext& EglContext::operator=(EglContext&& o) noexcept {
  if (this != &o) {
    this->~EglContext();
    display_ = std::exchange(o.display_, EGL_NO_DISPLAY);
    context_ = std::exchange(o.context_, EGL_NO_CONTEXT);
    info_ = std::move(o.info_);
    software_device_ = o.software_device_;
  }
  return *this;
}

void EglContext::MakeCurrent() const { eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_); }

bool EglContext::IsSoftware() const {
  if (software_device_) return true;
  for (const char* s : {"llvmpipe", "softpipe", "swrast", "Software"})
    if (info_.renderer.find(s) != std::string::npos) return true;
  return false;
}

}  // namespace hullpipe::gl
