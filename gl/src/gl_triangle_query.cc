#include "hullpipe/gl/gl_triangle_query.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "gl_cameras.h"

namespace hullpipe::gl {
namespace {

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

}  // namespace

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
