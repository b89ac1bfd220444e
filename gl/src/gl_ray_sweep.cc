#include "hullpipe/gl/gl_ray_sweep.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>

#include "hullpipe/geometry/conventions.h"
#include "gl_cameras.h"
#include "gl_upload.h"

namespace hullpipe::gl {
namespace {

// What both passes share: the view's rays, the planes, the hull box clip and the
// volume query of a point on the current ray (PlaneSweepCpu's RayQuery).
const char* kRayGlsl = R"(
layout(std430, binding = 1) readonly buffer Planes { float planes[]; };
layout(binding = 0) uniform usampler2DArray u_maps;
uniform int u_ncam;
uniform int u_unknown;   // 1: a camera that cannot see a point does not vote (OutOfView::kUnknown)
uniform int u_required;  // cameras that must see an inside point
uniform int u_nplanes;
uniform int u_refine;    // bisections (0: the paper's plane depth)
uniform vec4 u_view;     // fx fy cx cy of the novel view
uniform vec2 u_origin;   // view pixel of the pass image's (0, 0)
uniform mat3 u_Rwe;      // world_from_eye rotation
uniform vec3 u_O;        // eye centre, world metres
uniform vec3 u_bmin;     // hull box, world metres
uniform vec3 u_bmax;
const float INF = uintBitsToFloat(0x7f800000u);

vec3 g_ray;  // eye ray of the current pixel (z = 1)

// 0 background, 1 object, 2 unseen: camera c's vote on the ray's point at eye depth d.
int VoteAt(int c, float d) {
  precise vec3 B = vec3(dot(cams[c].m0.xyz, g_ray), dot(cams[c].m1.xyz, g_ray), dot(cams[c].m2.xyz, g_ray));
  precise vec3 X = cams[c].a.xyz + d * B;
  vec2 uv = CamPixel(c, X);
  if (uv.x < 0.0) return 2;
  return texelFetch(u_maps, ivec3(int(uv.x), int(uv.y), c), 0).r != 0u ? 1 : 0;
}

// Inside the hull at eye depth d? With want_near, *near is set when exactly one
// camera vetoes (the stencil count was n - 1).
bool InsideAt(float d, bool want_near, out bool near) {
  near = false;
  int object = 0, unseen = 0, veto = 0;
  for (int c = 0; c < u_ncam; ++c) {
    int v = VoteAt(c, d);
    if (v == 1) {
      ++object;
    } else if (v == 0 || u_unknown == 0) {
      ++veto;
      if (!want_near || veto > 1) break;
    } else {
      ++unseen;
    }
  }
  if (veto > 0) {
    near = want_near && veto == 1;
    return false;
  }
  return (unseen == 0 || u_unknown != 0) && object >= u_required;
}

float Bisect(float lo, float hi, int iterations) {
  bool unused;
  for (int it = 0; it < iterations; ++it) {
    float mid = 0.5 * (lo + hi);
    if (InsideAt(mid, false, unused)) hi = mid; else lo = mid;
  }
  return hi;
}

int LowerBound(float x) {
  int lo = 0, hi = u_nplanes;
  while (lo < hi) {
    int m = (lo + hi) / 2;
    if (planes[m] < x) lo = m + 1; else hi = m;
  }
  return lo;
}

float SpacingAt(float d) {
  if (u_nplanes < 2) return 0.0;
  int k = clamp(LowerBound(d), 1, u_nplanes - 1);
  return planes[k] - planes[k - 1];
}

// Aims at pass pixel px; the ray's part [s0, s1] in the hull box (false: misses).
bool Aim(ivec2 px, out float s0, out float s1) {
  vec2 uv = u_origin + vec2(px) + 0.5;
  g_ray = vec3((uv.x - u_view.z) / u_view.x, (uv.y - u_view.w) / u_view.y, 1.0);
  vec3 D = u_Rwe * g_ray;
  float lo = planes[0], hi = planes[u_nplanes - 1];
  s0 = lo;
  s1 = hi;
  for (int a = 0; a < 3; ++a) {
    if (abs(D[a]) < 1e-30) {
      if (u_O[a] < u_bmin[a] || u_O[a] > u_bmax[a]) return false;
      continue;
    }
    float t0 = (u_bmin[a] - u_O[a]) / D[a], t1 = (u_bmax[a] - u_O[a]) / D[a];
    if (t0 > t1) { float t = t0; t0 = t1; t1 = t; }
    lo = max(lo, t0);
    hi = min(hi, t1);
    if (lo > hi) return false;
  }
  s0 = lo;
  s1 = hi;
  return true;
}
)";

std::string MarchCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 8, local_size_y = 8) in;\n") + kCameraBufferGlsl +
         kRayGlsl + R"(
layout(r32f, binding = 0) uniform writeonly image2D u_out;
uniform ivec2 u_size;
void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= u_size.x || px.y >= u_size.y) return;
  float result = INF;
  float s0, s1;
  if (Aim(px, s0, s1)) {
    bool want = u_refine > 0;
    int near_k[8];
    int n_near = 0, hit = -1;
    for (int k = LowerBound(s0); k < u_nplanes && planes[k] <= s1; ++k) {
      bool near;
      if (InsideAt(planes[k], want, near)) { hit = k; break; }
      if (near && n_near < 8) near_k[n_near++] = k;
    }
    bool done = false;
    // Scan around each near miss, front to back, at 1/16 of its two gaps.
    for (int m = 0; m < n_near && !done; ++m) {
      int k = near_k[m];
      float a = max(s0, k > 0 ? planes[k - 1] : planes[k]);
      float b = min(s1, k + 1 < u_nplanes ? planes[k + 1] : planes[k]);
      float step = (b - a) / 16.0;
      if (!(step > 0.0)) continue;
      float prev = a;
      for (int i = 1; i < 16; ++i) {
        float t = a + float(i) * step;
        if (!(t < b)) break;
        bool unused;
        if (InsideAt(t, false, unused)) { result = Bisect(prev, t, u_refine); done = true; break; }
        prev = t;
      }
    }
    if (!done && hit >= 0)
      result = want && hit > 0 ? Bisect(max(planes[hit - 1], s0), planes[hit], u_refine) : planes[hit];
  }
  imageStore(u_out, px, vec4(result, 0.0, 0.0, 0.0));
}
)";
}

// The silhouette pass of the refinement (plane_sweep.cc, RefineEdges).
std::string EdgesCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 8, local_size_y = 8) in;\n") + kCameraBufferGlsl +
         kRayGlsl + R"(
layout(r32f, binding = 0) uniform readonly image2D u_swept;  // the march over the region
layout(r32f, binding = 1) uniform writeonly image2D u_out;   // the tile
uniform ivec2 u_region;  // region size
uniform ivec2 u_inner;   // tile origin in the region
uniform ivec2 u_size;    // tile size
void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= u_size.x || px.y >= u_size.y) return;
  ivec2 q = u_inner + px;
  float dp = imageLoad(u_swept, q).r;
  vec2 win[4];
  int nw = 0;
  const ivec2 nb[4] = ivec2[4](ivec2(0, -1), ivec2(0, 1), ivec2(-1, 0), ivec2(1, 0));
  for (int i = 0; i < 4; ++i) {
    ivec2 o = q + nb[i];
    if (o.x < 0 || o.y < 0 || o.x >= u_region.x || o.y >= u_region.y) continue;
    float dq = imageLoad(u_swept, o).r;
    if (isinf(dq) || isnan(dq)) continue;
    float sp = SpacingAt(dq);
    if (!isinf(dp) && dq >= dp - 1.5 * sp) continue;
    win[nw++] = vec2(dq - 2.0 * sp, dq + 2.0 * sp);
  }
  float best = dp;
  float s0, s1;
  if (nw > 0 && Aim(q, s0, s1)) {
    // Sort the windows (by start, then end) as the CPU does.
    for (int i = 1; i < nw; ++i)
      for (int j = i; j > 0 && (win[j].x < win[j - 1].x || (win[j].x == win[j - 1].x && win[j].y < win[j - 1].y)); --j) {
        vec2 t = win[j]; win[j] = win[j - 1]; win[j - 1] = t;
      }
    float limit = isinf(dp) ? s1 : min(dp, s1);
    for (int w = 0; w < nw; ++w) {
      float a = max(max(win[w].x, s0), planes[0]), b = min(win[w].y, limit);
      if (!(b > a) || a >= best) continue;
      float step = SpacingAt(a) / 8.0;
      if (!(step > 0.0)) continue;
      float prev = a;
      for (int i = 0; i < 256; ++i) {
        float t = a + float(i) * step;
        if (!(t <= b && t < best)) break;
        bool unused;
        if (InsideAt(t, false, unused)) {
          if (i == 0) {
            // Inside at the window's start: the entry lies in front, after the
            // last plane before it or the box entry.
            int k = LowerBound(a);
            prev = max(s0, k == 0 ? s0 : planes[k - 1]);
            if (!(prev < a)) { best = a; break; }
          }
          best = Bisect(prev, t, u_refine);
          break;
        }
        prev = t;
      }
    }
  }
  imageStore(u_out, px, vec4(best < dp || (isinf(dp) && !isinf(best)) ? best : dp, 0.0, 0.0, 0.0));
}
)";
}

void SetRayUniforms(GLuint p, const VolumeQuery& q, const NovelView& view, const cv::Rect& region, int nplanes,
                    int refine) {
  glUseProgram(p);
  glUniform1i(glGetUniformLocation(p, "u_ncam"), GLint(q.size()));
  glUniform1i(glGetUniformLocation(p, "u_unknown"), q.options().out_of_view == OutOfView::kUnknown ? 1 : 0);
  glUniform1i(glGetUniformLocation(p, "u_required"), GLint(q.required_seen()));
  glUniform1i(glGetUniformLocation(p, "u_nplanes"), nplanes);
  glUniform1i(glGetUniformLocation(p, "u_refine"), refine);
  SetViewUniforms(p, view, region.tl(), &q.hull_box());
  glUniform1i(glGetUniformLocation(p, "u_maps"), 0);
}

GLuint Groups(int n) { return GLuint((n + 7) / 8); }

}  // namespace

GlRaySweep::GlRaySweep()
    : march_(BuildComputeProgram(MarchCs().c_str())),
      edges_(BuildComputeProgram(EdgesCs().c_str())),
      maps_(std::make_unique<LayerUploader>(GL_R8UI, GL_RED_INTEGER, GL_UNSIGNED_BYTE, CV_8UC1)),
      cams_(MakeBuffer()),
      planes_(MakeBuffer()) {}

GlRaySweep::~GlRaySweep() = default;

void GlRaySweep::Upload(const VolumeQuery& q) {
  std::vector<cv::Mat> maps;
  for (const auto& v : q.views()) maps.push_back(v.map);
  maps_->Upload(maps);
  uploaded_cameras_ = q.size();
}

void GlRaySweep::EnsureImages(int w, int h) {
  if (w <= image_w_ && h <= image_h_) return;
  image_w_ = std::max(w, image_w_);
  image_h_ = std::max(h, image_h_);
  for (Texture* t : {&swept_, &refined_}) {
    *t = MakeTexture(GL_TEXTURE_2D);
    glTextureStorage2D(t->get(), 1, GL_R32F, image_w_, image_h_);
  }
  CheckGl("sweep images");
}

cv::Mat GlRaySweep::Sweep(const VolumeQuery& q, const NovelView& view, const std::vector<double>& depths,
                          const cv::Rect& tile, int refine) {
  view.Check();
  if (refine < 0) throw std::invalid_argument("GlRaySweep: refine iterations must be >= 0");
  if (q.size() != uploaded_cameras_)
    throw std::invalid_argument("GlRaySweep: the query has " + std::to_string(q.size()) +
                                " cameras, the last Upload " + std::to_string(uploaded_cameras_));
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(kNoDepth));
  if (depths.empty() || tile.area() == 0 || q.hull_box().empty()) return out;
  // With refinement the march covers the tile and a one-pixel margin in the view,
  // so the silhouette pass sees the neighbours a whole-view render has.
  const cv::Rect region = refine > 0 ? cv::Rect(tile.x - 1, tile.y - 1, tile.width + 2, tile.height + 2) &
                                           cv::Rect(0, 0, view.width, view.height)
                                     : tile;
  EnsureImages(region.width, region.height);

  std::vector<GpuCamera> cams;
  const Eigen::Vector3d O = view.world_from_eye.translation;
  for (size_t c = 0; c < q.size(); ++c) {
    const Rigid3d& cw = q.views()[c].camera.cam_from_world;
    cams.push_back(PackCamera(q.fast()[c], cw.rotation * view.world_from_eye.rotation, cw * O));
  }
  const std::vector<float> planes(depths.begin(), depths.end());
  glNamedBufferData(cams_.get(), GLsizeiptr(cams.size() * sizeof(GpuCamera)), cams.data(), GL_STREAM_DRAW);
  glNamedBufferData(planes_.get(), GLsizeiptr(planes.size() * sizeof(float)), planes.data(), GL_STREAM_DRAW);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, cams_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, planes_.get());
  glBindTextureUnit(0, maps_->texture());

  SetRayUniforms(march_.get(), q, view, region, int(planes.size()), refine);
  glUniform2i(glGetUniformLocation(march_.get(), "u_size"), region.width, region.height);
  glBindImageTexture(0, swept_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
  glDispatchCompute(Groups(region.width), Groups(region.height), 1);
  GLuint result = swept_.get();
  if (refine > 0) {
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
    SetRayUniforms(edges_.get(), q, view, region, int(planes.size()), refine);
    glUniform2i(glGetUniformLocation(edges_.get(), "u_region"), region.width, region.height);
    glUniform2i(glGetUniformLocation(edges_.get(), "u_inner"), tile.x - region.x, tile.y - region.y);
    glUniform2i(glGetUniformLocation(edges_.get(), "u_size"), tile.width, tile.height);
    glBindImageTexture(0, swept_.get(), 0, GL_FALSE, 0, GL_READ_ONLY, GL_R32F);
    glBindImageTexture(1, refined_.get(), 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_R32F);
    glDispatchCompute(Groups(tile.width), Groups(tile.height), 1);
    result = refined_.get();
  }
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureSubImage(result, 0, 0, 0, 0, tile.width, tile.height, 1, GL_RED, GL_FLOAT,
                       GLsizei(out.total() * sizeof(float)), out.data);
  CheckGl("ray-march sweep");
  return out;
}

}  // namespace hullpipe::gl
