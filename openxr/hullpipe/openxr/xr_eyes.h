// hullpipe's OpenXR client side (docs/hmd.md, "An OpenXR client"): a headset's
// two views each frame, as an OpenXR runtime reports them (xrLocateViews at
// the frame's predicted display time: an XrPosef and an XrFovf per view),
// turned into hullpipe's EyeViewsSample for render_node --view eyes-topic. The
// paper's participant wore a tracked HMD (§3: the parent pipe rendered for the
// tracked head); an OpenXR runtime is today's form of that tracker.
//
// Through the Khronos loader (libopenxr_loader): hullpipe links no runtime; the
// loader finds the active one (XR_RUNTIME_JSON or the system's
// active_runtime.json). The session is headless (XR_MND_headless: it locates
// views and submits no images) or, given a graphics binding (xr_display.h's
// EGL one), shows render_node's composited eyes in the headset as a
// projection layer (docs/hmd.md, "Display").
//
// Frames: an XrView's pose is in the chosen reference space (LOCAL or STAGE),
// OpenXR's view axes (x right, y up, z backward); hullpipe's eyes are in the
// rig's world, OpenCV's eye axes (geometry/conventions.h). The lab's
// registration world_from_space (x_world = R x_space + t, metres) maps one to
// the other; EyePoseFromXr turns the axes.
#pragma once

#include <openxr/openxr.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/reconstruction/stereo_views.h"

namespace hullpipe::openxr {

/// A failed OpenXR call: "xrCreateSession: XR_ERROR_GRAPHICS_DEVICE_INVALID"
/// and what it means for hullpipe.
class XrError : public std::runtime_error {
 public:
  XrError(const std::string& call, XrResult result, const std::string& meaning = "");
  XrResult result() const { return result_; }

 private:
  XrResult result_;
};

/// XrResult's name ("XR_ERROR_RUNTIME_UNAVAILABLE"; "XrResult(-123)" for one
/// the headers do not name), from the headers, with no runtime asked.
std::string XrResultName(XrResult result);
/// Throws XrError naming `call` (and what it means for hullpipe, if given)
/// when `result` is a failure; success codes (XR_TIMEOUT_EXPIRED among them)
/// pass.
void CheckXr(XrResult result, const char* call, const std::string& meaning = "");

/// The client's settings (hullpipe_openxr's flags).
struct XrClientOptions {
  /// The reference space the views are located in: "stage" (the tracked
  /// room's floor, XR_REFERENCE_SPACE_TYPE_STAGE) or "local" (the head's
  /// start, LOCAL). --space.
  std::string space = "stage";
  /// The lab's registration of that space to the rig's world (world_from_space,
  /// metres). --world-from-space.
  Rigid3d world_from_space;
  /// EyeViews.tracker_id of the views sent. --tracker-id.
  uint32_t tracker_id = 20;
  /// Throws std::invalid_argument naming the flag: space not "stage" or
  /// "local", world_from_space not a rotation (IsRotation) or not finite.
  void Check() const;
};

/// world_from_space from "x,y,z,qx,qy,qz,qw" (metres; a quaternion of any
/// non-zero length, normalized), as an XrPosef is written. Throws
/// std::invalid_argument naming `flag` for anything else.
Rigid3d RigidFromPoseText(const std::string& text, const std::string& flag);

/// Both eyes of one xrLocateViews as hullpipe's views: each view's pose
/// registered into the rig's world (world_from_space * the view's pose, in
/// OpenCV's eye axes: EyePoseFromXr), its fov as EyeFov; views[0] the left eye,
/// views[1] the right (XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO's order).
/// stamp_ns: when they hold (CLOCK_REALTIME ns). Throws std::invalid_argument
/// when `count` is not 2, when `flags` lacks XR_VIEW_STATE_POSITION_VALID_BIT or
/// XR_VIEW_STATE_ORIENTATION_VALID_BIT (the runtime lost tracking: no pose to
/// draw from), and for a pose not finite, a zero quaternion or a bad fov
/// (EyeFov::Check), naming the view.
EyeViewsSample EyeViewsFromXr(const XrView* views, uint32_t count, XrViewStateFlags flags,
                              const Rigid3d& world_from_space, int64_t stamp_ns, uint32_t tracker_id);

/// What a session that shows images needs of its graphics API (xr_display.h
/// gives EGL's): the instance extensions to enable (the session fails naming
/// the first the runtime does not offer), the API's requirements check, run
/// between xrGetSystem and xrCreateSession as OpenXR requires (it throws
/// XrError when the runtime cannot take the API's version), and the
/// XrGraphicsBinding* structure chained into XrSessionCreateInfo (it must
/// outlive the session's constructor).
struct XrGraphicsBinding {
  std::vector<std::string> extensions;
  std::function<void(XrInstance, XrSystemId)> check_requirements;
  const void* session_next = nullptr;
};

/// One frame of a running session, between XrEyeSession::BeginFrame and
/// EndFrame.
struct XrFrame {
  XrTime display_time = 0;             ///< The runtime's predicted display time.
  bool should_render = false;          ///< XrFrameState::shouldRender: layers would be shown.
  std::optional<EyeViewsSample> views;  ///< Both eyes located and converted, or none (see last_skip()).
};

/// The XrPosef of an eye in the reference space, from its pose in the rig's
/// world (OpenCV eye axes): world_from_space^-1 * world_from_eye, turned into
/// OpenXR's view axes (XrOrientationOf). EyeViewsFromXr's inverse for one
/// view: what a projection layer says an image was drawn from.
XrPosef XrPoseInSpace(const Rigid3d& world_from_space, const Rigid3d& world_from_eye);

/// What a session has done, counted.
struct XrSessionCounts {
  uint64_t frames = 0;       ///< Frames waited for while running.
  uint64_t located = 0;      ///< Of those, both views located and converted.
  uint64_t untracked = 0;    ///< Views the runtime marked invalid (tracking lost).
  uint64_t refused = 0;      ///< Views that did not convert (EyeViewsFromXr threw).
};

/// An OpenXR session that locates both eyes each frame: headless, or shown
/// through a graphics binding. Owns the instance, session and reference space
/// (destroyed in reverse order). Not thread-safe.
class XrEyeSession {
 public:
  /// Creates the instance (XR_MND_headless without `graphics`, else the
  /// binding's extensions; XR_KHR_convert_timespec_time when offered, to stamp
  /// views on hullpipe's clock), the HMD system, the session and the reference
  /// space. Throws XrError naming the call (no runtime, no headless or graphics
  /// extension, no HMD, no such space) and std::invalid_argument for bad
  /// options.
  explicit XrEyeSession(const XrClientOptions& options, const XrGraphicsBinding* graphics = nullptr);
  ~XrEyeSession();
  XrEyeSession(const XrEyeSession&) = delete;
  XrEyeSession& operator=(const XrEyeSession&) = delete;

  /// One frame's first half: the runtime's events (the session begun when
  /// READY, ended when STOPPING), then, while it runs, xrWaitFrame (blocks
  /// until the runtime's next frame), xrBeginFrame and both views located at
  /// its predicted display time. Returns the frame, its views stamped at that
  /// display time on CLOCK_REALTIME (without the timespec extension, when
  /// located) or absent (tracking lost, or a view that did not convert:
  /// counted, and the reason in last_skip()); nullopt when not running. Every
  /// frame it returns must be given to EndFrame (OpenXR pairs each
  /// xrBeginFrame with an xrEndFrame); a failed location is ended here, with no
  /// layers, and thrown as XrError, as is any other failed call.
  std::optional<XrFrame> BeginFrame();
  /// Ends `frame` showing `layers` (none: the headset shows nothing; pointers
  /// valid for the call). Throws XrError when xrEndFrame fails (a layer the
  /// runtime refuses: XR_ERROR_LAYER_INVALID, XR_ERROR_SWAPCHAIN_RECT_INVALID).
  void EndFrame(const XrFrame& frame, const std::vector<const XrCompositionLayerBaseHeader*>& layers);
  /// Asks the runtime to end the session (xrRequestExitSession); frames then
  /// run (BeginFrame, EndFrame) until exiting().
  void RequestExit();
  /// The runtime ended the session (EXITING or LOSS_PENDING) or the instance
  /// is being lost: nothing more comes.
  bool exiting() const { return exiting_; }
  /// True between xrBeginSession and xrEndSession.
  bool running() const { return running_; }
  /// XrInstanceProperties' runtime name and version ("Monado 21.0.0").
  const std::string& runtime() const { return runtime_; }
  const XrSessionCounts& counts() const { return counts_; }
  /// Why the last frame's views were not returned ("" if they were).
  const std::string& last_skip() const { return last_skip_; }
  XrInstance instance() const { return instance_; }
  XrSystemId system() const { return system_; }
  XrSession session() const { return session_; }
  /// The reference space the views are located in and layers are placed in.
  XrSpace space() const { return space_; }
  const XrClientOptions& options() const { return o_; }

 private:
  void PollEvents();
  int64_t RealtimeNsOf(XrTime t) const;
  XrClientOptions o_;
  XrInstance instance_ = XR_NULL_HANDLE;
  XrSystemId system_ = XR_NULL_SYSTEM_ID;
  XrSession session_ = XR_NULL_HANDLE;
  XrSpace space_ = XR_NULL_HANDLE;
  PFN_xrVoidFunction to_timespec_ = nullptr;  // xrConvertTimeToTimespecTimeKHR, if offered
  std::string runtime_;
  bool running_ = false, exiting_ = false;
  XrSessionCounts counts_;
  std::string last_skip_;
};

}  // namespace hullpipe::openxr
