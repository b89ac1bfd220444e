#include "hullpipe/gl/gl_texture.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

#include "gl_cameras.h"
#include "gl_upload.h"

namespace hullpipe::gl {
namespace {

// Per camera, beside its projection (kCameraBufferGlsl's Cam, scaled to its image):
// its centre and its visibility view (eye_from_world, pinhole intrinsics, size).
struct TexExtra {
  float centre[4];
  float vr[12];
  float vt[4];
  float vintr[4];
  float vsize[4];
};

std::string TextureCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 8, local_size_y = 8) in;\n") + kCameraBufferGlsl + R"(
struct Extra { vec4 centre; vec4 vr0, vr1, vr2; vec4 vt; vec4 vintr; vec4 vsize; };
layout(std430, binding = 2) readonly buffer Extras { Extra ex[]; };
layout(std430, binding = 3) buffer Missing { uint missing; };  // bit k: camera k sampled off its upload
layout(binding = 0) uniform usampler2DArray u_images;  // bytes B, G, R of pixel x: texels 3 x .. 3 x + 2
layout(binding = 1) uniform sampler2DArray u_vis;      // hull depth from each camera
layout(binding = 2) uniform sampler2DArray u_depth;    // the tile's eye-z depths (layer 0)
layout(rgba8ui, binding = 0) uniform writeonly uimage2D u_out;
uniform int u_ncam;
uniform int u_max;        // TextureOptions::max_cameras
uniform float u_power;    // TextureOptions::angle_power
uniform float u_bias;     // TextureOptions::visibility_bias_m
uniform int u_has_vis;
uniform vec4 u_view;
uniform vec2 u_origin;
uniform mat3 u_Rwe;
uniform vec3 u_O;
uniform ivec2 u_size;
const int MAXC = 32;

// Camera k's pixel (x, y): its B, G, R bytes, three texels side by side
// (LayerUploader::Packing::kChannels).
vec3 Pixel(int k, int x, int y) {
  return vec3(texelFetch(u_images, ivec3(3 * x, y, k), 0).r, texelFetch(u_images, ivec3(3 * x + 1, y, k), 0).r,
              texelFetch(u_images, ivec3(3 * x + 2, y, k), 0).r);
}

// Camera k's colour at uv, bilinear over texel centres. Only the camera's
// uploaded rectangle (cams[k].rect, [x0, x1) x [y0, y1)) holds this frameset's
// texels: a footprint reaching outside it is flagged in u_missing (the CPU then
// uploads that image whole and runs the pass again) and its colour is not used.
vec3 Bilinear(int k, vec2 uv) {
  vec2 sz = cams[k].p.zw;
  float x = clamp(uv.x - 0.5, 0.0, sz.x - 1.0), y = clamp(uv.y - 0.5, 0.0, sz.y - 1.0);
  int x0 = int(x), y0 = int(y);
  int x1 = min(x0 + 1, int(sz.x) - 1), y1 = min(y0 + 1, int(sz.y) - 1);
  vec4 r = cams[k].rect;
  if (!(float(x0) >= r.x && float(y0) >= r.y && float(x1) < r.z && float(y1) < r.w)) {
    atomicOr(missing, 1u << uint(k));
    return vec3(0.0);
  }
  float ax = x - float(x0), ay = y - float(y0);
  vec3 p00 = Pixel(k, x0, y0), p01 = Pixel(k, x1, y0), p10 = Pixel(k, x0, y1), p11 = Pixel(k, x1, y1);
  return (p00 * (1.0 - ax) + p01 * ax) * (1.0 - ay) + (p10 * (1.0 - ax) + p11 * ax) * ay;
}

bool Visible(int k, vec3 X) {
  vec3 p = vec3(dot(ex[k].vr0.xyz, X), dot(ex[k].vr1.xyz, X), dot(ex[k].vr2.xyz, X)) + ex[k].vt.xyz;
  if (!(p.z > 0.0)) return false;
  vec4 in_ = ex[k].vintr;
  float u = in_.x * p.x / p.z + in_.z, w = in_.y * p.y / p.z + in_.w;
  vec2 sz = ex[k].vsize.xy;
  if (!(u >= 0.0 && w >= 0.0 && u < sz.x && w < sz.y)) return false;
  int x = clamp(int(u), 0, int(sz.x) - 1), y = clamp(int(w), 0, int(sz.y) - 1);
  float d = texelFetch(u_vis, ivec3(x, y, k), 0).r;
  float footprint = p.z / in_.x;
  return isinf(d) || p.z <= d + u_bias + 2.0 * footprint;
}

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= u_size.x || px.y >= u_size.y) return;
  float d = texelFetch(u_depth, ivec3(px, 0), 0).r;
  if (isinf(d) || isnan(d)) { imageStore(u_out, px, uvec4(0u)); return; }
  vec2 uv = u_origin + vec2(px) + 0.5;
  vec3 ray = vec3((uv.x - u_view.z) / u_view.x, (uv.y - u_view.w) / u_view.y, 1.0);
  vec3 X = u_O + d * (u_Rwe * ray);
  vec3 to_eye = normalize(u_O - X);
  float w[MAXC];
  vec2 at[MAXC];  // where camera cam[i] sees X
  int cam[MAXC];
  bool seen[MAXC];
  int n = 0;
  bool any_seen = false;
  for (int k = 0; k < u_ncam; ++k) {
    float cosang = dot(to_eye, normalize(ex[k].centre.xyz - X));
    vec3 Xc = cams[k].a.xyz + vec3(dot(cams[k].m0.xyz, X), dot(cams[k].m1.xyz, X), dot(cams[k].m2.xyz, X));
    vec2 puv = CamPixel(k, Xc);
    if (puv.x < 0.0) continue;
    // Cameras facing the eye's side dominate; when none does the least oblique wins.
    w[n] = (cosang > 0.0 ? pow(cosang, u_power) : 0.0) + 1e-9 * (1.0 + cosang);
    at[n] = puv;
    cam[n] = k;
    seen[n] = u_has_vis == 0 || Visible(k, X);
    any_seen = any_seen || seen[n];
    ++n;
  }
  if (n == 0) { imageStore(u_out, px, uvec4(128u, 128u, 128u, 255u)); return; }
  vec3 sum = vec3(0.0);
  float wsum = 0.0;
  // The u_max heaviest of the cameras that see the point (all, if none does).
  for (int taken = 0; taken < u_max; ++taken) {
    int best = -1;
    for (int i = 0; i < n; ++i)
      if ((seen[i] || !any_seen) && w[i] >= 0.0 && (best < 0 || w[i] > w[best])) best = i;
    if (best < 0) break;
    sum += Bilinear(cam[best], at[best]) * w[best];
    wsum += w[best];
    w[best] = -1.0;
  }
  sum *= 1.0 / wsum;
  imageStore(u_out, px, uvec4(uvec3(clamp(roundEven(sum), 0.0, 255.0)), 255u));
}
)";
}

}  // namespace

GlTexture::GlTexture()
    : program_(BuildComputeProgram(TextureCs().c_str())),
      images_(std::make_unique<LayerUploader>(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, CV_8UC3,
                                              LayerUploader::Packing::kChannels)),
      visibility_(std::make_unique<LayerUploader>(GL_R32F, GL_RED, GL_FLOAT, CV_32FC1)),
      missing_(MakeBuffer()),
      cams_(MakeBuffer()),
      extra_(MakeBuffer()) {
  glNamedBufferStorage(missing_.get(), sizeof(GLuint), nullptr, GL_DYNAMIC_STORAGE_BIT);
  CheckGl("texture pass's flag buffer");
}

GlTexture::~GlTexture() = default;

void GlTexture::UploadImages(const std::vector<CameraImage>& images, const std::vector<cv::Rect>* rects) {
  if (images.size() > size_t(kMaxTextureCameras))
    throw std::invalid_argument("GlTexture: at most " + std::to_string(kMaxTextureCameras) + " images");
  if (rects && rects->size() != images.size())
    throw std::invalid_argument("GlTexture: " + std::to_string(rects->size()) + " rectangles for " +
                                std::to_string(images.size()) + " images");
  std::vector<cv::Mat> layers;
  for (const auto& im : images) layers.push_back(im.image);
  std::vector<cv::Rect> parts;
  for (size_t k = 0; k < layers.size(); ++k) {
    const cv::Rect whole(0, 0, layers[k].cols, layers[k].rows);
    parts.push_back(rects ? (*rects)[k] & whole : whole);
  }
  uploaded_ = images.size();
  kept_.clear();
  rects_.clear();
  uploaded_bytes_ = 0;
  if (layers.empty()) return;
  images_->Upload(layers, &parts);
  uploaded_bytes_ = images_->last_bytes();
  kept_ = std::move(layers);
  rects_ = std::move(parts);
}

std::vector<cv::Rect> GlTexture::ObjectImageRects(const VolumeQuery& q, const std::vector<CameraImage>& images) {
  std::vector<cv::Rect> out;
  for (size_t k = 0; k < images.size(); ++k) {
    const cv::Mat& img = images[k].image;
    const cv::Rect whole(0, 0, img.cols, img.rows);
    if (k >= q.size() || q.views()[k].camera.id != images[k].camera.id || q.views()[k].map.empty()) {
      out.push_back(whole);
      continue;
    }
    out.push_back(ImageRectAroundObjectPixels(q.object_rect(k), q.views()[k].map.size(), img.size()));
  }
  return out;
}

cv::Mat GlTexture::Texture(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                           const std::vector<CameraImage>& images, const TextureOptions& options,
                           const HullVisibility* vis) {
  if (vis && (vis->views.size() != images.size() || vis->depth.size() != images.size()))
    throw std::invalid_argument("GlTexture: visibility has " + std::to_string(vis->views.size()) +
                                " cameras, images " + std::to_string(images.size()));
  if (vis && !images.empty()) visibility_->Upload(vis->depth);
  return Run(depth, tile, view, images, options, vis ? &vis->views : nullptr, vis ? visibility_->texture() : 0, 0);
}

cv::Mat GlTexture::Texture(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                           const std::vector<CameraImage>& images, const TextureOptions& options,
                           const std::vector<NovelView>& visibility_views, GLuint visibility_texture,
                           GLuint depth_texture) {
  if (visibility_views.size() != images.size())
    throw std::invalid_argument("GlTexture: visibility has " + std::to_string(visibility_views.size()) +
                                " cameras, images " + std::to_string(images.size()));
  return Run(depth, tile, view, images, options, &visibility_views, visibility_texture, depth_texture);
}

cv::Mat GlTexture::Run(const cv::Mat& depth, const cv::Rect& tile, const NovelView& view,
                       const std::vector<CameraImage>& images, const TextureOptions& options,
                       const std::vector<NovelView>* vis_views, GLuint vis_texture, GLuint depth_texture) {
  CV_Assert(depth.type() == CV_32FC1 && depth.size() == tile.size());
  Dispatch(tile, view, images, options, vis_views, vis_texture, depth_texture, depth_texture ? nullptr : &depth);
  return ReadBack();
}

void GlTexture::Dispatch(const cv::Rect& tile, const NovelView& view, const std::vector<CameraImage>& images,
                         const TextureOptions& options, const std::vector<NovelView>* vis_views, GLuint vis_texture,
                         GLuint depth_texture, const cv::Mat* depth) {
  options.Check();
  view.Check();
  if (!depth_texture && !depth) throw std::invalid_argument("GlTexture: no depth tile (neither on the GPU nor given)");
  if (vis_views && vis_views->size() != images.size())
    throw std::invalid_argument("GlTexture: visibility has " + std::to_string(vis_views->size()) +
                                " cameras, images " + std::to_string(images.size()));
  const bool vis = vis_views != nullptr;
  if (images.size() != uploaded_)
    throw std::invalid_argument("GlTexture: " + std::to_string(images.size()) + " images, the last upload " +
                                std::to_string(uploaded_));
  if (options.max_cameras > kMaxTextureCameras)
    throw std::invalid_argument("GlTexture: max_cameras above " + std::to_string(kMaxTextureCameras));
  out_size_ = tile.size();
  dispatched_ = false;
  if (tile.area() == 0 || images.empty()) return;

  std::vector<GpuCamera> cams;
  std::vector<TexExtra> extra(images.size());
  for (size_t k = 0; k < images.size(); ++k) {
    const Camera c = ScaledCamera(images[k].camera, images[k].image.cols, images[k].image.rows);
    cams.push_back(PackCamera(c));
    TexExtra& e = extra[k];
    const Eigen::Vector3d C = c.Center();
    for (int i = 0; i < 3; ++i) e.centre[i] = float(C[i]);
    if (vis) {
      const NovelView& v = (*vis_views)[k];
      const Rigid3d ew = v.world_from_eye.Inverse();
      for (int r = 0; r < 3; ++r)
        for (int j = 0; j < 3; ++j) e.vr[4 * r + j] = float(ew.rotation(r, j));
      for (int i = 0; i < 3; ++i) e.vt[i] = float(ew.translation[i]);
      e.vintr[0] = float(v.fx), e.vintr[1] = float(v.fy), e.vintr[2] = float(v.cx), e.vintr[3] = float(v.cy);
      e.vsize[0] = float(v.width), e.vsize[1] = float(v.height);
    }
  }
  glNamedBufferData(extra_.get(), GLsizeiptr(extra.size() * sizeof(TexExtra)), extra.data(), GL_STREAM_DRAW);

  if (tile.width > w_ || tile.height > h_) {
    w_ = std::max(w_, tile.width);
    h_ = std::max(h_, tile.height);
    depth_ = MakeTexture(GL_TEXTURE_2D_ARRAY);
    glTextureStorage3D(depth_.get(), 1, GL_R32F, w_, h_, 1);
    glTextureParameteri(depth_.get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(depth_.get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    out_ = MakeTexture(GL_TEXTURE_2D);
    glTextureStorage2D(out_.get(), 1, GL_RGBA8UI, w_, h_);
  }
  if (!depth_texture) {
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(depth->step[0] / sizeof(float)));
    glTextureSubImage3D(depth_.get(), 0, 0, 0, 0, tile.width, tile.height, 1, GL_RED, GL_FLOAT, depth->data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  }

  for (size_t k = 0; k < cams.size(); ++k) {
    const cv::Rect& r = rects_[k];
    cams[k].rect[0] = float(r.x), cams[k].rect[1] = float(r.y);
    cams[k].rect[2] = float(r.br().x), cams[k].rect[3] = float(r.br().y);
  }
  glNamedBufferData(cams_.get(), GLsizeiptr(cams.size() * sizeof(GpuCamera)), cams.data(), GL_STREAM_DRAW);
  pending_ = Pending{tile, view, options, vis, vis ? vis_texture : 0, depth_texture ? depth_texture : depth_.get()};
  Launch();
}

void GlTexture::Launch() {
  const Pending& d = pending_;
  const GLuint zero = 0;
  glNamedBufferSubData(missing_.get(), 0, sizeof zero, &zero);
  const GLuint p = program_.get();
  glUseProgram(p);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, cams_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, extra_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, missing_.get());
  glBindTextureUnit(0, images_->texture());
  glBindTextureUnit(1, d.vis ? d.vis_texture : images_->texture());
  glBindTextureUnit(2, d.depth_texture);
  glBindImageTexture(0, out_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8UI);
  glUniform1i(glGetUniformLocation(p, "u_ncam"), GLint(uploaded_));
  glUniform1i(glGetUniformLocation(p, "u_max"), d.options.max_cameras);
  glUniform1f(glGetUniformLocation(p, "u_power"), float(d.options.angle_power));
  glUniform1f(glGetUniformLocation(p, "u_bias"), float(d.options.visibility_bias_m));
  glUniform1i(glGetUniformLocation(p, "u_has_vis"), d.vis ? 1 : 0);
  SetViewUniforms(p, d.view, d.tile.tl());
  glUniform2i(glGetUniformLocation(p, "u_size"), d.tile.width, d.tile.height);
  glUniform1i(glGetUniformLocation(p, "u_images"), 0);
  glUniform1i(glGetUniformLocation(p, "u_vis"), 1);
  glUniform1i(glGetUniformLocation(p, "u_depth"), 2);
  glDispatchCompute(GLuint((d.tile.width + 7) / 8), GLuint((d.tile.height + 7) / 8), 1);
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  CheckGl("texture hull");
  dispatched_ = true;
}

cv::Mat GlTexture::ReadBack() {
  if (!dispatched_) return cv::Mat(out_size_, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat out = ReadOut();
  GLuint missing = 0;
  glGetNamedBufferSubData(missing_.get(), 0, sizeof missing, &missing);
  CheckGl("texture hull's flags");
  if (missing == 0) return out;
  // Some camera was sampled outside the part of its image on the GPU (a point
  // the given depth puts off its object pixels, or rounding at its view's
  // edge): those images go up whole and the pass runs again.
  std::vector<cv::Rect> parts(kept_.size());
  for (size_t k = 0; k < kept_.size(); ++k)
    if (missing & (1u << k)) {
      parts[k] = rects_[k] = cv::Rect(0, 0, kept_[k].cols, kept_[k].rows);
      ++refetched_;
      const GLintptr at = GLintptr(k * sizeof(GpuCamera) + offsetof(GpuCamera, rect));
      const float rect[4] = {0, 0, float(kept_[k].cols), float(kept_[k].rows)};
      glNamedBufferSubData(cams_.get(), at, sizeof rect, rect);
    }
  images_->Upload(kept_, &parts);
  Launch();
  out = ReadOut();
  glGetNamedBufferSubData(missing_.get(), 0, sizeof missing, &missing);
  if (missing != 0) throw std::logic_error("GlTexture: a whole image's sample flagged outside it");
  return out;
}

cv::Mat GlTexture::ReadOut() const {
  cv::Mat out(out_size_, CV_8UC3, cv::Scalar(0, 0, 0));
  cv::Mat bgra(out_size_, CV_8UC4);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureSubImage(out_.get(), 0, 0, 0, 0, out_size_.width, out_size_.height, 1, GL_RGBA_INTEGER,
                       GL_UNSIGNED_BYTE, GLsizei(bgra.total() * 4), bgra.data);
  CheckGl("texture hull read-back");
  cv::cvtColor(bgra, out, cv::COLOR_BGRA2BGR);
  return out;
}

}  // namespace hullpipe::gl
