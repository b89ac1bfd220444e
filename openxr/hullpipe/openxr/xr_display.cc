#include "hullpipe/openxr/xr_display.h"

#define GL_GLEXT_PROTOTYPES
#include <EGL/egl.h>
#include <GL/glcorearb.h>

#define XR_USE_PLATFORM_EGL
#define XR_USE_GRAPHICS_API_OPENGL
#include <openxr/openxr_platform.h>

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace hullpipe::openxr {
namespace {

std::string FormatList(const std::vector<int64_t>& formats) {
  std::string out;
  char hex[24];
  for (int64_t f : formats) {
    std::snprintf(hex, sizeof hex, "0x%llx", static_cast<unsigned long long>(f));
    out += (out.empty() ? "" : ", ") + std::string(hex);
  }
  return out.empty() ? "none" : out;
}

// The runtime's xrGetOpenGLGraphicsRequirementsKHR, which OpenXR requires
// before xrCreateSession with an OpenGL binding; the context is GL 4.5 core.
void CheckGlRequirements(XrInstance instance, XrSystemId system) {
  PFN_xrVoidFunction fn = nullptr;
  CheckXr(xrGetInstanceProcAddr(instance, "xrGetOpenGLGraphicsRequirementsKHR", &fn),
        "xrGetInstanceProcAddr(xrGetOpenGLGraphicsRequirementsKHR)");
  XrGraphicsRequirementsOpenGLKHR req{XR_TYPE_GRAPHICS_REQUIREMENTS_OPENGL_KHR};
  CheckXr(reinterpret_cast<PFN_xrGetOpenGLGraphicsRequirementsKHR>(fn)(instance, system, &req),
        "xrGetOpenGLGraphicsRequirementsKHR");
  const XrVersion ours = XR_MAKE_VERSION(4, 5, 0);
  if (ours < req.minApiVersionSupported)
    throw XrError("xrGetOpenGLGraphicsRequirementsKHR", XR_ERROR_GRAPHICS_DEVICE_INVALID,
                  "the runtime needs OpenGL " + std::to_string(XR_VERSION_MAJOR(req.minApiVersionSupported)) + "." +
                      std::to_string(XR_VERSION_MINOR(req.minApiVersionSupported)) +
                      " or later; hullpipe's context is 4.5");
}

// A swapchain handle, destroyed with the object.
class Swapchain {
 public:
  Swapchain() = default;
  Swapchain(XrSession session, int width, int height, int64_t format) {
    XrSwapchainCreateInfo ci{XR_TYPE_SWAPCHAIN_CREATE_INFO};
    ci.usageFlags = XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT | XR_SWAPCHAIN_USAGE_TRANSFER_DST_BIT;
    ci.format = format;
    ci.sampleCount = 1;
    ci.width = uint32_t(width);
    ci.height = uint32_t(height);
    ci.faceCount = 1;
    ci.arraySize = 1;
    ci.mipCount = 1;
    CheckXr(xrCreateSwapchain(session, &ci, &handle_), "xrCreateSwapchain");
    uint32_t n = 0;
    CheckXr(xrEnumerateSwapchainImages(handle_, 0, &n, nullptr), "xrEnumerateSwapchainImages");
    std::vector<XrSwapchainImageOpenGLKHR> images(n, XrSwapchainImageOpenGLKHR{XR_TYPE_SWAPCHAIN_IMAGE_OPENGL_KHR});
    CheckXr(xrEnumerateSwapchainImages(handle_, n, &n,
                                     reinterpret_cast<XrSwapchainImageBaseHeader*>(images.data())),
          "xrEnumerateSwapchainImages");
    for (uint32_t i = 0; i < n && i < images.size(); ++i) textures_.push_back(images[i].image);
    width_ = width;
    height_ = height;
  }
  ~Swapchain() {
    if (handle_ != XR_NULL_HANDLE) xrDestroySwapchain(handle_);
  }
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // One image: acquire, wait, upload `rgba_bottom_first`, release.
  void Upload(const cv::Mat& rgba_bottom_first) {
    uint32_t index = 0;
    XrSwapchainImageAcquireInfo ai{XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO};
    CheckXr(xrAcquireSwapchainImage(handle_, &ai, &index), "xrAcquireSwapchainImage");
    XrSwapchainImageWaitInfo wi{XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO};
    wi.timeout = 50'000'000;  // 50 ms, twice: the runtime holds an image for at most a frame
    XrResult waited = xrWaitSwapchainImage(handle_, &wi);
    if (waited == XR_TIMEOUT_EXPIRED) waited = xrWaitSwapchainImage(handle_, &wi);
    CheckXr(waited, "xrWaitSwapchainImage");
    if (waited == XR_TIMEOUT_EXPIRED)
      throw XrError("xrWaitSwapchainImage", waited, "the runtime kept the swapchain's image for 100 ms");
    if (index >= textures_.size())
      throw XrError("xrAcquireSwapchainImage", XR_ERROR_RUNTIME_FAILURE,
                    "image " + std::to_string(index) + " of " + std::to_string(textures_.size()));
    glBindTexture(GL_TEXTURE_2D, textures_[index]);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, int(rgba_bottom_first.step / 4));
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba_bottom_first.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glBindTexture(GL_TEXTURE_2D, 0);
    glFlush();  // the upload is submitted before the runtime may read the image
    XrSwapchainImageReleaseInfo ri{XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO};
    CheckXr(xrReleaseSwapchainImage(handle_, &ri), "xrReleaseSwapchainImage");
  }
  XrSwapchain handle() const { return handle_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  XrSwapchain handle_ = XR_NULL_HANDLE;
  std::vector<uint32_t> textures_;
  int width_ = 0, height_ = 0;
};

}  // namespace

int64_t ChooseSwapchainFormat(const std::vector<int64_t>& offered) {
  for (int64_t want : {kGlSrgb8Alpha8, kGlRgba8})
    for (int64_t f : offered)
      if (f == want) return f;
  throw XrError("xrEnumerateSwapchainFormats", XR_ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED,
                "hullpipe uploads GL_SRGB8_ALPHA8 (0x8c43) or GL_RGBA8 (0x8058); the runtime offers " +
                    FormatList(offered));
}

struct XrEglBinding::Binding {
  XrGraphicsBindingEGLMNDX egl{XR_TYPE_GRAPHICS_BINDING_EGL_MNDX};
};

XrEglBinding::XrEglBinding(const gl::EglContext& context) : binding_(std::make_unique<Binding>()) {
  binding_->egl.getProcAddress = eglGetProcAddress;
  binding_->egl.display = context.display();
  binding_->egl.context = context.context();
  // The context's own config (EGL_NO_CONFIG_KHR for a context made without one).
  EGLint id = 0, n = 0;
  EGLConfig config = nullptr;
  if (eglQueryContext(context.display(), context.context(), EGL_CONFIG_ID, &id) && id != 0) {
    const EGLint attribs[] = {EGL_CONFIG_ID, id, EGL_NONE};
    if (!(eglChooseConfig(context.display(), attribs, &config, 1, &n) && n == 1)) config = nullptr;
  }
  binding_->egl.config = config;
  graphics_.extensions = {XR_MNDX_EGL_ENABLE_EXTENSION_NAME, XR_KHR_OPENGL_ENABLE_EXTENSION_NAME};
  graphics_.check_requirements = CheckGlRequirements;
  graphics_.session_next = &binding_->egl;
}

XrEglBinding::~XrEglBinding() = default;

struct XrEyeDisplay::Swapchains {
  std::array<Swapchain, 2> eye;
  XrCompositionLayerProjection layer{XR_TYPE_COMPOSITION_LAYER_PROJECTION};
  std::array<XrCompositionLayerProjectionView, 2> views{
      XrCompositionLayerProjectionView{XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW},
      XrCompositionLayerProjectionView{XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW}};
  bool shown = false;
  Swapchains(XrSession session, int width, int height, int64_t format)
      : eye{Swapchain(session, width, height, format), Swapchain(session, width, height, format)} {}
};

XrEyeDisplay::XrEyeDisplay(const XrEyeSession& session) : session_(session) {
  uint32_t n = 0;
  CheckXr(xrEnumerateSwapchainFormats(session.session(), 0, &n, nullptr), "xrEnumerateSwapchainFormats");
  std::vector<int64_t> formats(n);
  CheckXr(xrEnumerateSwapchainFormats(session.session(), n, &n, formats.data()), "xrEnumerateSwapchainFormats");
  formats.resize(std::min<size_t>(n, formats.size()));
  format_ = ChooseSwapchainFormat(formats);
  std::array<XrViewConfigurationView, 2> views{XrViewConfigurationView{XR_TYPE_VIEW_CONFIGURATION_VIEW},
                                               XrViewConfigurationView{XR_TYPE_VIEW_CONFIGURATION_VIEW}};
  CheckXr(xrEnumerateViewConfigurationViews(session.instance(), session.system(),
                                            XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO, 2, &n, views.data()),
          "xrEnumerateViewConfigurationViews");
  max_width_ = int(std::min(views[0].maxImageRectWidth, views[1].maxImageRectWidth));
  max_height_ = int(std::min(views[0].maxImageRectHeight, views[1].maxImageRectHeight));
}

XrEyeDisplay::~XrEyeDisplay() = default;

void XrEyeDisplay::Show(const std::array<EyeImage, 2>& pair) {
  for (const EyeImage& e : pair)
    if (e.bgr.empty() || e.bgr.type() != CV_8UC3)
      throw std::invalid_argument("an eye's composited image must be BGR, 8 bits a channel, not empty");
  const int w = pair[0].bgr.cols, h = pair[0].bgr.rows;
  if (pair[1].bgr.cols != w || pair[1].bgr.rows != h)
    throw std::invalid_argument("the eyes' composited images differ in size");
  if (!swapchains_ || swapchains_->eye[0].width() != w || swapchains_->eye[0].height() != h) {
    swapchains_.reset();  // the old ones first: a runtime may cap how many exist
    swapchains_ = std::make_unique<Swapchains>(session_.session(), w, h, format_);
  }
  Swapchains& s = *swapchains_;
  cv::Mat rgba;
  for (int k = 0; k < 2; ++k) {
    cv::cvtColor(pair[k].bgr, rgba, cv::COLOR_BGR2RGBA);
    cv::flip(rgba, rgba, 0);  // a GL texture's first row is its bottom
    s.eye[k].Upload(rgba);
    XrCompositionLayerProjectionView& v = s.views[k];
    v.pose = XrPoseInSpace(session_.options().world_from_space, pair[k].view.world_from_eye);
    const EyeFov fov = FovOfView(pair[k].view);
    v.fov = XrFovf{float(fov.left), float(fov.right), float(fov.up), float(fov.down)};
    v.subImage.swapchain = s.eye[k].handle();
    v.subImage.imageRect = XrRect2Di{{0, 0}, {w, h}};
    v.subImage.imageArrayIndex = 0;
  }
  s.layer.space = session_.space();
  s.layer.viewCount = 2;
  s.layer.views = s.views.data();
  s.shown = true;
  ++counts_.pairs_shown;
}

const XrCompositionLayerBaseHeader* XrEyeDisplay::Layer() const {
  if (!swapchains_ || !swapchains_->shown) return nullptr;
  return reinterpret_cast<const XrCompositionLayerBaseHeader*>(&swapchains_->layer);
}

}  // namespace hullpipe::openxr
