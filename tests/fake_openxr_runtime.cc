// A fake OpenXR runtime for hullpipe_openxr's tests (docs/hmd.md, "An OpenXR
// client"): the Khronos loader loads it as it loads a lab's runtime (a
// manifest named by XR_RUNTIME_JSON, then xrNegotiateLoaderRuntimeInterface),
// and it reports a headset whose eyes follow a script the tests know. Only
// what a headless client calls is here; any other function is unsupported.
//
// The script: frame n (counted from 0 by xrWaitFrame) has its head at
// (0.001 n, 1.6, -0.5) in the reference space (y up), turned kYaw about +y;
// the eyes kHalfIpd either side along the head's x, both looking along the
// head's -z (OpenXR's view axes); fields of view kLeftFov and its mirror.
// Environment (read at xrCreateInstance):
//   HULLPIPE_FAKE_XR_HEADLESS=0          XR_MND_headless not offered
//   HULLPIPE_FAKE_XR_EXIT_AFTER=N        the session stops after N frames (0: never)
//   HULLPIPE_FAKE_XR_UNTRACKED_EVERY=K   frames n with n % K == K - 1 lose tracking
#include <openxr/openxr.h>
#include <time.h>

#define XR_USE_TIMESPEC
#include <openxr/openxr_platform.h>

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

struct State {
  bool headless_offered = true, timespec = false, instance = false, session = false, running = false;
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
  const bool headless = EnvCount("HULLPIPE_FAKE_XR_HEADLESS", 1) != 0;
  const char* names[2] = {XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME, XR_MND_HEADLESS_EXTENSION_NAME};
  const uint32_t n = headless ? 2 : 1;
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
  bool headless = false;
  for (uint32_t i = 0; i < info->enabledExtensionCount; ++i) {
    const std::string e = info->enabledExtensionNames[i];
    if (e == XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME) {
      g.timespec = true;
    } else if (e == XR_MND_HEADLESS_EXTENSION_NAME && g.headless_offered) {
      headless = true;
    } else {
      return XR_ERROR_EXTENSION_NOT_PRESENT;
    }
  }
  if (!headless) g.headless_offered = false;  // a session then needs a graphics binding
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

XRAPI_ATTR XrResult XRAPI_CALL CreateSession(XrInstance, const XrSessionCreateInfo* info, XrSession* session) {
  if (info->systemId != 1) return XR_ERROR_SYSTEM_INVALID;
  if (info->next == nullptr && !g.headless_offered) return XR_ERROR_GRAPHICS_DEVICE_INVALID;
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

XRAPI_ATTR XrResult XRAPI_CALL EndFrame(XrSession, const XrFrameEndInfo* info) {
  if (info->layerCount != 0) return XR_ERROR_LAYER_INVALID;  // headless: nothing to show
  return g.running ? XR_SUCCESS : XR_ERROR_SESSION_NOT_RUNNING;
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
