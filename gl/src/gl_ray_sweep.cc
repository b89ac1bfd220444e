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

// One swept view as the shaders read it (std430: 9 x 16 bytes).
struct GpuView {
  float intr[4];     // fx fy cx cy
  float O[4];        // eye centre, world metres
  float Rwe[12];     // world_from_eye rotation, columns (std430 mat3: 3 x vec4)
  float origin[4];   // xy: view pixel of the region's (0, 0)
  int32_t idx[4];    // first plane, plane count, first Cam entry
  int32_t size[4];   // region w, h; tile w, h
  int32_t inner[4];  // tile origin in the region
};
static_assert(sizeof(GpuView) == 144);

// What both passes share: the views, their rays, the planes, the hull box clip
// and the volume query of a point on the current ray (PlaneSweepCpu's RayQuery).
// Invocation z sweeps view z; its cameras are Cam entries idx.z .. idx.z + n - 1
// (each camera's M and A depend on the view), its planes idx.x .. idx.x + idx.y - 1.
const char* kRayGlsl = R"(
struct View {
  vec4 intr;
  vec4 O;
  mat3 Rwe;
  vec4 origin;
  ivec4 idx;
  ivec4 size;
  ivec4 inner;
};
layout(std430, binding = 1) readonly buffer Planes { float planes[]; };
layout(std430, binding = 3) readonly buffer Views { View views[]; };
layout(binding = 0) uniform usampler2DArray u_maps;
uniform int u_ncam;
uniform int u_unknown;   // 1: a camera that cannot see a point does not vote (OutOfView::kUnknown)
uniform int u_required;  // cameras that must see an inside point
uniform int u_refine;    // bisections (0: the paper's plane depth)
uniform vec3 u_bmin;     // hull box, world metres
uniform vec3 u_bmax;
const float INF = uintBitsToFloat(0x7f800000u);

View g_v;    // this invocation's view
vec3 g_ray;  // eye ray of the current pixel (z = 1)

float Plane(int k) { return planes[g_v.idx.x + k]; }

// 0 background, 1 object, 2 unseen: camera c's vote on the ray's point at eye depth d.
int VoteAt(int c, float d) {
  int e = g_v.idx.z + c;
  precise vec3 B = vec3(dot(cams[e].m0.xyz, g_ray), dot(cams[e].m1.xyz, g_ray), dot(cams[e].m2.xyz, g_ray));
  precise vec3 X = cams[e].a.xyz + d * B;
  vec2 uv = CamPixel(e, X);
  if (uv.x < 0.0) return 2;
  // Outside the map's object rectangle every pixel is background (not uploaded).
  vec4 r = cams[e].rect;
  if (!(uv.x >= r.x && uv.y >= r.y && uv.x < r.z && uv.y < r.w)) return 0;
  return ObjectPixelBit(u_maps, int(uv.x), int(uv.y), c);  // the maps go up as bits
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
  int lo = 0, hi = g_v.idx.y;
  while (lo < hi) {
    int m = (lo + hi) / 2;
    if (Plane(m) < x) lo = m + 1; else hi = m;
  }
  return lo;
}

float SpacingAt(float d) {
  if (g_v.idx.y < 2) return 0.0;
  int k = clamp(LowerBound(d), 1, g_v.idx.y - 1);
  return Plane(k) - Plane(k - 1);
}

// Aims at region pixel px; the ray's part [s0, s1] in the hull box (false: misses).
bool Aim(ivec2 px, out float s0, out float s1) {
  vec2 uv = g_v.origin.xy + vec2(px) + 0.5;
  g_ray = vec3((uv.x - g_v.intr.z) / g_v.intr.x, (uv.y - g_v.intr.w) / g_v.intr.y, 1.0);
  vec3 D = g_v.Rwe * g_ray;
  vec3 O = g_v.O.xyz;
  float lo = Plane(0), hi = Plane(g_v.idx.y - 1);
  s0 = lo;
  s1 = hi;
  for (int a = 0; a < 3; ++a) {
    if (abs(D[a]) < 1e-30) {
      if (O[a] < u_bmin[a] || O[a] > u_bmax[a]) return false;
      continue;
    }
    float t0 = (u_bmin[a] - O[a]) / D[a], t1 = (u_bmax[a] - O[a]) / D[a];
    if (t0 > t1) { float t = t0; t0 = t1; t1 = t; }
    lo = max(lo, t0);
    hi = min(hi, t1);
    if (lo > hi) return false;
  }
  s0 = lo;
  s1 = hi;
  return true;
}

// Narrows [a, b] to where g0 + t g1 >= 0 (empty: a > b).
void KeepWhereNonNegative(float g0, float g1, inout float a, inout float b) {
  if (g1 > 0.0) a = max(a, -g0 / g1);
  else if (g1 < 0.0) b = min(b, -g0 / g1);
  else if (g0 < 0.0) { a = INF; b = -INF; }
}

// The part [lo, hi] of the current ray's [s0, s1] outside which at least two
// cameras veto every point, so that the march need not ask about them: a
// vetoed-twice point is neither inside nor a near miss, and the march returns
// the same depth (the CPU's empty-space grid skips the same points,
// docs/gpu.md). An undistorted camera that sees the whole segment (both ends
// in its image and lens disc, which are convex) vetoes every point whose pixel
// lies outside its map's object rectangle; grown by a pixel here, so that the
// float arithmetic of the bounds and of VoteAt cannot disagree.
void Narrow(float s0, float s1, out float lo, out float hi) {
  float lo1 = -INF, lo2 = -INF, hi1 = INF, hi2 = INF;  // the two largest starts, the two smallest ends
  for (int c = 0; c < u_ncam; ++c) {
    int e = g_v.idx.z + c;
    vec4 k = cams[e].k, p = cams[e].p, intr = cams[e].intr;
    if (k.x != 0.0 || k.y != 0.0 || k.z != 0.0 || p.x != 0.0 || p.y != 0.0) continue;  // curved projections
    vec3 B = vec3(dot(cams[e].m0.xyz, g_ray), dot(cams[e].m1.xyz, g_ray), dot(cams[e].m2.xyz, g_ray));
    vec3 A = cams[e].a.xyz;
    float skew = cams[e].a.w;
    vec3 X0 = A + s0 * B, X1 = A + s1 * B;
    if (!(X0.z > 1e-3 && X1.z > 1e-3) || CamPixel(e, X0).x < 0.0 || CamPixel(e, X1).x < 0.0) continue;
    // u(t) = U(A + t B) / z(t), U(X) = fx X.x + skew X.y + cx X.z, z > 0 on the segment:
    // u >= x0 is U(A) - x0 A.z + t (U(B) - x0 B.z) >= 0, and so on.
    vec4 r = cams[e].rect + vec4(-1.0, -1.0, 1.0, 1.0);
    float ua = intr.x * A.x + skew * A.y + intr.z * A.z, ub = intr.x * B.x + skew * B.y + intr.z * B.z;
    float va = intr.y * A.y + intr.w * A.z, vb = intr.y * B.y + intr.w * B.z;
    float a = s0, b = s1;
    KeepWhereNonNegative(ua - r.x * A.z, ub - r.x * B.z, a, b);
    KeepWhereNonNegative(r.z * A.z - ua, r.z * B.z - ub, a, b);
    KeepWhereNonNegative(va - r.y * A.z, vb - r.y * B.z, a, b);
    KeepWhereNonNegative(r.w * A.z - va, r.w * B.z - vb, a, b);
    if (a > b) { a = INF; b = -INF; }  // this camera vetoes the whole segment
    if (a > lo1) { lo2 = lo1; lo1 = a; } else if (a > lo2) { lo2 = a; }
    if (b < hi1) { hi2 = hi1; hi1 = b; } else if (b < hi2) { hi2 = b; }
  }
  lo = max(s0, lo2);
  hi = min(s1, hi2);
}
)";

std::string MarchCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 8, local_size_y = 8) in;\n") + kCameraBufferGlsl +
         kObjectPixelBitGlsl + kRayGlsl + R"(
layout(r32f, binding = 0) uniform writeonly image2DArray u_out;
layout(std430, binding = 4) buffer Counter { uint g_asked; };
uniform int u_narrow;  // 1: skip where two cameras' object rectangles veto (Narrow)
uniform int u_count;   // 1: add the plane points asked to g_asked
void main() {
  int z = int(gl_GlobalInvocationID.z);
  g_v = views[z];
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= g_v.size.x || px.y >= g_v.size.y) return;
  float result = INF;
  float s0, s1;
  if (g_v.idx.y > 0 && Aim(px, s0, s1)) {
    bool want = u_refine > 0;
    int near_k[8];
    int n_near = 0, hit = -1;
    float m0 = s0, m1 = s1;
    if (u_narrow != 0) Narrow(s0, s1, m0, m1);
    uint asked = 0u;
    for (int k = LowerBound(m0); k < g_v.idx.y && Plane(k) <= m1; ++k) {
      ++asked;
      bool near;
      if (InsideAt(Plane(k), want, near)) { hit = k; break; }
      if (near && n_near < 8) near_k[n_near++] = k;
    }
    bool done = false;
    // Scan around each near miss, front to back, at 1/16 of its two gaps.
    for (int m = 0; m < n_near && !done; ++m) {
      int k = near_k[m];
      float a = max(s0, k > 0 ? Plane(k - 1) : Plane(k));
      float b = min(s1, k + 1 < g_v.idx.y ? Plane(k + 1) : Plane(k));
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
      result = want && hit > 0 ? Bisect(max(Plane(hit - 1), s0), Plane(hit), u_refine) : Plane(hit);
    if (u_count != 0 && asked > 0u) atomicAdd(g_asked, asked);
  }
  imageStore(u_out, ivec3(px, z), vec4(result, 0.0, 0.0, 0.0));
}
)";
}

// The silhouette pass of the refinement (plane_sweep.cc, RefineEdges).
std::string EdgesCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 8, local_size_y = 8) in;\n") + kCameraBufferGlsl +
         kObjectPixelBitGlsl + kRayGlsl + R"(
layout(r32f, binding = 0) uniform readonly image2DArray u_swept;  // the march over each region
layout(r32f, binding = 1) uniform writeonly image2DArray u_out;   // each tile
void main() {
  int z = int(gl_GlobalInvocationID.z);
  g_v = views[z];
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (px.x >= g_v.size.z || px.y >= g_v.size.w) return;
  ivec2 region = g_v.size.xy;
  ivec2 q = g_v.inner.xy + px;
  float dp = imageLoad(u_swept, ivec3(q, z)).r;
  vec2 win[4];
  int nw = 0;
  const ivec2 nb[4] = ivec2[4](ivec2(0, -1), ivec2(0, 1), ivec2(-1, 0), ivec2(1, 0));
  for (int i = 0; i < 4; ++i) {
    ivec2 o = q + nb[i];
    if (o.x < 0 || o.y < 0 || o.x >= region.x || o.y >= region.y) continue;
    float dq = imageLoad(u_swept, ivec3(o, z)).r;
    if (isinf(dq) || isnan(dq)) continue;
    float sp = SpacingAt(dq);
    if (!isinf(dp) && dq >= dp - 1.5 * sp) continue;
    win[nw++] = vec2(dq - 2.0 * sp, dq + 2.0 * sp);
  }
  float best = dp;
  float s0, s1;
  if (nw > 0 && g_v.idx.y > 0 && Aim(q, s0, s1)) {
    // Sort the windows (by start, then end) as the CPU does.
    for (int i = 1; i < nw; ++i)
      for (int j = i; j > 0 && (win[j].x < win[j - 1].x || (win[j].x == win[j - 1].x && win[j].y < win[j - 1].y)); --j) {
        vec2 t = win[j]; win[j] = win[j - 1]; win[j - 1] = t;
      }
    float limit = isinf(dp) ? s1 : min(dp, s1);
    for (int w = 0; w < nw; ++w) {
      float a = max(max(win[w].x, s0), Plane(0)), b = min(win[w].y, limit);
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
            prev = max(s0, k == 0 ? s0 : Plane(k - 1));
            if (!(prev < a)) { best = a; break; }
          }
          best = Bisect(prev, t, u_refine);
          break;
        }
        prev = t;
      }
    }
  }
  imageStore(u_out, ivec3(px, z), vec4(best < dp || (isinf(dp) && !isinf(best)) ? best : dp, 0.0, 0.0, 0.0));
}
)";
}

void SetPassUniforms(GLuint p, const VolumeQuery& q, int refine) {
  glUseProgram(p);
  glUniform1i(glGetUniformLocation(p, "u_ncam"), GLint(q.size()));
  glUniform1i(glGetUniformLocation(p, "u_unknown"), q.options().out_of_view == OutOfView::kUnknown ? 1 : 0);
  glUniform1i(glGetUniformLocation(p, "u_required"), GLint(q.required_seen()));
  glUniform1i(glGetUniformLocation(p, "u_refine"), refine);
  const Eigen::Vector3f bmin = q.hull_box().min.cast<float>(), bmax = q.hull_box().max.cast<float>();
  glUniform3fv(glGetUniformLocation(p, "u_bmin"), 1, bmin.data());
  glUniform3fv(glGetUniformLocation(p, "u_bmax"), 1, bmax.data());
  glUniform1i(glGetUniformLocation(p, "u_maps"), 0);
}

GLuint Groups(int n) { return GLuint((n + 7) / 8); }

// An R32F texture array of at least w x h x layers (grown, never shrunk).
void EnsureArray(Texture* t, int* w, int* h, int* layers, int want_w, int want_h, int want_layers) {
  if (want_w <= *w && want_h <= *h && want_layers <= *layers && t->get()) return;
  *w = std::max(*w, want_w);
  *h = std::max(*h, want_h);
  *layers = std::max(*layers, want_layers);
  *t = MakeTexture(GL_TEXTURE_2D_ARRAY);
  glTextureStorage3D(t->get(), 1, GL_R32F, *w, *h, *layers);
  glTextureParameteri(t->get(), GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t->get(), GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  CheckGl("sweep images");
}

}  // namespace

// The march's and the silhouette pass's images for one kind of sweep (tiles, or
// the visibility views), and which of them holds the result.
struct GlRaySweep::Target {
  Texture swept, refined;
  int sw = 0, sh = 0, sl = 0, rw = 0, rh = 0, rl = 0;
  GLuint result = 0;
};

GlRaySweep::GlRaySweep()
    : march_(BuildComputeProgram(MarchCs().c_str())),
      edges_(BuildComputeProgram(EdgesCs().c_str())),
      maps_(std::make_unique<LayerUploader>(GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, CV_8UC1,
                                            LayerUploader::Packing::kBits)),
      cams_(MakeBuffer()),
      planes_(MakeBuffer()),
      views_(MakeBuffer()),
      counter_(MakeBuffer()),
      tile_target_(std::make_unique<Target>()),
      view_target_(std::make_unique<Target>()) {
  const uint32_t zero = 0;
  glNamedBufferStorage(counter_.get(), sizeof zero, &zero, GL_DYNAMIC_STORAGE_BIT);
}

GlRaySweep::~GlRaySweep() = default;

void GlRaySweep::Upload(const VolumeQuery& q) {
  std::vector<cv::Mat> maps;
  std::vector<cv::Rect> rects;
  for (size_t c = 0; c < q.size(); ++c) {
    maps.push_back(q.views()[c].map);
    rects.push_back(q.object_rect(c));
  }
  maps_->Upload(maps, &rects);
  uploaded_cameras_ = q.size();
}

size_t GlRaySweep::last_upload_bytes() const { return maps_->last_bytes(); }

void GlRaySweep::Run(const VolumeQuery& q, const std::vector<NovelView>& views,
                     const std::vector<std::vector<double>>& depths, const std::vector<cv::Rect>& tiles, int refine,
                     Target& target) {
  if (q.size() != uploaded_cameras_)
    throw std::invalid_argument("GlRaySweep: the query has " + std::to_string(q.size()) +
                                " cameras, the last Upload " + std::to_string(uploaded_cameras_));
  const size_t n = q.size();
  std::vector<GpuCamera> cams;
  cams.reserve(views.size() * n);
  std::vector<float> planes;
  std::vector<GpuView> gv(views.size());
  int max_rw = 1, max_rh = 1, max_tw = 1, max_th = 1;
  for (size_t k = 0; k < views.size(); ++k) {
    const NovelView& view = views[k];
    const cv::Rect& tile = tiles[k];
    // With refinement the march covers the tile and a one-pixel margin in the
    // view, so the silhouette pass sees the neighbours a whole-view render has.
    const cv::Rect region = refine > 0 ? cv::Rect(tile.x - 1, tile.y - 1, tile.width + 2, tile.height + 2) &
                                             cv::Rect(0, 0, view.width, view.height)
                                       : tile;
    GpuView& g = gv[k];
    g = GpuView{};
    g.intr[0] = float(view.fx), g.intr[1] = float(view.fy), g.intr[2] = float(view.cx), g.intr[3] = float(view.cy);
    const Eigen::Vector3d O = view.world_from_eye.translation;
    for (int i = 0; i < 3; ++i) g.O[i] = float(O[i]);
    for (int col = 0; col < 3; ++col)
      for (int row = 0; row < 3; ++row) g.Rwe[4 * col + row] = float(view.world_from_eye.rotation(row, col));
    g.origin[0] = float(region.x), g.origin[1] = float(region.y);
    g.idx[0] = int32_t(planes.size()), g.idx[1] = int32_t(depths[k].size()), g.idx[2] = int32_t(cams.size());
    g.size[0] = region.width, g.size[1] = region.height, g.size[2] = tile.width, g.size[3] = tile.height;
    g.inner[0] = tile.x - region.x, g.inner[1] = tile.y - region.y;
    for (const double d : depths[k]) planes.push_back(float(d));
    for (size_t c = 0; c < n; ++c) {
      const Rigid3d& cw = q.views()[c].camera.cam_from_world;
      cams.push_back(PackCamera(q.fast()[c], cw.rotation * view.world_from_eye.rotation, cw * O, q.object_rect(c)));
    }
    max_rw = std::max(max_rw, region.width), max_rh = std::max(max_rh, region.height);
    max_tw = std::max(max_tw, tile.width), max_th = std::max(max_th, tile.height);
  }
  if (planes.empty()) planes.push_back(0.0f);  // a buffer of no size cannot be bound
  const int layers = int(views.size());
  EnsureArray(&target.swept, &target.sw, &target.sh, &target.sl, max_rw, max_rh, layers);
  if (refine > 0) EnsureArray(&target.refined, &target.rw, &target.rh, &target.rl, max_tw, max_th, layers);
  glNamedBufferData(cams_.get(), GLsizeiptr(cams.size() * sizeof(GpuCamera)), cams.data(), GL_STREAM_DRAW);
  glNamedBufferData(planes_.get(), GLsizeiptr(planes.size() * sizeof(float)), planes.data(), GL_STREAM_DRAW);
  glNamedBufferData(views_.get(), GLsizeiptr(gv.size() * sizeof(GpuView)), gv.data(), GL_STREAM_DRAW);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, cams_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, planes_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, views_.get());
  glBindTextureUnit(0, maps_->texture());

  SetPassUniforms(march_.get(), q, refine);
  const uint32_t zero = 0;
  if (counting_) glNamedBufferSubData(counter_.get(), 0, sizeof zero, &zero);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, counter_.get());
  glUniform1i(glGetUniformLocation(march_.get(), "u_narrow"), narrowing_ ? 1 : 0);
  glUniform1i(glGetUniformLocation(march_.get(), "u_count"), counting_ ? 1 : 0);
  counted_ = counting_;
  glBindImageTexture(0, target.swept.get(), 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_R32F);
  glDispatchCompute(Groups(max_rw), Groups(max_rh), GLuint(layers));
  target.result = target.swept.get();
  if (refine > 0) {
    glMemoryBarrier(GL_SHADER_IMAGE_ACCESS_BARRIER_BIT);
    SetPassUniforms(edges_.get(), q, refine);
    glBindImageTexture(0, target.swept.get(), 0, GL_TRUE, 0, GL_READ_ONLY, GL_R32F);
    glBindImageTexture(1, target.refined.get(), 0, GL_TRUE, 0, GL_WRITE_ONLY, GL_R32F);
    glDispatchCompute(Groups(max_tw), Groups(max_th), GLuint(layers));
    target.result = target.refined.get();
  }
  // Later passes read the result by texel fetch or read it back.
  glMemoryBarrier(GL_TEXTURE_FETCH_BARRIER_BIT | GL_TEXTURE_UPDATE_BARRIER_BIT);
  CheckGl("ray-march sweep");
}

cv::Mat GlRaySweep::Sweep(const VolumeQuery& q, const NovelView& view, const std::vector<double>& depths,
                          const cv::Rect& tile, int refine) {
  SweepOnGpu(q, view, depths, tile, refine);
  return ReadTile();
}

bool GlRaySweep::SweepOnGpu(const VolumeQuery& q, const NovelView& view, const std::vector<double>& depths,
                            const cv::Rect& tile, int refine) {
  view.Check();
  if (refine < 0) throw std::invalid_argument("GlRaySweep: refine iterations must be >= 0");
  if (q.size() != uploaded_cameras_)
    throw std::invalid_argument("GlRaySweep: the query has " + std::to_string(q.size()) +
                                " cameras, the last Upload " + std::to_string(uploaded_cameras_));
  tile_valid_ = false;
  counted_ = false;
  tile_size_ = tile.size();
  if (depths.empty() || tile.area() == 0 || q.hull_box().empty()) return false;
  Run(q, {view}, {depths}, {tile}, refine, *tile_target_);
  tile_valid_ = true;
  return true;
}

cv::Mat GlRaySweep::ReadTile() const {
  cv::Mat out(tile_size_, CV_32FC1, cv::Scalar(kNoDepth));
  if (!tile_valid_ || tile_size_.area() == 0) return out;
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureSubImage(tile_target_->result, 0, 0, 0, 0, tile_size_.width, tile_size_.height, 1, GL_RED, GL_FLOAT,
                       GLsizei(out.total() * sizeof(float)), out.data);
  CheckGl("ray-march sweep read-back");
  return out;
}

void GlRaySweep::SweepViews(const VolumeQuery& q, const std::vector<NovelView>& views,
                            const std::vector<std::vector<double>>& depths, int refine) {
  if (views.size() != depths.size())
    throw std::invalid_argument("GlRaySweep::SweepViews: " + std::to_string(views.size()) + " views, " +
                                std::to_string(depths.size()) + " plane lists");
  if (refine < 0) throw std::invalid_argument("GlRaySweep: refine iterations must be >= 0");
  std::vector<cv::Rect> tiles;
  std::vector<std::vector<double>> used = depths;
  for (const NovelView& v : views) {
    v.Check();
    tiles.emplace_back(0, 0, v.width, v.height);
  }
  // An empty hull box: no plane is inside anywhere (as Sweep returns).
  if (q.hull_box().empty())
    for (auto& d : used) d.clear();
  view_sizes_.clear();
  counted_ = false;
  for (const NovelView& v : views) view_sizes_.emplace_back(v.width, v.height);
  if (views.empty()) return;
  Run(q, views, used, tiles, refine, *view_target_);
}

uint64_t GlRaySweep::points_asked() const {
  if (!counted_) return 0;
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  uint32_t n = 0;
  glGetNamedBufferSubData(counter_.get(), 0, sizeof n, &n);
  CheckGl("ray-march count read-back");
  return n;
}

GLuint GlRaySweep::views_texture() const { return view_target_->result; }

GLuint GlRaySweep::tile_texture() const { return tile_valid_ ? tile_target_->result : 0; }

cv::Mat GlRaySweep::ReadView(size_t k) const {
  const cv::Size size = view_sizes_.at(k);
  cv::Mat out(size, CV_32FC1);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glGetTextureSubImage(view_target_->result, 0, 0, 0, GLint(k), size.width, size.height, 1, GL_RED, GL_FLOAT,
                       GLsizei(out.total() * sizeof(float)), out.data);
  CheckGl("ray-march view read-back");
  return out;
}

}  // namespace hullpipe::gl
