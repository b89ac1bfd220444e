#include "hullpipe/openxr/xr_eyes.h"

#include <time.h>

#define XR_USE_TIMESPEC
#include <openxr/openxr_platform.h>
#include <openxr/openxr_reflection.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <vector>

namespace hullpipe::openxr {
namespace {

int64_t ClockNs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// A located view's pose is usable only with both bits (otherwise the runtime
// lost tracking).
constexpr XrViewStateFlags kPoseValid = XR_VIEW_STATE_POSITION_VALID_BIT | XR_VIEW_STATE_ORIENTATION_VALID_BIT;

std::vector<std::string> OfferedExtensions() {
  uint32_t n = 0;
  CheckXr(xrEnumerateInstanceExtensionProperties(nullptr, 0, &n, nullptr), "xrEnumerateInstanceExtensionProperties",
        "no OpenXR runtime is active (XR_RUNTIME_JSON, or the system's active_runtime.json)");
  std::vector<XrExtensionProperties> props(n, XrExtensionProperties{XR_TYPE_EXTENSION_PROPERTIES, nullptr, {}, 0});
  CheckXr(xrEnumerateInstanceExtensionProperties(nullptr, n, &n, props.data()),
          "xrEnumerateInstanceExtensionProperties");
  std::vector<std::string> names;
  for (uint32_t i = 0; i < n && i < props.size(); ++i)
    names.emplace_back(props[i].extensionName, strnlen(props[i].extensionName, XR_MAX_EXTENSION_NAME_SIZE));
  return names;
}

}  // namespace

XrError::XrError(const std::string& call, XrResult result, const std::string& meaning)
    : std::runtime_error(call + ": " + XrResultName(result) + (meaning.empty() ? "" : " (" + meaning + ")")),
      result_(result) {}

void CheckXr(XrResult result, const char* call, const std::string& meaning) {
  if (XR_FAILED(result)) throw XrError(call, result, meaning);
}

std::string XrResultName(XrResult result) {
  switch (result) {
#define HULLPIPE_XR_RESULT_NAME(name, value) \
  case name:                                 \
    return #name;
    XR_LIST_ENUM_XrResult(HULLPIPE_XR_RESULT_NAME)
#undef HULLPIPE_XR_RESULT_NAME
    default:
      break;
  }
  return "XrResult(" + std::to_string(int(result)) + ")";
}

void XrClientOptions::Check() const {
  if (space != "stage" && space != "local")
    throw std::invalid_argument("--space must be 'stage' or 'local', not '" + space + "'");
  if (!world_from_space.translation.allFinite() || !IsRotation(world_from_space.rotation))
    throw std::invalid_argument("--world-from-space is not a rigid transform");
}

Rigid3d RigidFromPoseText(const std::string& text, const std::string& flag) {
  std::vector<double> v;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(x))
      throw std::invalid_argument(flag + " '" + text + "': '" + item + "' is not a number");
    v.push_back(x);
  }
  if (v.size() != 7) throw std::invalid_argument(flag + " '" + text + "': give x,y,z,qx,qy,qz,qw (7 numbers)");
  const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
  if (!(q.norm() > 1e-9)) throw std::invalid_argument(flag + " '" + text + "': a zero quaternion");
  Rigid3d X;
  X.rotation = q.normalized().toRotationMatrix();
  X.translation = {v[0], v[1], v[2]};
  return X;
}

EyeViewsSample EyeViewsFromXr(const XrView* views, uint32_t count, XrViewStateFlags flags,
                              const Rigid3d& world_from_space, int64_t stamp_ns, uint32_t tracker_id) {
  if (count != 2) throw std::invalid_argument("xrLocateViews gave " + std::to_string(count) + " views, not 2");
  if ((flags & kPoseValid) != kPoseValid)
    throw std::invalid_argument("the runtime marked the views' pose invalid (tracking lost)");
  EyeViewsSample s;
  s.tracker_id = tracker_id;
  s.stamp_ns = stamp_ns;
  for (uint32_t k = 0; k < 2; ++k) {
    const char* eye = k == 0 ? "view 0 (left)" : "view 1 (right)";
    const XrPosef& p = views[k].pose;
    try {
      const Rigid3d space_from_eye = EyePoseFromXr(Eigen::Vector3d(p.position.x, p.position.y, p.position.z),
                                                   Eigen::Vector4d(p.orientation.x, p.orientation.y,
                                                                   p.orientation.z, p.orientation.w));
      s.world_from_eye[k] = world_from_space * space_from_eye;
      const XrFovf& f = views[k].fov;
      s.fov[k] = EyeFov{f.angleLeft, f.angleRight, f.angleUp, f.angleDown};
      s.fov[k].Check();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string(eye) + ": " + e.what());
    }
  }
  return s;
}

XrPosef XrPoseInSpace(const Rigid3d& world_from_space, const Rigid3d& world_from_eye) {
  const Rigid3d space_from_eye = world_from_space.Inverse() * world_from_eye;
  const Eigen::Vector4d q = XrOrientationOf(space_from_eye);
  XrPosef p{};
  p.orientation = {float(q[0]), float(q[1]), float(q[2]), float(q[3])};
  p.position = {float(space_from_eye.translation.x()), float(space_from_eye.translation.y()),
                float(space_from_eye.translation.z())};
  return p;
}

XrEyeSession::XrEyeSession(const XrClientOptions& options, const XrGraphicsBinding* graphics) : o_(options) {
  o_.Check();
  const std::vector<std::string> offered = OfferedExtensions();
  const auto offers = [&](const std::string& name) {
    for (const auto& e : offered)
      if (e == name) return true;
    return false;
  };
  std::vector<const char*> enabled;
  if (graphics) {
    for (const auto& e : graphics->extensions) {
      if (!offers(e))
        throw XrError("xrEnumerateInstanceExtensionProperties", XR_ERROR_EXTENSION_NOT_PRESENT,
                      "the runtime offers no " + e + ", which showing images needs (docs/hmd.md, \"Display\"); "
                      "without --display hullpipe_openxr only locates the eyes");
      enabled.push_back(e.c_str());
    }
  } else {
    if (!offers(XR_MND_HEADLESS_EXTENSION_NAME))
      throw XrError("xrEnumerateInstanceExtensionProperties", XR_ERROR_EXTENSION_NOT_PRESENT,
                    "the runtime offers no XR_MND_headless, which locating views without drawing needs: use "
                    "--display (docs/hmd.md)");
    enabled.push_back(XR_MND_HEADLESS_EXTENSION_NAME);
  }
  const bool timespec = offers(XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);
  if (timespec) enabled.push_back(XR_KHR_CONVERT_TIMESPEC_TIME_EXTENSION_NAME);

  XrInstanceCreateInfo ci{XR_TYPE_INSTANCE_CREATE_INFO};
  std::strncpy(ci.applicationInfo.applicationName, "hullpipe_openxr", XR_MAX_APPLICATION_NAME_SIZE - 1);
  ci.applicationInfo.applicationVersion = 1;
  std::strncpy(ci.applicationInfo.engineName, "hullpipe", XR_MAX_ENGINE_NAME_SIZE - 1);
  ci.applicationInfo.apiVersion = XR_MAKE_VERSION(1, 0, 0);
  ci.enabledExtensionCount = uint32_t(enabled.size());
  ci.enabledExtensionNames = enabled.data();
  CheckXr(xrCreateInstance(&ci, &instance_), "xrCreateInstance");
  try {
    XrInstanceProperties ip{XR_TYPE_INSTANCE_PROPERTIES};
    if (XR_SUCCEEDED(xrGetInstanceProperties(instance_, &ip))) {
      runtime_ = std::string(ip.runtimeName, strnlen(ip.runtimeName, XR_MAX_RUNTIME_NAME_SIZE)) + " " +
                 std::to_string(XR_VERSION_MAJOR(ip.runtimeVersion)) + "." +
                 std::to_string(XR_VERSION_MINOR(ip.runtimeVersion)) + "." +
                 std::to_string(XR_VERSION_PATCH(ip.runtimeVersion));
    }
    if (timespec)
      CheckXr(xrGetInstanceProcAddr(instance_, "xrConvertTimeToTimespecTimeKHR", &to_timespec_),
            "xrGetInstanceProcAddr(xrConvertTimeToTimespecTimeKHR)");
    XrSystemGetInfo sg{XR_TYPE_SYSTEM_GET_INFO};
    sg.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
    CheckXr(xrGetSystem(instance_, &sg, &system_), "xrGetSystem", "no head-mounted display is connected");
    if (graphics && graphics->check_requirements) graphics->check_requirements(instance_, system_);
    XrSessionCreateInfo sc{XR_TYPE_SESSION_CREATE_INFO};  // headless: no graphics binding
    sc.next = graphics ? graphics->session_next : nullptr;
    sc.systemId = system_;
    CheckXr(xrCreateSession(instance_, &sc, &session_), "xrCreateSession");
    XrReferenceSpaceCreateInfo rs{XR_TYPE_REFERENCE_SPACE_CREATE_INFO};
    rs.referenceSpaceType = o_.space == "stage" ? XR_REFERENCE_SPACE_TYPE_STAGE : XR_REFERENCE_SPACE_TYPE_LOCAL;
    rs.poseInReferenceSpace.orientation.w = 1;
    CheckXr(xrCreateReferenceSpace(session_, &rs, &space_), "xrCreateReferenceSpace",
          o_.space == "stage" ? "the runtime has no stage: set the room up, or use --space local" : "");
  } catch (...) {
    if (session_ != XR_NULL_HANDLE) xrDestroySession(session_);
    xrDestroyInstance(instance_);
    throw;
  }
}

XrEyeSession::~XrEyeSession() {
  if (space_ != XR_NULL_HANDLE) xrDestroySpace(space_);
  if (session_ != XR_NULL_HANDLE) {
    if (running_) xrEndSession(session_);
    xrDestroySession(session_);
  }
  if (instance_ != XR_NULL_HANDLE) xrDestroyInstance(instance_);
}

void XrEyeSession::PollEvents() {
  for (;;) {
    XrEventDataBuffer ev{XR_TYPE_EVENT_DATA_BUFFER};
    const XrResult r = xrPollEvent(instance_, &ev);
    if (r == XR_EVENT_UNAVAILABLE) return;
    CheckXr(r, "xrPollEvent");
    if (ev.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING) {
      exiting_ = true;
    } else if (ev.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) {
      const auto& sc = *reinterpret_cast<const XrEventDataSessionStateChanged*>(&ev);
      switch (sc.state) {
        case XR_SESSION_STATE_READY: {
          XrSessionBeginInfo bi{XR_TYPE_SESSION_BEGIN_INFO};
          bi.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
          CheckXr(xrBeginSession(session_, &bi), "xrBeginSession");
          running_ = true;
          break;
        }
        case XR_SESSION_STATE_STOPPING:
          CheckXr(xrEndSession(session_), "xrEndSession");
          running_ = false;
          break;
        case XR_SESSION_STATE_EXITING:
        case XR_SESSION_STATE_LOSS_PENDING:
          exiting_ = true;
          break;
        default:
          break;
      }
    }
  }
}

int64_t XrEyeSession::RealtimeNsOf(XrTime t) const {
  if (to_timespec_) {
    timespec ts{};
    const auto convert = reinterpret_cast<PFN_xrConvertTimeToTimespecTimeKHR>(to_timespec_);
    if (XR_SUCCEEDED(convert(instance_, t, &ts))) {
      // The extension's timespec is CLOCK_MONOTONIC's; hullpipe stamps CLOCK_REALTIME.
      const int64_t mono = int64_t(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
      return mono + (ClockNs(CLOCK_REALTIME) - ClockNs(CLOCK_MONOTONIC));
    }
  }
  return ClockNs(CLOCK_REALTIME);
}

std::optional<XrFrame> XrEyeSession::BeginFrame() {
  PollEvents();
  if (!running_ || exiting_) return std::nullopt;
  XrFrameState fs{XR_TYPE_FRAME_STATE};
  XrFrameWaitInfo wi{XR_TYPE_FRAME_WAIT_INFO};
  CheckXr(xrWaitFrame(session_, &wi, &fs), "xrWaitFrame");
  XrFrameBeginInfo bi{XR_TYPE_FRAME_BEGIN_INFO};
  CheckXr(xrBeginFrame(session_, &bi), "xrBeginFrame");
  ++counts_.frames;
  XrFrame frame;
  frame.display_time = fs.predictedDisplayTime;
  frame.should_render = fs.shouldRender == XR_TRUE;
  XrViewLocateInfo li{XR_TYPE_VIEW_LOCATE_INFO};
  li.viewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
  li.displayTime = fs.predictedDisplayTime;
  li.space = space_;
  XrViewState vs{XR_TYPE_VIEW_STATE};
  XrView views[2] = {{XR_TYPE_VIEW}, {XR_TYPE_VIEW}};
  uint32_t n = 0;
  const XrResult located = xrLocateViews(session_, &li, &vs, 2, &n, views);
  if (XR_FAILED(located)) {
    EndFrame(frame, {});  // every xrBeginFrame is ended, whatever the views
    CheckXr(located, "xrLocateViews");
  }
  if ((vs.viewStateFlags & kPoseValid) != kPoseValid) {
    ++counts_.untracked;
    last_skip_ = "tracking lost";
    return frame;
  }
  try {
    frame.views = EyeViewsFromXr(views, n, vs.viewStateFlags, o_.world_from_space,
                                 RealtimeNsOf(fs.predictedDisplayTime), o_.tracker_id);
    ++counts_.located;
    last_skip_.clear();
  } catch (const std::invalid_argument& e) {
    ++counts_.refused;
    last_skip_ = e.what();
  }
  return frame;
}

void XrEyeSession::EndFrame(const XrFrame& frame, const std::vector<const XrCompositionLayerBaseHeader*>& layers) {
  XrFrameEndInfo ei{XR_TYPE_FRAME_END_INFO};
  ei.displayTime = frame.display_time;
  ei.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
  ei.layerCount = uint32_t(layers.size());
  ei.layers = layers.empty() ? nullptr : layers.data();
  CheckXr(xrEndFrame(session_, &ei), "xrEndFrame");
}

void XrEyeSession::RequestExit() {
  if (running_ && !exiting_) CheckXr(xrRequestExitSession(session_), "xrRequestExitSession");
  if (!running_) exiting_ = true;  // never begun (or already ended): nothing to wait for
}

}  // namespace hullpipe::openxr
