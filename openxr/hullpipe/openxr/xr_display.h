// Showing render_node's composited eyes in a headset through an OpenXR runtime
// (docs/hmd.md, "Display"): hullpipe's headless EGL context bound to the
// session (XR_MNDX_egl_enable, with XR_KHR_opengl_enable's requirements call
// and swapchain images), one swapchain per eye, and each frame one projection
// layer whose views carry the image last paired (eye_images.h) with the pose
// and field of view it was drawn for, in the session's reference space. The
// runtime reprojects each image from that pose to the eye's pose at display
// time.
//
// Images: the composited BGR image (rows top first, OpenCV's) is uploaded as
// RGBA with its rows reversed, a GL texture's first row being its bottom
// (OpenXR's OpenGL swapchain images keep GL's origin). The swapchain format is
// GL_SRGB8_ALPHA8 where the runtime offers it (the image's bytes are
// sRGB-encoded, as a JPEG's are), else GL_RGBA8.
#pragma once

#include <openxr/openxr.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "hullpipe/gl/egl_context.h"
#include "hullpipe/openxr/eye_images.h"
#include "hullpipe/openxr/xr_eyes.h"

namespace hullpipe::openxr {

/// GL_SRGB8_ALPHA8 and GL_RGBA8 as OpenXR's OpenGL swapchains name formats.
constexpr int64_t kGlSrgb8Alpha8 = 0x8C43, kGlRgba8 = 0x8058;

/// The swapchain format for the composited images among the runtime's
/// `offered` (xrEnumerateSwapchainFormats): GL_SRGB8_ALPHA8, else GL_RGBA8.
/// Throws XrError (XR_ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED) listing the offered
/// formats when neither is.
int64_t ChooseSwapchainFormat(const std::vector<int64_t>& offered);

/// The graphics binding of hullpipe's EGL context (gl/egl_context.h): the
/// extensions XR_MNDX_egl_enable and XR_KHR_opengl_enable, the requirements
/// check (xrGetOpenGLGraphicsRequirementsKHR: the context's GL 4.5 within the
/// runtime's supported versions, else XrError naming them), and the
/// XrGraphicsBindingEGLMNDX. The context must outlive the session.
class XrEglBinding {
 public:
  explicit XrEglBinding(const gl::EglContext& context);
  ~XrEglBinding();
  XrEglBinding(const XrEglBinding&) = delete;
  XrEglBinding& operator=(const XrEglBinding&) = delete;
  const XrGraphicsBinding& graphics() const { return graphics_; }

 private:
  struct Binding;
  std::unique_ptr<Binding> binding_;
  XrGraphicsBinding graphics_;
};

/// What XrEyeDisplay has done, counted.
struct XrDisplayCounts {
  uint64_t pairs_shown = 0;  ///< Pairs uploaded.
};

/// Both eyes' swapchains and the projection layer showing them. The GL context
/// bound to the session must be current on the calling thread. Not
/// thread-safe; not copyable or movable (the layer points into it).
class XrEyeDisplay {
 public:
  /// Picks the format (ChooseSwapchainFormat) and reads the largest image
  /// each eye takes (xrEnumerateViewConfigurationViews). Throws XrError.
  explicit XrEyeDisplay(const XrEyeSession& session);
  ~XrEyeDisplay();
  XrEyeDisplay(const XrEyeDisplay&) = delete;
  XrEyeDisplay& operator=(const XrEyeDisplay&) = delete;

  /// Uploads the pair, each image into its eye's swapchain (acquire, wait,
  /// upload, release), the swapchains made, or made again, at the images'
  /// size; the layer then shows it. Throws std::invalid_argument for an
  /// empty image or one of another type than CV_8UC3, XrError for a failed
  /// call (a wait that times out twice in 100 ms: XR_TIMEOUT_EXPIRED).
  void Show(const std::array<EyeImage, 2>& pair);
  /// The projection layer of the pair last shown, in the session's reference
  /// space (the pair's poses by XrPoseInSpace, fovs by FovOfView, each image
  /// whole), or nullptr before any pair. Valid until the next Show.
  const XrCompositionLayerBaseHeader* Layer() const;
  int64_t format() const { return format_; }
  /// The largest image both eyes take, pixels (the smaller of the two views'
  /// maxImageRectWidth and maxImageRectHeight): a composite beyond it is
  /// refused before it is decoded.
  int max_width() const { return max_width_; }
  int max_height() const { return max_height_; }
  const XrDisplayCounts& counts() const { return counts_; }

 private:
  struct Swapchains;
  const XrEyeSession& session_;
  int64_t format_ = 0;
  int max_width_ = 0, max_height_ = 0;
  std::unique_ptr<Swapchains> swapchains_;
  XrDisplayCounts counts_;
};

}  // namespace hullpipe::openxr
