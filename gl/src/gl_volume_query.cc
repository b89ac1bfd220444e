#include "hullpipe/gl/gl_volume_query.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace hullpipe::gl {
namespace {

// Shared GLSL: camera c's projection with OpenCV distortion and map lookup. The
// point is X_c = u_A[c] + u_M[c] * x, whose meaning each pass sets.
const char* kProjectGlsl = R"(
const int MAXCAM = 16;
uniform mat3 u_M[MAXCAM];
uniform vec3 u_A[MAXCAM];
uniform vec4 u_intr[MAXCAM];  // fx fy cx cy
uniform vec4 u_k[MAXCAM];     // k1 k2 k3 r2max
uniform vec4 u_p[MAXCAM];     // p1 p2 width height
uniform sampler2D u_maps[MAXCAM];
// Where camera c sees camera-frame point X: its pixel, or (-1, -1) if unseen.
vec2 Pixel(int c, vec3 X) {
  if (!(X.z > 1e-6)) return vec2(-1.0);
  float iz = 1.0 / X.z;
  vec2 xn = X.xy * iz;
  float r2 = dot(xn, xn);
  if (!(r2 <= u_k[c].w)) return vec2(-1.0);
  float radial = 1.0 + r2 * (u_k[c].x + r2 * (u_k[c].y + r2 * u_k[c].z));
  float xy = xn.x * xn.y;
  vec2 xd = vec2(xn.x * radial + 2.0 * u_p[c].x * xy + u_p[c].y * (r2 + 2.0 * xn.x * xn.x),
                 xn.y * radial + u_p[c].x * (r2 + 2.0 * xn.y * xn.y) + 2.0 * u_p[c].y * xy);
  vec2 uv = vec2(u_intr[c].x * xd.x + u_intr[c].z, u_intr[c].y * xd.y + u_intr[c].w);
  if (!(uv.x >= 0.0 && uv.y >= 0.0 && uv.x < u_p[c].z && uv.y < u_p[c].w)) return vec2(-1.0);
  return uv;
}
// Camera c's vote on X: 0 background, 1 object, 2 unseen (as VolumeQuery::VoteFast).
int VoteOf(int c, vec3 X) {
  vec2 uv = Pixel(c, X);
  if (uv.x < 0.0) return 2;
  return texelFetch(u_maps[c], ivec2(uv), 0).r > 0.0 ? 1 : 0;
}
)";

const char* kQuadVs = R"(#version 450 core
void main() {
  vec2 p = vec2((gl_VertexID & 1) != 0 ? 3.0 : -1.0, (gl_VertexID & 2) != 0 ? 3.0 : -1.0);
  gl_Position = vec4(p, 0.0, 1.0);
}
)";

std::string SweepCountFs() {
  return std::string("#version 450 core\n") + kProjectGlsl + R"(
uniform int u_cam;
uniform float u_depth;
uniform int u_unknown;  // 1: a camera that cannot see the point does not veto it
uniform vec4 u_view;    // fx fy cx cy of the novel view
uniform vec2 u_origin;  // tile origin in view pixels
out vec4 o_colour;
void main() {
  // Framebuffer row r is image row tile.y + r (no flip: rays are computed here).
  vec2 uv = u_origin + gl_FragCoord.xy;
  vec3 ray = vec3((uv.x - u_view.z) / u_view.x, (uv.y - u_view.w) / u_view.y, 1.0);
  vec3 X = u_A[u_cam] + u_depth * (u_M[u_cam] * ray);
  int v = VoteOf(u_cam, X);
  if (!(v == 1 || (u_unknown != 0 && v == 2))) discard;
  o_colour = vec4(0.0);
}
)";
}

std::string SweepResolveFs() {
  return std::string("#version 450 core\n") + kProjectGlsl + R"(
uniform int u_ncam;
uniform int u_unknown;
uniform int u_required;  // cameras that must see the point (kUnknown)
uniform float u_depth;
uniform float u_rank;  // (k + 1) / (planes + 1): the first plane wins the depth test
uniform vec4 u_view;
uniform vec2 u_origin;
uniform mat3 u_Rwe;    // world_from_eye rotation
uniform vec3 u_O;      // eye centre, world
uniform vec3 u_bmin;   // hull box: outside it nothing is hull (as on the CPU)
uniform vec3 u_bmax;
out vec4 o_depth;
void main() {
  vec2 uv = u_origin + gl_FragCoord.xy;
  vec3 ray = vec3((uv.x - u_view.z) / u_view.x, (uv.y - u_view.w) / u_view.y, 1.0);
  vec3 X = u_O + u_depth * (u_Rwe * ray);
  if (any(lessThan(X, u_bmin)) || any(greaterThan(X, u_bmax))) discard;
  if (u_unknown != 0) {
    // The stencil says no camera voted background; enough must have seen it.
    int seen = 0;
    for (int c = 0; c < u_ncam; ++c)
      if (Pixel(c, u_A[c] + u_depth * (u_M[c] * ray)).x >= 0.0) ++seen;
    if (seen < u_required) discard;
  }
  gl_FragDepth = u_rank;
  o_depth = vec4(u_depth, 0.0, 0.0, 0.0);
}
)";
}

const char* kTriVs = R"(#version 450 core
layout(location = 0) in vec2 a_pix;    // vertex in its viewport's pixel coordinates
layout(location = 1) in vec3 a_world;  // vertex in world metres
uniform vec2 u_vp;                     // viewport size in pixels
out vec3 v_world;
void main() {
  v_world = a_world;
  gl_Position = vec4(a_pix / u_vp * 2.0 - 1.0, 0.0, 1.0);
}
)";

std::string TriFs() {
  return std::string("#version 450 core\n") + kProjectGlsl + R"(
uniform int u_ncam;
uniform int u_unknown;
uniform int u_required;
uniform vec3 u_wmin;  // workspace box, world metres
uniform vec3 u_wmax;
in vec3 v_world;
out vec4 o_hit;
void main() {
  // No early break: sampler arrays must be indexed with dynamically uniform
  // values (GLSL 4.5), which a divergent break would violate.
  int votes[3] = int[3](0, 0, 0);
  for (int c = 0; c < u_ncam; ++c) votes[VoteOf(c, u_A[c] + u_M[c] * v_world)] += 1;
  bool in_box = all(greaterThanEqual(v_world, u_wmin)) && all(lessThanEqual(v_world, u_wmax));
  bool inside = in_box && votes[0] == 0 && (votes[2] == 0 || u_unknown != 0) && votes[1] >= u_required;
  o_hit = vec4(v_world, inside ? 1.0 : 0.5);
}
)";
}

// Uploads maps as R8 textures (row 0 of the image = texel row 0) and sets the
// per-camera uniforms; M/A given per camera by the caller.
void SetCameras(GLuint program, const VolumeQuery& q, std::vector<Texture>& maps,
                const std::vector<Eigen::Matrix3f>& M, const std::vector<Eigen::Vector3f>& A, bool upload = true) {
  const auto& views = q.views();
  const auto& fast = q.fast();
  if (views.size() > size_t(kMaxGlCameras))
    throw std::invalid_argument("GL volume query handles at most 16 cameras");
  while (maps.size() < views.size()) maps.push_back(MakeTexture());
  glUseProgram(program);
  for (size_t c = 0; c < views.size(); ++c) {
    const cv::Mat& map = views[c].map;
    if (upload) {
    glActiveTexture(GLenum(GL_TEXTURE0 + c));
    glBindTexture(GL_TEXTURE_2D, maps[c].get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, GLint(map.step[0]));
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R8, map.cols, map.rows, 0, GL_RED, GL_UNSIGNED_BYTE, map.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    }
    const std::string i = "[" + std::to_string(c) + "]";
    const auto& f = fast[c];
    // Eigen is column-major like GL: no transpose.
    glUniformMatrix3fv(glGetUniformLocation(program, ("u_M" + i).c_str()), 1, GL_FALSE, M[c].data());
    glUniform3fv(glGetUniformLocation(program, ("u_A" + i).c_str()), 1, A[c].data());
    glUniform4f(glGetUniformLocation(program, ("u_intr" + i).c_str()), f.fx, f.fy, f.cx, f.cy);
    glUniform4f(glGetUniformLocation(program, ("u_k" + i).c_str()), f.k1, f.k2, f.k3,
                f.r2max);
    glUniform4f(glGetUniformLocation(program, ("u_p" + i).c_str()), f.p1, f.p2, float(f.width),
                float(f.height));
    glUniform1i(glGetUniformLocation(program, ("u_maps" + i).c_str()), GLint(c));
  }
  const bool unknown = q.options().out_of_view == OutOfView::kUnknown;
  glUniform1i(glGetUniformLocation(program, "u_unknown"), unknown ? 1 : 0);
  glUniform1i(glGetUniformLocation(program, "u_required"), GLint(q.required_seen()));
  glUniform1i(glGetUniformLocation(program, "u_ncam"), GLint(views.size()));
  CheckGl("upload maps and camera uniforms");
}

}  // namespace

GlPlaneSweep::GlPlaneSweep()
    : count_program_(BuildProgram(kQuadVs, SweepCountFs().c_str())),
      resolve_program_(BuildProgram(kQuadVs, SweepResolveFs().c_str())),
      vao_(MakeVertexArray()),
      fbo_(MakeFramebuffer()) {}

void GlPlaneSweep::EnsureTarget(int w, int h) {
  if (w == width_ && h == height_) return;
  glActiveTexture(GL_TEXTURE0 + kMaxGlCameras);  // units 0..15 hold the maps
  depth_out_ = MakeTexture();
  glBindTexture(GL_TEXTURE_2D, depth_out_.get());
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, w, h, 0, GL_RED, GL_FLOAT, nullptr);
  depth_stencil_ = MakeRenderbuffer();
  glBindRenderbuffer(GL_RENDERBUFFER, depth_stencil_.get());
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, w, h);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, depth_out_.get(), 0);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_stencil_.get());
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw GlError("plane sweep framebuffer incomplete");
  width_ = w;
  height_ = h;
}

cv::Mat GlPlaneSweep::Sweep(const VolumeQuery& q, const NovelView& view, const std::vector<double>& depths,
                            const cv::Rect& tile) {
  view.Check();
  cv::Mat out(tile.height, tile.width, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  if (depths.empty() || tile.area() == 0 || q.hull_box().empty()) return out;
  EnsureTarget(tile.width, tile.height);
  const size_t n = q.size();
  std::vector<Eigen::Matrix3f> M(n);
  std::vector<Eigen::Vector3f> A(n);
  for (size_t c = 0; c < n; ++c) {
    const Rigid3d& cw = q.views()[c].camera.cam_from_world;
    M[c] = (cw.rotation * view.world_from_eye.rotation).cast<float>();
    A[c] = (cw * view.world_from_eye.translation).cast<float>();
  }
  SetCameras(count_program_.get(), q, maps_, M, A);
  const GLuint cp = count_program_.get(), rp = resolve_program_.get();
  glUniform4f(glGetUniformLocation(cp, "u_view"), float(view.fx), float(view.fy), float(view.cx), float(view.cy));
  glUniform2f(glGetUniformLocation(cp, "u_origin"), float(tile.x), float(tile.y));
  const GLint loc_cam = glGetUniformLocation(cp, "u_cam"), loc_d = glGetUniformLocation(cp, "u_depth");
  const GLint loc_rd = glGetUniformLocation(rp, "u_depth"), loc_rank = glGetUniformLocation(rp, "u_rank");
  SetCameras(rp, q, maps_, M, A, /*upload=*/false);  // leaves rp in use
  glUniform4f(glGetUniformLocation(rp, "u_view"), float(view.fx), float(view.fy), float(view.cx), float(view.cy));
  glUniform2f(glGetUniformLocation(rp, "u_origin"), float(tile.x), float(tile.y));
  const Eigen::Matrix3f Rwe = view.world_from_eye.rotation.cast<float>();
  const Eigen::Vector3f O = view.world_from_eye.translation.cast<float>();
  const Eigen::Vector3f bmin = q.hull_box().min.cast<float>(), bmax = q.hull_box().max.cast<float>();
  glUniformMatrix3fv(glGetUniformLocation(rp, "u_Rwe"), 1, GL_FALSE, Rwe.data());
  glUniform3fv(glGetUniformLocation(rp, "u_O"), 1, O.data());
  glUniform3fv(glGetUniformLocation(rp, "u_bmin"), 1, bmin.data());
  glUniform3fv(glGetUniformLocation(rp, "u_bmax"), 1, bmax.data());

  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
  glViewport(0, 0, tile.width, tile.height);
  glBindVertexArray(vao_.get());
  const float inf = std::numeric_limits<float>::infinity();
  const float clear_colour[4] = {inf, 0, 0, 0};
  glClearBufferfv(GL_COLOR, 0, clear_colour);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_STENCIL_TEST);
  const double planes = double(depths.size());
  for (size_t k = 0; k < depths.size(); ++k) {
    glClearStencil(0);
    glClear(GL_STENCIL_BUFFER_BIT);
    // Count: each camera's map projected onto plane k increments the stencil.
    glUseProgram(cp);
    glUniform1f(loc_d, float(depths[k]));
    glDisable(GL_DEPTH_TEST);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glStencilFunc(GL_ALWAYS, 0, 0xff);
    glStencilOp(GL_KEEP, GL_KEEP, GL_INCR);
    for (size_t c = 0; c < n; ++c) {
      glUniform1i(loc_cam, GLint(c));
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
    // Resolve: where the count is n, the first such plane keeps its depth.
    glUseProgram(rp);
    glUniform1f(loc_rd, float(depths[k]));
    glUniform1f(loc_rank, float((double(k) + 1.0) / (planes + 1.0)));
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    glStencilFunc(GL_EQUAL, GLint(n), 0xff);
    glStencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }
  glDisable(GL_STENCIL_TEST);
  glDisable(GL_DEPTH_TEST);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, tile.width, tile.height, GL_RED, GL_FLOAT, out.data);
  CheckGl("plane sweep");
  return out;
}

GlTriangleQuery::GlTriangleQuery()
    : program_(BuildProgram(kTriVs, TriFs().c_str())), vao_(MakeVertexArray()), vbo_(MakeBuffer()),
      fbo_(MakeFramebuffer()) {
  glBindVertexArray(vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, vbo_.get());
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 5 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 5 * sizeof(float), reinterpret_cast<void*>(2 * sizeof(float)));
  CheckGl("triangle query setup");
}

std::vector<TriangleQueryResult> GlTriangleQuery::Query(const VolumeQuery& q, const std::vector<Triangle>& tris,
                                                        const TriangleQueryOptions& options) {
  options.Check();
  std::vector<TriangleQueryResult> results(tris.size());
  if (tris.empty()) return results;
  const size_t n = q.size();
  std::vector<Eigen::Matrix3f> M(n);
  std::vector<Eigen::Vector3f> A(n);
  for (size_t c = 0; c < n; ++c) {
    M[c] = q.views()[c].camera.cam_from_world.rotation.cast<float>();
    A[c] = q.views()[c].camera.cam_from_world.translation.cast<float>();
  }
  SetCameras(program_.get(), q, maps_, M, A);
  const Eigen::Vector3f wmin = q.workspace().min.cast<float>(), wmax = q.workspace().max.cast<float>();
  glUniform3fv(glGetUniformLocation(program_.get(), "u_wmin"), 1, wmin.data());
  glUniform3fv(glGetUniformLocation(program_.get(), "u_wmax"), 1, wmax.data());
  const GLint loc_vp = glGetUniformLocation(program_.get(), "u_vp");

  std::vector<TriangleViewport> vps;
  vps.reserve(tris.size());
  int cell = 1;
  for (const auto& t : tris) {
    vps.push_back(MakeTriangleViewport(t.a, t.b, t.c, options));
    cell = std::max({cell, vps.back().width, vps.back().height});
  }
  const int atlas = 1024;
  const int per_row = std::max(1, atlas / cell);
  const size_t per_pass = size_t(per_row) * size_t(per_row);
  if (atlas_ != atlas) {
    glActiveTexture(GL_TEXTURE0 + kMaxGlCameras);  // units 0..15 hold the maps
    colour_ = MakeTexture();
    glBindTexture(GL_TEXTURE_2D, colour_.get());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, atlas, atlas, 0, GL_RGBA, GL_FLOAT, nullptr);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_.get(), 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw GlError("triangle query framebuffer incomplete");
    atlas_ = atlas;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
  glBindVertexArray(vao_.get());
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_STENCIL_TEST);
  std::vector<float> verts;
  cv::Mat readback;
  for (size_t first = 0; first < tris.size(); first += per_pass) {
    const size_t count = std::min(per_pass, tris.size() - first);
    verts.clear();
    for (size_t t = first; t < first + count; ++t) {
      const auto& vp = vps[t];
      const Triangle& tr = tris[t];
      for (const auto& [p2, p3] : {std::pair{vp.a2, tr.a}, std::pair{vp.b2, tr.b}, std::pair{vp.c2, tr.c}}) {
        verts.insert(verts.end(), {float(p2.x()), float(p2.y()), float(p3.x()), float(p3.y()), float(p3.z())});
      }
    }
    glBindBuffer(GL_ARRAY_BUFFER, vbo_.get());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(verts.size() * sizeof(float)), verts.data(), GL_STREAM_DRAW);
    const float zero[4] = {0, 0, 0, 0};
    glViewport(0, 0, atlas, atlas);
    glClearBufferfv(GL_COLOR, 0, zero);
    const int rows_used = int((count + size_t(per_row) - 1) / size_t(per_row));
    for (size_t k = 0; k < count; ++k) {
      const auto& vp = vps[first + k];
      const int cx = int(k % size_t(per_row)) * cell, cy = int(k / size_t(per_row)) * cell;
      glViewport(cx, cy, vp.width, vp.height);
      glUniform2f(loc_vp, float(vp.width), float(vp.height));
      glDrawArrays(GL_TRIANGLES, GLint(3 * k), 3);
    }
    readback.create(rows_used * cell, atlas, CV_32FC4);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    glReadPixels(0, 0, atlas, rows_used * cell, GL_RGBA, GL_FLOAT, readback.data);
    CheckGl("triangle query");
    for (size_t k = 0; k < count; ++k) {
      const auto& vp = vps[first + k];
      const int cx = int(k % size_t(per_row)) * cell, cy = int(k / size_t(per_row)) * cell;
      TriangleQueryResult& r = results[first + k];
      if (vp.height == 1) {
        // Thinner than a pixel: sampled along its spine on the CPU (QueryTriangleCpu).
        const Triangle& tr = tris[first + k];
        r = QueryTriangleCpu(q, tr.a, tr.b, tr.c, options);
        continue;
      }
      for (int j = 0; j < vp.height; ++j) {
        const cv::Vec4f* row = readback.ptr<cv::Vec4f>(cy + j) + cx;
        for (int i = 0; i < vp.width; ++i) {
          if (row[i][3] == 0.0f) continue;
          ++r.pixels_tested;
          if (row[i][3] == 1.0f) r.collision_points.emplace_back(row[i][0], row[i][1], row[i][2]);
        }
      }
      if (r.pixels_tested == 0) {
        // No pixel centre covered (smaller than a pixel): query the centroid, as the CPU does.
        const Triangle& tr = tris[first + k];
        r.pixels_tested = 1;
        const Eigen::Vector3d centroid = (tr.a + tr.b + tr.c) / 3.0;
        if (q.Inside(centroid)) r.collision_points.push_back(centroid);
      }
    }
  }
  return results;
}

}  // namespace hullpipe::gl
