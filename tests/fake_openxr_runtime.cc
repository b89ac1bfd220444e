// A fake OpenXR runtime for hullpipe_openxr's tests (docs/hmd.md, "An OpenXR
// client" and "Display"): the Khronos loader loads it as it loads a lab's
// runtime (a manifest named by XR_RUNTIME_JSON, then
// xrNegotiateLoaderRuntimeInterface), and it reports a headset whose eyes
// follow a script the tests know. Only what hullpipe_openxr calls is here; any
// other function is unsupported.
//
// The script: frame n (counted from 0 by xrWaitFrame) has its head at
// (0.001 n, 1.6, -0.5) in the reference space (y up), turned kYaw about +y;
// the eyes kHalfIpd either side along the head's x, both looking along the
// head's -z (OpenXR's view axes); fields of view kLeftFov and its mirror.
// Display (XR_MNDX_egl_enable with XR_KHR_opengl_enable, as Monado offers
// them): swapchains are GL textures made in the client's context (current
// when it calls), and xrEndFrame checks each projection layer as a strict
// runtime would, then reads back what each eye would show.
// Environment (read at xrCreateInstance):
//   HULLPIPE_FAKE_XR_HEADLESS=0          XR_MND_headless not offered
//   HULLPIPE_FAKE_XR_EGL=0               XR_MNDX_egl_enable not offered
//   HULLPIPE_FAKE_XR_FORMATS=a,b         the swapchain formats offered (decimal;
//                                        default GL_SRGB8_ALPHA8, GL_RGBA8)
//   HULLPIPE_FAKE_XR_LAYERS_DIR=dir      each xrEndFrame's layers as a line of
//                                        dir/layers.txt; each newly released eye
//                                        image as dir/f<frame>_eye<k>.ppm (top row
//                                        first; at most 64 files)
//   HULLPIPE_FAKE_XR_EXIT_AFTER=N        the session stops after N frames (0: never)
//   HULLPIPE_FAKE_XR_UNTRACKED_EVERY=K   frames n with n % K == K - 1 lose tracking
#include <openxr/openxr.h>
#include <time.h>

#define GL_GLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <GL/glcorearb.h>

#define XR_USE_TIMESPEC
#define XR_USE_PLATFORM_EGL
#define XR_USE_GRAPHICS_API_OPENGL
#include <openxr/openxr_platform.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <vector>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <string>
#include <thread>

#include "fake_openxr_script.h"

namespace {

// The loader-runtime negotiation, as the OpenXR loader specification defines
// it (its header is not installed by Debian's libopenxr-dev).
constexpr int kLoaderInfoStruct = 1, kRuntimeRequestStruct = 3;
struct NegotiateLoaderInfo {
  int structType;
  uint32_t structVersion;
  size_t structSize;
  uint32_t minInterfaceVersion, maxInterfaceVersion;
  XrVersion minApiVersion, maxApiVersion;
};
struct NegotiateRuntimeRequest {
  int structType;
  uint32_t structVersion;
  size_t structSize;
  uint32_t runtimeInterfaceVersion;
  XrVersion runtimeApiVersion;
  PFN_xrGetInstanceProcAddr getInstanceProcAddr;
};

struct Swapchain {
  int width = 0, height = 0;
  int64_t format = 0;
  std::vector<GLuint> textures;
  uint32_t next = 0;          // the image xrAcquireSwapchainImage gives next
  int acquired = -1;          // acquired, not yet released
  bool waited = false;
  int released = -1;          // the image last released (shown by a layer)
  uint64_t releases = 0, dumped_releases = 0;
};

struct State {
  bool headless_offered = true, timespec = false, instance = false, session = false, running = false;
  bool egl_offered = true, egl = false, gl_requirements_asked = false, graphics_session = false;
  std::vector<int64_t> formats;
  std::string layers_dir;
  int dumped_files = 0;
  std::map<XrSwapchain, Swapchain> swapchains;
  uint64_t next_swapchain = 1;
  XrSessionState state = XR_SESSION_STATE_UNKNOWN;
  std::deque<XrSessionState> events;
  uint64_t frames = 0, exit_after = 0, untracked_every = 0;
  bool stop_sent = false;
  std::chrono::steady_clock::time_point next_frame;
} g;

int kInstanceTag, kSessionTag, kSpaceTag;
XrInstance InstanceHandle() { return reinterpret_cast<XrInstance>(&kInstanceTag); }
XrSession SessionHandle() { return reinterpret_cast<XrSession>(&kSessionTag); }
XrSpace SpaceHandle() { return reinterpret_cast<XrSpace>(&kSpaceTag); }

uint64_t EnvCount(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtoull(v, nullptr, 10) : fallback;
}

int64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void Push(XrSessionState s) { g.events.push_back(s); }

XRAPI_ATTR XrResult XRAPI_CALL EnumerateInstanceExtensionProperties(const char*, uint32_t capacity, uint32_t* count,
                                                                     XrExtensionProperties* props) {
  std::vector<const char*> names = {XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME};
  if (EnvCount("HULLPIPE_FAKE_XR_HEADLESS", 1) != 0) names.push_back(XR_MND_HEADLESS_EXTENSION_NAME);
  if (EnvCount("HULLPIPE_FAKE_XR_EGL", 1) != 0) {
    names.push_back(XR_MNDX_EGL_ENABLE_EXTENSION_NAME);
    names.push_back(XR_KHR_OPENGL_ENABLE_EXTENSION_NAME);
  }
  const uint32_t n = uint32_t(names.size());
  *count = n;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < n) return XR_ERROR_SIZE_INSUFFICIENT;
  for (uint32_t i = 0; i < n; ++i) {
    std::strncpy(props[i].extensionName, names[i], XR_MAX_EXTENSION_NAME_SIZE - 1);
    props[i].extensionVersion = 1;
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateInstance(const XrInstanceCreateInfo* info, XrInstance* instance) {
  if (g.instance) return XR_ERROR_LIMIT_REACHED;
  g = State{};
  g.headless_offered = EnvCount("HULLPIPE_FAKE_XR_HEADLESS", 1) != 0;
  g.exit_after = EnvCount("HULLPIPE_FAKE_XR_EXIT_AFTER", 0);
  g.untracked_every = EnvCount("HULLPIPE_FAKE_XR_UNTRACKED_EVERY", 0);
  g.egl_offered = EnvCount("HULLPIPE_FAKE_XR_EGL", 1) != 0;
  g.formats = {0x8C43, 0x8058};  // GL_SRGB8_ALPHA8, GL_RGBA8
  if (const char* f = std::getenv("HULLPIPE_FAKE_XR_FORMATS")) {
    g.formats.clear();
    std::stringstream ss(f);
    for (std::string item; std::getline(ss, item, ',');) g.formats.push_back(std::strtoll(item.c_str(), nullptr, 10));
  }
  if (const char* d = std::getenv("HULLPIPE_FAKE_XR_LAYERS_DIR")) g.layers_dir = d;
  bool headless = false, opengl = false;
  for (uint32_t i = 0; i < info->enabledExtensionCount; ++i) {
    const std::string e = info->enabledExtensionNames[i];
    if (e == XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME) {
      g.timespec = true;
    } else if (e == XR_MNDX_EGL_ENABLE_EXTENSION_NAME && g.egl_offered) {
      g.egl = true;
    } else if (e == XR_KHR_OPENGL_ENABLE_EXTENSION_NAME && g.egl_offered) {
      opengl = true;
    } else if (e == XR_MND_HEADLESS_EXTENSION_NAME && g.headless_offered) {
      headless = true;
    } else {
      return XR_ERROR_EXTENSION_NOT_PRESENT;
    }
  }
  if (!headless) g.headless_offered = false;  // a session then needs a graphics binding
  if (g.egl && !opengl) return XR_ERROR_EXTENSION_NOT_PRESENT;  // Monado's EGL binding gives OpenGL images
  g.instance = true;
  *instance = InstanceHandle();
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroyInstance(XrInstance) {
  g.instance = false;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProperties(XrInstance, XrInstanceProperties* p) {
  std::strncpy(p->runtimeName, "hullpipe fake runtime", XR_MAX_RUNTIME_NAME_SIZE - 1);
  p->runtimeVersion = XR_MAKE_VERSION(1, 2, 3);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetSystem(XrInstance, const XrSystemGetInfo* info, XrSystemId* id) {
  if (info->formFactor != XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY) return XR_ERROR_FORM_FACTOR_UNSUPPORTED;
  *id = 1;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetOpenGLGraphicsRequirements(XrInstance, XrSystemId system,
                                                             XrGraphicsRequirementsOpenGLKHR* req) {
  if (!g.egl) return XR_ERROR_FUNCTION_UNSUPPORTED;
  if (system != 1 || req->type != XR_TYPE_GRAPHICS_REQUIREMENTS_OPENGL_KHR) return XR_ERROR_VALIDATION_FAILURE;
  req->minApiVersionSupported = XR_MAKE_VERSION(3, 3, 0);
  req->maxApiVersionSupported = XR_MAKE_VERSION(4, 6, 0);
  g.gl_requirements_asked = true;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateSession(XrInstance, const XrSessionCreateInfo* info, XrSession* session) {
  if (info->systemId != 1) return XR_ERROR_SYSTEM_INVALID;
  if (info->next == nullptr && !g.headless_offered) return XR_ERROR_GRAPHICS_DEVICE_INVALID;
  if (info->next != nullptr) {
    const auto* b = static_cast<const XrGraphicsBindingEGLMNDX*>(info->next);
    if (!g.egl || b->type != XR_TYPE_GRAPHICS_BINDING_EGL_MNDX) return XR_ERROR_GRAPHICS_DEVICE_INVALID;
    if (!g.gl_requirements_asked) return XR_ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING;
    if (!b->getProcAddress || b->display == EGL_NO_DISPLAY || b->context == EGL_NO_CONTEXT ||
        eglGetCurrentContext() != b->context)  // the client's context, current as it calls
      return XR_ERROR_GRAPHICS_DEVICE_INVALID;
    g.graphics_session = true;
  }
  g.session = true;
  Push(XR_SESSION_STATE_IDLE);
  Push(XR_SESSION_STATE_READY);
  *session = SessionHandle();
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySession(XrSession) {
  g.session = g.running = false;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateReferenceSpace(XrSession, const XrReferenceSpaceCreateInfo* info,
                                                    XrSpace* space) {
  if (info->referenceSpaceType != XR_REFERENCE_SPACE_TYPE_STAGE &&
      info->referenceSpaceType != XR_REFERENCE_SPACE_TYPE_LOCAL)
    return XR_ERROR_REFERENCE_SPACE_UNSUPPORTED;
  *space = SpaceHandle();
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySpace(XrSpace) { return XR_SUCCESS; }

XRAPI_ATTR XrResult XRAPI_CALL PollEvent(XrInstance, XrEventDataBuffer* buffer) {
  if (g.events.empty()) return XR_EVENT_UNAVAILABLE;
  g.state = g.events.front();
  g.events.pop_front();
  auto* e = reinterpret_cast<XrEventDataSessionStateChanged*>(buffer);
  *e = XrEventDataSessionStateChanged{XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED, nullptr, SessionHandle(), g.state,
                                      MonotonicNs()};
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL BeginSession(XrSession, const XrSessionBeginInfo* info) {
  if (g.state != XR_SESSION_STATE_READY) return XR_ERROR_SESSION_NOT_READY;
  if (info->primaryViewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  g.running = true;
  g.next_frame = std::chrono::steady_clock::now();
  Push(XR_SESSION_STATE_SYNCHRONIZED);
  Push(XR_SESSION_STATE_VISIBLE);
  Push(XR_SESSION_STATE_FOCUSED);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EndSession(XrSession) {
  if (g.state != XR_SESSION_STATE_STOPPING) return XR_ERROR_SESSION_NOT_STOPPING;
  g.running = false;
  Push(XR_SESSION_STATE_IDLE);
  Push(XR_SESSION_STATE_EXITING);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL RequestExitSession(XrSession) {
  if (!g.running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (!g.stop_sent) Push(XR_SESSION_STATE_STOPPING);
  g.stop_sent = true;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL WaitFrame(XrSession, const XrFrameWaitInfo*, XrFrameState* fs) {
  if (!g.running) return XR_ERROR_SESSION_NOT_RUNNING;
  // Paced as a 90 Hz display.
  g.next_frame += std::chrono::microseconds(11111);
  std::this_thread::sleep_until(g.next_frame);
  fs->predictedDisplayTime = MonotonicNs() + 20'000'000;
  fs->predictedDisplayPeriod = 11'111'111;
  fs->shouldRender = XR_TRUE;
  ++g.frames;
  if (g.exit_after && g.frames >= g.exit_after && !g.stop_sent) {
    Push(XR_SESSION_STATE_STOPPING);
    g.stop_sent = true;
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL BeginFrame(XrSession, const XrFrameBeginInfo*) {
  return g.running ? XR_SUCCESS : XR_ERROR_SESSION_NOT_RUNNING;
}

// Each eye: recommended 1440x1600, at most 2048x2048 (a common headset's).
XRAPI_ATTR XrResult XRAPI_CALL EnumerateViewConfigurationViews(XrInstance, XrSystemId system,
                                                                XrViewConfigurationType type, uint32_t capacity,
                                                                uint32_t* count, XrViewConfigurationView* views) {
  if (system != 1) return XR_ERROR_SYSTEM_INVALID;
  if (type != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO) return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  *count = 2;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < 2) return XR_ERROR_SIZE_INSUFFICIENT;
  for (uint32_t k = 0; k < 2; ++k) {
    if (views[k].type != XR_TYPE_VIEW_CONFIGURATION_VIEW) return XR_ERROR_VALIDATION_FAILURE;
    views[k].recommendedImageRectWidth = 1440;
    views[k].recommendedImageRectHeight = 1600;
    views[k].maxImageRectWidth = views[k].maxImageRectHeight = 2048;
    views[k].recommendedSwapchainSampleCount = views[k].maxSwapchainSampleCount = 1;
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateSwapchainFormats(XrSession, uint32_t capacity, uint32_t* count,
                                                          int64_t* formats) {
  if (!g.graphics_session) return XR_ERROR_VALIDATION_FAILURE;
  *count = uint32_t(g.formats.size());
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < *count) return XR_ERROR_SIZE_INSUFFICIENT;
  for (size_t i = 0; i < g.formats.size(); ++i) formats[i] = g.formats[i];
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL CreateSwapchain(XrSession, const XrSwapchainCreateInfo* ci, XrSwapchain* out) {
  if (!g.graphics_session) return XR_ERROR_VALIDATION_FAILURE;
  bool offered = false;
  for (int64_t f : g.formats) offered = offered || f == ci->format;
  if (!offered) return XR_ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED;
  if (ci->width < 1 || ci->height < 1 || ci->width > 2048 || ci->height > 2048 || ci->faceCount != 1 ||
      ci->arraySize != 1 || ci->mipCount != 1 || ci->sampleCount != 1)
    return XR_ERROR_VALIDATION_FAILURE;
  Swapchain sc;
  sc.width = int(ci->width);
  sc.height = int(ci->height);
  sc.format = ci->format;
  sc.textures.resize(3);
  glGenTextures(3, sc.textures.data());
  for (GLuint t : sc.textures) {
    glBindTexture(GL_TEXTURE_2D, t);
    glTexStorage2D(GL_TEXTURE_2D, 1, GLenum(ci->format), sc.width, sc.height);
  }
  glBindTexture(GL_TEXTURE_2D, 0);
  const XrSwapchain h = reinterpret_cast<XrSwapchain>(g.next_swapchain++);
  g.swapchains[h] = std::move(sc);
  *out = h;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL DestroySwapchain(XrSwapchain h) {
  auto it = g.swapchains.find(h);
  if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
  glDeleteTextures(GLsizei(it->second.textures.size()), it->second.textures.data());
  g.swapchains.erase(it);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL EnumerateSwapchainImages(XrSwapchain h, uint32_t capacity, uint32_t* count,
                                                         XrSwapchainImageBaseHeader* images) {
  auto it = g.swapchains.find(h);
  if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
  *count = uint32_t(it->second.textures.size());
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < *count) return XR_ERROR_SIZE_INSUFFICIENT;
  auto* gl = reinterpret_cast<XrSwapchainImageOpenGLKHR*>(images);
  for (uint32_t i = 0; i < *count; ++i) {
    if (gl[i].type != XR_TYPE_SWAPCHAIN_IMAGE_OPENGL_KHR) return XR_ERROR_VALIDATION_FAILURE;
    gl[i].image = it->second.textures[i];
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL AcquireSwapchainImage(XrSwapchain h, const XrSwapchainImageAcquireInfo*,
                                                      uint32_t* index) {
  auto it = g.swapchains.find(h);
  if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
  Swapchain& sc = it->second;
  if (sc.acquired >= 0) return XR_ERROR_CALL_ORDER_INVALID;  // one at a time here
  sc.acquired = int(sc.next);
  sc.waited = false;
  sc.next = (sc.next + 1) % uint32_t(sc.textures.size());
  *index = uint32_t(sc.acquired);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL WaitSwapchainImage(XrSwapchain h, const XrSwapchainImageWaitInfo*) {
  auto it = g.swapchains.find(h);
  if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
  if (it->second.acquired < 0) return XR_ERROR_CALL_ORDER_INVALID;
  it->second.waited = true;
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL ReleaseSwapchainImage(XrSwapchain h, const XrSwapchainImageReleaseInfo*) {
  auto it = g.swapchains.find(h);
  if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
  Swapchain& sc = it->second;
  if (sc.acquired < 0 || !sc.waited) return XR_ERROR_CALL_ORDER_INVALID;
  sc.released = sc.acquired;
  sc.acquired = -1;
  ++sc.releases;
  return XR_SUCCESS;
}

// What the eye would see: the released image read back, top row first.
bool DumpImage(const Swapchain& sc, const std::string& path) {
  std::vector<unsigned char> rgba(size_t(sc.width) * size_t(sc.height) * 4);
  GLuint fbo = 0;
  glGenFramebuffers(1, &fbo);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
  glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, sc.textures[size_t(sc.released)],
                         0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, sc.width, sc.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glDeleteFramebuffers(1, &fbo);
  std::ofstream f(path, std::ios::binary);
  f << "P6\n" << sc.width << " " << sc.height << "\n255\n";
  for (int y = sc.height - 1; y >= 0; --y)  // GL's first row is the bottom
    for (int x = 0; x < sc.width; ++x)
      f.write(reinterpret_cast<const char*>(&rgba[(size_t(y) * size_t(sc.width) + size_t(x)) * 4]), 3);
  return bool(f);
}

XRAPI_ATTR XrResult XRAPI_CALL EndFrame(XrSession, const XrFrameEndInfo* info) {
  if (!g.running) return XR_ERROR_SESSION_NOT_RUNNING;
  if (info->layerCount != 0 && !g.graphics_session) return XR_ERROR_LAYER_INVALID;  // headless: nothing to show
  if (info->environmentBlendMode != XR_ENVIRONMENT_BLEND_MODE_OPAQUE)
    return XR_ERROR_ENVIRONMENT_BLEND_MODE_UNSUPPORTED;
  std::ostringstream line;
  line << g.frames - 1 << " layers " << info->layerCount;
  for (uint32_t i = 0; i < info->layerCount; ++i) {
    const auto* base = info->layers[i];
    if (!base || base->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION) return XR_ERROR_LAYER_INVALID;
    const auto* p = reinterpret_cast<const XrCompositionLayerProjection*>(base);
    if (p->space != SpaceHandle()) return XR_ERROR_HANDLE_INVALID;
    if (p->viewCount != 2) return XR_ERROR_VALIDATION_FAILURE;
    for (uint32_t k = 0; k < 2; ++k) {
      const XrCompositionLayerProjectionView& v = p->views[k];
      if (v.type != XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW) return XR_ERROR_VALIDATION_FAILURE;
      auto it = g.swapchains.find(v.subImage.swapchain);
      if (it == g.swapchains.end()) return XR_ERROR_HANDLE_INVALID;
      Swapchain& sc = it->second;
      if (sc.released < 0) return XR_ERROR_LAYER_INVALID;  // no image released yet
      const XrRect2Di& r = v.subImage.imageRect;
      if (r.offset.x < 0 || r.offset.y < 0 || r.extent.width < 1 || r.extent.height < 1 ||
          r.offset.x + r.extent.width > sc.width || r.offset.y + r.extent.height > sc.height ||
          v.subImage.imageArrayIndex != 0)
        return XR_ERROR_SWAPCHAIN_RECT_INVALID;
      const XrQuaternionf& q = v.pose.orientation;
      if (std::abs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1.0f) > 1e-3f) return XR_ERROR_POSE_INVALID;
      if (!(v.fov.angleLeft < v.fov.angleRight && v.fov.angleDown < v.fov.angleUp))
        return XR_ERROR_VALIDATION_FAILURE;
      line.precision(9);
      line << " eye " << k << " " << v.pose.position.x << " " << v.pose.position.y << " " << v.pose.position.z
           << " " << q.x << " " << q.y << " " << q.z << " " << q.w << " " << v.fov.angleLeft << " "
           << v.fov.angleRight << " " << v.fov.angleUp << " " << v.fov.angleDown << " " << r.extent.width << " "
           << r.extent.height << " " << sc.format;
      std::string file = "-";
      if (!g.layers_dir.empty() && sc.releases != sc.dumped_releases && g.dumped_files < 64) {
        file = "f" + std::to_string(g.frames - 1) + "_eye" + std::to_string(k) + ".ppm";
        if (!DumpImage(sc, g.layers_dir + "/" + file)) return XR_ERROR_RUNTIME_FAILURE;
        sc.dumped_releases = sc.releases;
        ++g.dumped_files;
      }
      line << " " << file;
    }
  }
  if (!g.layers_dir.empty()) {
    std::ofstream f(g.layers_dir + "/layers.txt", std::ios::app);
    f << line.str() << "\n";
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL LocateViews(XrSession, const XrViewLocateInfo* info, XrViewState* state,
                                           uint32_t capacity, uint32_t* count, XrView* views) {
  if (info->viewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  if (info->space != SpaceHandle()) return XR_ERROR_HANDLE_INVALID;
  *count = 2;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < 2) return XR_ERROR_SIZE_INSUFFICIENT;
  const uint64_t n = g.frames - 1;
  const bool lost = g.untracked_every && n % g.untracked_every == g.untracked_every - 1;
  state->viewStateFlags = lost ? 0
                               : XR_VIEW_STATE_POSITION_VALID_BIT | XR_VIEW_STATE_ORIENTATION_VALID_BIT |
                                     XR_VIEW_STATE_POSITION_TRACKED_BIT | XR_VIEW_STATE_ORIENTATION_TRACKED_BIT;
  for (int k = 0; k < 2; ++k) {
    const hullpipe::fake_xr::ScriptedEye e = hullpipe::fake_xr::EyeAt(n, k);
    views[k].pose.position = {float(e.position[0]), float(e.position[1]), float(e.position[2])};
    views[k].pose.orientation = {float(e.orientation_xyzw[0]), float(e.orientation_xyzw[1]),
                                 float(e.orientation_xyzw[2]), float(e.orientation_xyzw[3])};
    views[k].fov = {e.fov[0], e.fov[1], e.fov[2], e.fov[3]};
  }
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL ConvertTimeToTimespecTime(XrInstance, XrTime time, timespec* ts) {
  if (!g.timespec) return XR_ERROR_FUNCTION_UNSUPPORTED;
  ts->tv_sec = time_t(time / 1'000'000'000);
  ts->tv_nsec = long(time % 1'000'000'000);
  return XR_SUCCESS;
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* fn);

const std::map<std::string, PFN_xrVoidFunction>& Functions() {
  static const std::map<std::string, PFN_xrVoidFunction> f = {
#define HULLPIPE_FAKE_XR(name, impl) {name, reinterpret_cast<PFN_xrVoidFunction>(impl)}
      HULLPIPE_FAKE_XR("xrGetInstanceProcAddr", GetInstanceProcAddr),
      HULLPIPE_FAKE_XR("xrEnumerateInstanceExtensionProperties", EnumerateInstanceExtensionProperties),
      HULLPIPE_FAKE_XR("xrCreateInstance", CreateInstance),
      HULLPIPE_FAKE_XR("xrDestroyInstance", DestroyInstance),
      HULLPIPE_FAKE_XR("xrGetInstanceProperties", GetInstanceProperties),
      HULLPIPE_FAKE_XR("xrGetSystem", GetSystem),
      HULLPIPE_FAKE_XR("xrCreateSession", CreateSession),
      HULLPIPE_FAKE_XR("xrDestroySession", DestroySession),
      HULLPIPE_FAKE_XR("xrCreateReferenceSpace", CreateReferenceSpace),
      HULLPIPE_FAKE_XR("xrDestroySpace", DestroySpace),
      HULLPIPE_FAKE_XR("xrPollEvent", PollEvent),
      HULLPIPE_FAKE_XR("xrBeginSession", BeginSession),
      HULLPIPE_FAKE_XR("xrEndSession", EndSession),
      HULLPIPE_FAKE_XR("xrRequestExitSession", RequestExitSession),
      HULLPIPE_FAKE_XR("xrWaitFrame", WaitFrame),
      HULLPIPE_FAKE_XR("xrBeginFrame", BeginFrame),
      HULLPIPE_FAKE_XR("xrEndFrame", EndFrame),
      HULLPIPE_FAKE_XR("xrLocateViews", LocateViews),
      HULLPIPE_FAKE_XR("xrConvertTimeToTimespecTimeKHR", ConvertTimeToTimespecTime),
      HULLPIPE_FAKE_XR("xrGetOpenGLGraphicsRequirementsKHR", GetOpenGLGraphicsRequirements),
      HULLPIPE_FAKE_XR("xrEnumerateViewConfigurationViews", EnumerateViewConfigurationViews),
      HULLPIPE_FAKE_XR("xrEnumerateSwapchainFormats", EnumerateSwapchainFormats),
      HULLPIPE_FAKE_XR("xrCreateSwapchain", CreateSwapchain),
      HULLPIPE_FAKE_XR("xrDestroySwapchain", DestroySwapchain),
      HULLPIPE_FAKE_XR("xrEnumerateSwapchainImages", EnumerateSwapchainImages),
      HULLPIPE_FAKE_XR("xrAcquireSwapchainImage", AcquireSwapchainImage),
      HULLPIPE_FAKE_XR("xrWaitSwapchainImage", WaitSwapchainImage),
      HULLPIPE_FAKE_XR("xrReleaseSwapchainImage", ReleaseSwapchainImage),
#undef HULLPIPE_FAKE_XR
  };
  return f;
}

XRAPI_ATTR XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name, PFN_xrVoidFunction* fn) {
  const std::string n = name ? name : "";
  // Before an instance only these (the specification's rule).
  if (instance == XR_NULL_HANDLE && n != "xrEnumerateInstanceExtensionProperties" && n != "xrCreateInstance" &&
      n != "xrEnumerateApiLayerProperties") {
    *fn = nullptr;
    return XR_ERROR_HANDLE_INVALID;
  }
  const auto it = Functions().find(n);
  *fn = it == Functions().end() ? nullptr : it->second;
  return *fn ? XR_SUCCESS : XR_ERROR_FUNCTION_UNSUPPORTED;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) XrResult xrNegotiateLoaderRuntimeInterface(
    const NegotiateLoaderInfo* info, NegotiateRuntimeRequest* request) {
  if (!info || !request || info->structType != kLoaderInfoStruct || request->structType != kRuntimeRequestStruct ||
      request->structSize != sizeof(NegotiateRuntimeRequest) || info->minInterfaceVersion > 1 ||
      info->maxInterfaceVersion < 1)
    return XR_ERROR_INITIALIZATION_FAILED;
  request->runtimeInterfaceVersion = 1;
  request->runtimeApiVersion = XR_CURRENT_API_VERSION;
  request->getInstanceProcAddr = GetInstanceProcAddr;
  return XR_SUCCESS;
}
