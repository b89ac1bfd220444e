#include "hullpipe/gl/gl_triangle_query.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "hullpipe/geometry/conventions.h"
#include "gl_cameras.h"
#include "gl_upload.h"

namespace hullpipe::gl {
namespace {

// A triangle's mask offset when it has no mask.
constexpr uint32_t kMaskFull = 0xFFFFFFFEu;  // the mask buffer was full: run again
constexpr uint32_t kCentroid = 0xFFFFFFFDu;  // no pixel centre covered: its centroid was queried

// One workgroup per triangle: its viewport (MakeTriangleViewport), its pixel
// centres in the triangle (PixelInTriangle's edge functions), each one's volume
// query (VolumeQuery::Inside's votes), the inside ones as bits in shared
// memory, then the counts and, where any pixel is inside, the mask written at
// an offset taken from one atomic counter.
std::string TriangleCs() {
  return std::string("#version 450 core\nlayout(local_size_x = 64) in;\n") + kCameraBufferGlsl + kObjectPixelBitGlsl +
         R"(
layout(std430, binding = 1) readonly buffer Tris { float tris[]; };     // a, b, c: 9 floats per triangle
layout(std430, binding = 2) writeonly buffer Results { uvec4 results[]; };  // tested, inside, mask offset, w | h << 16
layout(std430, binding = 3) buffer Masks { uint mask_used; uint mask_capacity; uint pad0; uint pad1; uint masks[]; };
layout(binding = 0) uniform usampler2DArray u_maps;
uniform int u_ncam;
uniform int u_unknown;
uniform int u_required;
uniform uint u_count;
uniform uint u_first;     // triangle index of workgroup 0
uniform vec3 u_wmin;      // workspace box, world metres
uniform vec3 u_wmax;
uniform float u_pixel;    // TriangleQueryOptions::max_pixel_size
uniform int u_fixed;      // ::fixed_viewport
uniform int u_maxvp;      // ::max_viewport
shared uint s_mask[2048];  // 256 x 256 pixels (TriangleQueryOptions::kMaxViewportSide)
shared uint s_tested, s_inside, s_offset;

// 0 background, 1 object, 2 unseen: camera c on world point X.
int VoteOf(int c, vec3 X) {
  vec3 Xc = cams[c].a.xyz + vec3(dot(cams[c].m0.xyz, X), dot(cams[c].m1.xyz, X), dot(cams[c].m2.xyz, X));
  vec2 uv = CamPixel(c, Xc);
  if (uv.x < 0.0) return 2;
  vec4 r = cams[c].rect;
  if (!(uv.x >= r.x && uv.y >= r.y && uv.x < r.z && uv.y < r.w)) return 0;
  return ObjectPixelBit(u_maps, int(uv.x), int(uv.y), c);  // the maps go up as bits
}

bool Inside(vec3 X) {
  int object = 0, unseen = 0;
  for (int c = 0; c < u_ncam; ++c) {
    int v = VoteOf(c, X);
    if (v == 0 || (v == 2 && u_unknown == 0)) return false;
    if (v == 1) ++object; else ++unseen;
  }
  return (unseen == 0 || u_unknown != 0) && object >= u_required;
}

float Edge(vec2 s, vec2 e, vec2 q) { return (e.x - s.x) * (q.y - s.y) - (e.y - s.y) * (q.x - s.x); }

void main() {
  uint t = u_first + gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  if (t >= u_count) return;  // the whole group
  uint lid = gl_LocalInvocationIndex;
  vec3 a = vec3(tris[9 * t], tris[9 * t + 1], tris[9 * t + 2]);
  vec3 b = vec3(tris[9 * t + 3], tris[9 * t + 4], tris[9 * t + 5]);
  vec3 c = vec3(tris[9 * t + 6], tris[9 * t + 7], tris[9 * t + 8]);
  // The viewport (MakeTriangleViewport): u along the longest edge from its
  // start, v across, in the triangle's plane.
  vec3 p0 = a, p1 = b;
  if (length(c - b) > length(p1 - p0)) { p0 = b; p1 = c; }
  if (length(a - c) > length(p1 - p0)) { p0 = c; p1 = a; }
  vec3 u = p1 - p0;
  float len = length(u);
  u = len > 0.0 ? u / len : vec3(1.0, 0.0, 0.0);
  vec3 n = cross(b - a, c - a);
  vec3 v;
  if (length(n) > 1e-18) {
    v = normalize(cross(n, u));
  } else if (abs(u.x) > 1e-6 * abs(u.z) || abs(u.y) > 1e-6 * abs(u.z)) {
    v = vec3(-u.y, u.x, 0.0) / sqrt(u.x * u.x + u.y * u.y);
  } else {
    v = vec3(0.0, -u.z, u.y) / sqrt(u.z * u.z + u.y * u.y);
  }
  vec2 pa = vec2(dot(a - p0, u), dot(a - p0, v)), pb = vec2(dot(b - p0, u), dot(b - p0, v)),
       pc = vec2(dot(c - p0, u), dot(c - p0, v));
  vec2 lo = min(pa, min(pb, pc)), hi = max(pa, max(pb, pc));
  vec2 ext = hi - lo;
  int w, h;
  if (u_fixed > 0) {
    w = h = u_fixed;
  } else {
    w = int(clamp(ceil(ext.x / u_pixel), 1.0, float(u_maxvp)));
    h = int(clamp(ceil(ext.y / u_pixel), 1.0, float(u_maxvp)));
  }
  vec2 s = vec2(ext.x > 0.0 ? ext.x / float(w) : 1e-9, ext.y > 0.0 ? ext.y / float(h) : 1e-9);
  vec3 origin = p0 + lo.x * u + lo.y * v;
  vec3 du = s.x * u, dv = s.y * v;
  vec2 a2 = (pa - lo) / s, b2 = (pb - lo) / s, c2 = (pc - lo) / s;
  float area = Edge(a2, b2, c2);
  float sgn = area > 0.0 ? 1.0 : area < 0.0 ? -1.0 : 0.0;
  bool check_ws = !(all(greaterThanEqual(min(a, min(b, c)), u_wmin)) && all(lessThanEqual(max(a, max(b, c)), u_wmax)));
  uint words = uint(w * h + 31) / 32u;
  if (lid == 0u) { s_tested = 0u; s_inside = 0u; }
  for (uint k = lid; k < words; k += 64u) s_mask[k] = 0u;
  barrier();
  uint tested = 0u, inside = 0u;
  bool thin = h == 1;
  if (sgn != 0.0 || thin) {
    for (int p = int(lid); p < w * h; p += 64) {
      vec2 q = vec2(float(p % w) + 0.5, float(p / w) + 0.5);
      if (thin) {
        // Thinner than a pixel: each column's sample is the middle of the
        // triangle's chord there (TriangleChord), along all its length.
        float clo = 1e30, chi = -1e30;
        vec2 v3[3] = vec2[3](a2, b2, c2);
        for (int e = 0; e < 3; ++e) {
          vec2 e0 = v3[e], e1 = v3[(e + 1) % 3];
          if ((e0.x - q.x) * (e1.x - q.x) > 0.0) continue;
          if (e0.x == e1.x) {
            clo = min(clo, min(e0.y, e1.y));
            chi = max(chi, max(e0.y, e1.y));
            continue;
          }
          float y = e0.y + (q.x - e0.x) / (e1.x - e0.x) * (e1.y - e0.y);
          clo = min(clo, y);
          chi = max(chi, y);
        }
        if (!(clo <= chi)) continue;
        q.y = 0.5 * (clo + chi);
      } else if (!(sgn * Edge(a2, b2, q) >= 0.0 && sgn * Edge(b2, c2, q) >= 0.0 && sgn * Edge(c2, a2, q) >= 0.0)) {
        continue;
      }
      ++tested;
      vec3 X = origin + q.x * du + q.y * dv;
      if (check_ws && !(all(greaterThanEqual(X, u_wmin)) && all(lessThanEqual(X, u_wmax)))) continue;
      if (Inside(X)) {
        atomicOr(s_mask[p >> 5], 1u << uint(p & 31));
        ++inside;
      }
    }
  }
  atomicAdd(s_tested, tested);
  atomicAdd(s_inside, inside);
  barrier();
  if (s_tested == 0u) {  // the same for the whole group
    // No pixel centre covered (smaller than a pixel): its centroid, as the CPU
    // does (QueryTriangleCpu; VolumeQuery::Inside with the workspace).
    if (lid == 0u) {
      vec3 X = (a + b + c) / 3.0;
      bool in_ws = all(greaterThanEqual(X, u_wmin)) && all(lessThanEqual(X, u_wmax));
      results[t] = uvec4(1u, in_ws && Inside(X) ? 1u : 0u, 0xFFFFFFFDu, uint(w) | (uint(h) << 16));
    }
    return;
  }
  if (lid == 0u) {
    uint off = 0xFFFFFFFFu;
    if (s_inside > 0u) {
      off = atomicAdd(mask_used, words);
      if (off + words > mask_capacity) off = 0xFFFFFFFEu;
    }
    s_offset = off;
    results[t] = uvec4(s_tested, s_inside, off, uint(w) | (uint(h) << 16));
  }
  barrier();
  if (s_offset < 0xFFFFFFFDu)
    for (uint k = lid; k < words; k += 64u) masks[s_offset + k] = s_mask[k];
}
)";
}

}  // namespace

std::vector<Eigen::Vector3d> TriangleBatchResult::Points(size_t i) const {
  if (inside_.at(i) == 0) return {};
  const uint32_t h = hit_of_[i];
  const Triangle& t = hit_triangles_[h];
  if (hit_mask_[h] == kCentroid) return {(t.a + t.b + t.c) / 3.0};
  // The pixel centres the GPU found inside, placed by the CPU's own viewport
  // (QueryTriangleCpu's points). Where float and double round a side's pixel
  // count differently, or the mask did not fit, the CPU queries the triangle.
  const TriangleViewport vp = MakeTriangleViewport(t.a, t.b, t.c, options_);
  const int w = int(hit_size_[h] & 0xFFFFu), hh = int(hit_size_[h] >> 16);
  if (hit_mask_[h] == kMaskFull || vp.width != w || vp.height != hh)
    return QueryTriangleCpu(*query_, t.a, t.b, t.c, options_).collision_points;
  std::vector<Eigen::Vector3d> out;
  out.reserve(size_t(inside_[i]));
  const uint32_t* mask = masks_.data() + hit_mask_[h];
  for (int p = 0; p < w * hh; ++p) {
    if (!(mask[p >> 5] >> (p & 31) & 1u)) continue;
    const double fi = p % w + 0.5;
    double fj = p / w + 0.5;
    if (vp.height == 1) {  // a thin triangle's sample: the middle of its chord
      double lo, hi;
      if (!TriangleChord(vp, 0, fi, &lo, &hi)) continue;
      fj = 0.5 * (lo + hi);
    }
    out.push_back(vp.origin + fi * vp.u_step + fj * vp.v_step);
  }
  return out;
}

std::vector<TriangleQueryResult> TriangleBatchResult::All() const {
  std::vector<TriangleQueryResult> out(size());
  for (size_t i = 0; i < size(); ++i) {
    out[i].pixels_tested = tested_[i];
    out[i].collision_points = Points(i);
  }
  return out;
}

GlTriangleQuery::GlTriangleQuery(size_t initial_mask_words)
    : program_(BuildComputeProgram(TriangleCs().c_str())),
      maps_(std::make_unique<LayerUploader>(GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, CV_8UC1,
                                            LayerUploader::Packing::kBits)),
      cams_(MakeBuffer()),
      tris_(MakeBuffer()),
      results_(MakeBuffer()),
      masks_(MakeBuffer()),
      mask_capacity_(std::max<size_t>(initial_mask_words, 1)) {}

GlTriangleQuery::~GlTriangleQuery() = default;

TriangleBatchResult GlTriangleQuery::QueryBatch(const VolumeQuery& q, const std::vector<Triangle>& tris,
                                                const TriangleQueryOptions& options) {
  options.Check();
  TriangleBatchResult r;
  r.query_ = &q;
  r.options_ = options;
  const size_t count = tris.size();
  r.tested_.assign(count, 0);
  r.inside_.assign(count, 0);
  r.hit_of_.assign(count, 0);
  if (count == 0) return r;
  const double t0 = MonotonicSeconds();

  const size_t n = q.size();
  std::vector<cv::Mat> maps;
  std::vector<cv::Rect> rects;
  std::vector<GpuCamera> cams;
  for (size_t c = 0; c < n; ++c) {
    maps.push_back(q.views()[c].map);
    rects.push_back(q.object_rect(c));
    const Rigid3d& cw = q.views()[c].camera.cam_from_world;
    cams.push_back(PackCamera(q.fast()[c], cw.rotation, cw.translation, q.object_rect(c)));
  }
  maps_->Upload(maps, &rects);
  // The triangles written as floats straight into a persistently mapped
  // buffer (the last batch's pass is over: its results were read back).
  if (tris_capacity_ < count) {
    tris_capacity_ = std::max(count, 2 * tris_capacity_);
    tris_ = MakeBuffer();
    const GLbitfield flags = GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
    glNamedBufferStorage(tris_.get(), GLsizeiptr(tris_capacity_ * 9 * sizeof(float)), nullptr, flags);
    tris_mapped_ = static_cast<float*>(
        glMapNamedBufferRange(tris_.get(), 0, GLsizeiptr(tris_capacity_ * 9 * sizeof(float)), flags));
    if (!tris_mapped_) throw GlError("glMapNamedBufferRange of the triangle buffer failed");
    results_ = MakeBuffer();
    glNamedBufferStorage(results_.get(), GLsizeiptr(tris_capacity_ * 16), nullptr, GL_DYNAMIC_STORAGE_BIT);
  }
  for (size_t i = 0; i < count; ++i) {
    const Triangle& t = tris[i];
    float* f = tris_mapped_ + 9 * i;
    for (int k = 0; k < 3; ++k) f[k] = float(t.a[k]), f[3 + k] = float(t.b[k]), f[6 + k] = float(t.c[k]);
  }
  glNamedBufferData(cams_.get(), GLsizeiptr(cams.size() * sizeof(GpuCamera)), cams.data(), GL_STREAM_DRAW);

  const GLuint p = program_.get();
  glUseProgram(p);
  glUniform1i(glGetUniformLocation(p, "u_ncam"), GLint(n));
  glUniform1i(glGetUniformLocation(p, "u_unknown"), q.options().out_of_view == OutOfView::kUnknown ? 1 : 0);
  glUniform1i(glGetUniformLocation(p, "u_required"), GLint(q.required_seen()));
  glUniform1ui(glGetUniformLocation(p, "u_count"), GLuint(count));
  const Eigen::Vector3f wmin = q.workspace().min.cast<float>(), wmax = q.workspace().max.cast<float>();
  glUniform3fv(glGetUniformLocation(p, "u_wmin"), 1, wmin.data());
  glUniform3fv(glGetUniformLocation(p, "u_wmax"), 1, wmax.data());
  glUniform1f(glGetUniformLocation(p, "u_pixel"), float(options.max_pixel_size));
  glUniform1i(glGetUniformLocation(p, "u_fixed"), options.fixed_viewport);
  glUniform1i(glGetUniformLocation(p, "u_maxvp"), options.max_viewport);
  glUniform1i(glGetUniformLocation(p, "u_maps"), 0);
  glBindTextureUnit(0, maps_->texture());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, cams_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, tris_.get());
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, results_.get());

  std::unique_ptr<uint32_t[]> res(new uint32_t[count * 4]);  // every entry read back below
  uint32_t used = 0;
  double t1 = 0, t2 = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    // Header: words used, capacity.
    glNamedBufferData(masks_.get(), GLsizeiptr(16 + mask_capacity_ * 4), nullptr, GL_STREAM_READ);
    const uint32_t header[4] = {0, uint32_t(mask_capacity_), 0, 0};
    glNamedBufferSubData(masks_.get(), 0, sizeof header, header);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, masks_.get());
    // Workgroups in a 2D grid (at most 65,535 along x), one dispatch for up to
    // 65,535^2 triangles.
    const size_t gx = std::min<size_t>(count, 65535), gy = (count + gx - 1) / gx;
    glUniform1ui(glGetUniformLocation(p, "u_first"), 0u);
    t1 = MonotonicSeconds();
    glDispatchCompute(GLuint(gx), GLuint(gy), 1);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(masks_.get(), 0, sizeof used, &used);  // waits for the pass
    t2 = MonotonicSeconds();
    if (used <= mask_capacity_) break;
    mask_capacity_ = size_t(used) + used / 4;  // too many masks for the buffer: again with room for all
  }
  glGetNamedBufferSubData(results_.get(), 0, GLsizeiptr(count * 16), res.get());
  r.masks_.resize(std::min<size_t>(used, mask_capacity_));
  if (!r.masks_.empty()) glGetNamedBufferSubData(masks_.get(), 16, GLsizeiptr(r.masks_.size() * 4), r.masks_.data());
  CheckGl("triangle query");
  const double t3 = MonotonicSeconds();

  // Counts as the GPU found them; the triangles with an inside pixel kept
  // for their points (made on demand: TriangleBatchResult::Points).
  size_t hits = 0;
  for (size_t i = 0; i < count; ++i) hits += res[4 * i + 1] > 0;
  r.hit_triangles_.reserve(hits);
  r.hit_mask_.reserve(hits);
  r.hit_size_.reserve(hits);
  for (size_t i = 0; i < count; ++i) {
    const uint32_t* e = &res[4 * i];
    r.tested_[i] = int(e[0]);
    r.inside_[i] = int(e[1]);
    if (e[1] == 0) continue;
    r.hit_of_[i] = uint32_t(r.hit_triangles_.size());
    r.hit_triangles_.push_back(tris[i]);
    r.hit_mask_.push_back(e[2]);
    r.hit_size_.push_back(e[3]);
  }
  r.timing_ = {(t1 - t0) * 1e3, (t2 - t1) * 1e3, (t3 - t2) * 1e3, (MonotonicSeconds() - t3) * 1e3};
  return r;
}

}  // namespace hullpipe::gl
