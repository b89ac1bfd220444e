#include "hullpipe/gl/gl_plane_sweep.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "gl_cameras.h"

namespace hullpipe::gl {
namespace {

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
  SetViewUniforms(rp, view, tile.tl(), &q.hull_box());

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

}  // namespace hullpipe::gl
