#include "hullpipe/gl/gl_triangle_query.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "gl_cameras.h"

namespace hullpipe::gl {
namespace {

// One inside fragment as the shader appends it (std430 struct Hit).
struct Hit {
  float world[4];
  uint32_t id[4];
};

const char* kTriVs = R"(#version 450 core
layout(location = 0) in vec2 a_pix;    // vertex in its viewport's pixel coordinates
layout(location = 1) in vec3 a_world;  // vertex in world metres
layout(location = 2) in ivec4 a_cell;  // cell origin x, y in the atlas; triangle index; viewport width
uniform vec2 u_atlas;                  // atlas size in pixels
out vec3 v_world;
flat out ivec4 v_cell;
void main() {
  v_world = a_world;
  v_cell = a_cell;
  gl_Position = vec4((vec2(a_cell.xy) + a_pix) / u_atlas * 2.0 - 1.0, 0.0, 1.0);
}
)";

std::string TriFs() {
  return std::string("#version 450 core\n") + kProjectGlsl + R"(
uniform int u_ncam;
uniform int u_unknown;
uniform int u_required;
uniform vec3 u_wmin;  // workspace box, world metres
uniform vec3 u_wmax;
layout(std430, binding = 0) buffer Counts { uint total; uint tested[]; };
struct Hit { vec4 world; uvec4 id; };  // id: triangle, row-major pixel of its viewport
layout(std430, binding = 1) buffer Points { uint capacity; uint pad[3]; Hit hits[]; };
in vec3 v_world;
flat in ivec4 v_cell;
void main() {
  // No early break: sampler arrays must be indexed with dynamically uniform
  // values (GLSL 4.5), which a divergent break would violate.
  int votes[3] = int[3](0, 0, 0);
  for (int c = 0; c < u_ncam; ++c) votes[VoteOf(c, u_A[c] + u_M[c] * v_world)] += 1;
  bool in_box = all(greaterThanEqual(v_world, u_wmin)) && all(lessThanEqual(v_world, u_wmax));
  bool inside = in_box && votes[0] == 0 && (votes[2] == 0 || u_unknown != 0) && votes[1] >= u_required;
  atomicAdd(tested[v_cell.z], 1u);
  if (inside) {
    uint k = atomicAdd(total, 1u);
    ivec2 p = ivec2(gl_FragCoord.xy) - v_cell.xy;  // pixel in the triangle's viewport
    if (k < capacity) hits[k] = Hit(vec4(v_world, 0.0), uvec4(uint(v_cell.z), uint(p.y * v_cell.w + p.x), 0u, 0u));
  }
}
)";
}

}  // namespace

GlTriangleQuery::GlTriangleQuery(int max_atlas)
    : program_(BuildProgram(kTriVs, TriFs().c_str())), vao_(MakeVertexArray()), vbo_(MakeBuffer()),
      counts_(MakeBuffer()), points_(MakeBuffer()), fbo_(MakeFramebuffer()), max_atlas_(max_atlas) {
  if (max_atlas < 64 || max_atlas > 16384)
    throw std::invalid_argument("GlTriangleQuery: max_atlas must be in [64, 16384]");
  glBindVertexArray(vao_.get());
  glBindBuffer(GL_ARRAY_BUFFER, vbo_.get());
  const GLsizei stride = 9 * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(2 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribIPointer(2, 4, GL_INT, stride, reinterpret_cast<void*>(5 * sizeof(float)));
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
  const GLuint prog = program_.get();
  const Eigen::Vector3f wmin = q.workspace().min.cast<float>(), wmax = q.workspace().max.cast<float>();
  glUniform3fv(glGetUniformLocation(prog, "u_wmin"), 1, wmin.data());
  glUniform3fv(glGetUniformLocation(prog, "u_wmax"), 1, wmax.data());

  std::vector<TriangleViewport> vps;
  vps.reserve(tris.size());
  int cell = 1;
  for (const auto& t : tris) {
    vps.push_back(MakeTriangleViewport(t.a, t.b, t.c, options));
    cell = std::max({cell, vps.back().width, vps.back().height});
  }
  // Cells in a square atlas of at most max_atlas_ pixels a side; more triangles
  // than one atlas holds are drawn in further passes into the same buffers.
  const size_t fit = size_t(max_atlas_ / cell);
  const size_t per_row = std::min(fit, size_t(std::ceil(std::sqrt(double(tris.size())))));
  const size_t per_pass = per_row * fit;
  const int atlas_w = int(per_row) * cell;
  const int atlas_h = int(std::min(fit, (tris.size() + per_row - 1) / per_row)) * cell;

  // Vertices: viewport pixel (2), world point (3), cell x, y, triangle, width (4 ints).
  std::vector<float> verts;
  verts.reserve(tris.size() * 27);
  for (size_t t = 0; t < tris.size(); ++t) {
    const auto& vp = vps[t];
    const Triangle& tr = tris[t];
    const size_t k = t % per_pass;
    const int cx = int(k % per_row) * cell, cy = int(k / per_row) * cell;
    const int ints[4] = {cx, cy, int(t), vp.width};
    for (const auto& [p2, p3] : {std::pair{vp.a2, tr.a}, std::pair{vp.b2, tr.b}, std::pair{vp.c2, tr.c}}) {
      verts.insert(verts.end(), {float(p2.x()), float(p2.y()), float(p3.x()), float(p3.y()), float(p3.z())});
      for (int i : ints) {
        float f;
        std::memcpy(&f, &i, sizeof f);
        verts.push_back(f);
      }
    }
  }
  glNamedBufferData(vbo_.get(), GLsizeiptr(verts.size() * sizeof(float)), verts.data(), GL_STREAM_DRAW);
  const std::vector<uint32_t> zero_counts(tris.size() + 1, 0);
  glNamedBufferData(counts_.get(), GLsizeiptr(zero_counts.size() * sizeof(uint32_t)), zero_counts.data(),
                    GL_DYNAMIC_COPY);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, counts_.get());
  glNamedFramebufferParameteri(fbo_.get(), GL_FRAMEBUFFER_DEFAULT_WIDTH, atlas_w);
  glNamedFramebufferParameteri(fbo_.get(), GL_FRAMEBUFFER_DEFAULT_HEIGHT, atlas_h);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_.get());
  glBindVertexArray(vao_.get());
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_STENCIL_TEST);
  glViewport(0, 0, atlas_w, atlas_h);
  glUniform2f(glGetUniformLocation(prog, "u_atlas"), float(atlas_w), float(atlas_h));

  uint32_t total = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (point_capacity_ < std::max<size_t>(total, 4096)) {
      point_capacity_ = std::max<size_t>(size_t(total) + total / 4, 4096);
      glNamedBufferData(points_.get(), GLsizeiptr(16 + point_capacity_ * sizeof(Hit)), nullptr, GL_DYNAMIC_COPY);
    }
    const uint32_t header[4] = {uint32_t(point_capacity_), 0, 0, 0};
    glNamedBufferSubData(points_.get(), 0, sizeof header, header);
    if (attempt > 0) glNamedBufferSubData(counts_.get(), 0, GLsizeiptr(zero_counts.size() * 4), zero_counts.data());
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, points_.get());
    for (size_t first = 0; first < tris.size(); first += per_pass)
      glDrawArrays(GL_TRIANGLES, GLint(3 * first), GLsizei(3 * std::min(per_pass, tris.size() - first)));
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(counts_.get(), 0, sizeof total, &total);
    if (total <= point_capacity_) break;  // else: too many points for the buffer; again with room for all
  }
  std::vector<uint32_t> tested(tris.size() + 1);
  glGetNamedBufferSubData(counts_.get(), 0, GLsizeiptr(tested.size() * 4), tested.data());
  std::vector<Hit> hits(total);
  if (total > 0) glGetNamedBufferSubData(points_.get(), 16, GLsizeiptr(size_t(total) * sizeof(Hit)), hits.data());
  CheckGl("triangle query");

  // Points by triangle, then in the viewport's row-major pixel order (as the CPU
  // visits them; the GPU appends in no particular order).
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) {
    return a.id[0] != b.id[0] ? a.id[0] < b.id[0] : a.id[1] < b.id[1];
  });
  for (const Hit& h : hits)
    if (h.id[0] < tris.size()) results[h.id[0]].collision_points.emplace_back(h.world[0], h.world[1], h.world[2]);
  for (size_t t = 0; t < tris.size(); ++t) {
    TriangleQueryResult& r = results[t];
    const auto& vp = vps[t];
    const Triangle& tr = tris[t];
    if (vp.height == 1) {
      // Thinner than a pixel: sampled along its spine on the CPU (QueryTriangleCpu).
      r = QueryTriangleCpu(q, tr.a, tr.b, tr.c, options);
      continue;
    }
    r.pixels_tested = int(tested[t + 1]);
    if (r.pixels_tested == 0) {
      // No pixel centre covered (smaller than a pixel): query the centroid, as the CPU does.
      r.pixels_tested = 1;
      const Eigen::Vector3d centroid = (tr.a + tr.b + tr.c) / 3.0;
      if (q.Inside(centroid)) r.collision_points.push_back(centroid);
    }
  }
  return results;
}

}  // namespace hullpipe::gl
