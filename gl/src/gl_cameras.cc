#include "gl_cameras.h"

#include <limits>
#include <stdexcept>
#include <string>

namespace hullpipe::gl {

void SetCameras(GLuint program, const VolumeQuery& q, std::vector<Texture>& maps,
                const std::vector<Eigen::Matrix3f>& M, const std::vector<Eigen::Vector3f>& A, bool upload) {
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
    glUniform1f(glGetUniformLocation(program, ("u_skew" + i).c_str()), f.skew);
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

GpuCamera PackCamera(const hullpipe::detail::FastCamera& f, const Eigen::Matrix3d& M, const Eigen::Vector3d& A,
                     const cv::Rect& object_rect) {
  GpuCamera g{};
  const cv::Rect& o = object_rect;
  g.rect[0] = float(o.x), g.rect[1] = float(o.y), g.rect[2] = float(o.x + o.width), g.rect[3] = float(o.y + o.height);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) g.m[4 * r + c] = float(M(r, c));
  for (int i = 0; i < 3; ++i) g.a[i] = float(A[i]);
  g.a[3] = f.skew;
  g.intr[0] = f.fx, g.intr[1] = f.fy, g.intr[2] = f.cx, g.intr[3] = f.cy;
  g.k[0] = f.k1, g.k[1] = f.k2, g.k[2] = f.k3, g.k[3] = f.r2max;
  g.p[0] = f.p1, g.p[1] = f.p2, g.p[2] = float(f.width), g.p[3] = float(f.height);
  return g;
}

void SetViewUniforms(GLuint program, const NovelView& view, cv::Point origin, const Aabb* hull_box) {
  glUniform4f(glGetUniformLocation(program, "u_view"), float(view.fx), float(view.fy), float(view.cx), float(view.cy));
  glUniform2f(glGetUniformLocation(program, "u_origin"), float(origin.x), float(origin.y));
  const Eigen::Matrix3f Rwe = view.world_from_eye.rotation.cast<float>();
  const Eigen::Vector3f O = view.world_from_eye.translation.cast<float>();
  glUniformMatrix3fv(glGetUniformLocation(program, "u_Rwe"), 1, GL_FALSE, Rwe.data());
  glUniform3fv(glGetUniformLocation(program, "u_O"), 1, O.data());
  if (hull_box) {
    const Eigen::Vector3f bmin = hull_box->min.cast<float>(), bmax = hull_box->max.cast<float>();
    glUniform3fv(glGetUniformLocation(program, "u_bmin"), 1, bmin.data());
    glUniform3fv(glGetUniformLocation(program, "u_bmax"), 1, bmax.data());
  }
}

GpuCamera PackCamera(const Camera& c) {
  hullpipe::detail::FastCamera f{};
  f.fx = float(c.fx), f.fy = float(c.fy), f.cx = float(c.cx), f.cy = float(c.cy), f.skew = float(c.skew);
  f.k1 = float(c.distortion[0]), f.k2 = float(c.distortion[1]);
  f.p1 = float(c.distortion[2]), f.p2 = float(c.distortion[3]), f.k3 = float(c.distortion[4]);
  const double r2 = c.MaxValidRadius2();
  f.r2max = r2 > 1e30 ? std::numeric_limits<float>::max() : float(r2);
  f.width = c.width, f.height = c.height;
  f.width_f = float(c.width), f.height_f = float(c.height);
  return PackCamera(f, c.cam_from_world.rotation, c.cam_from_world.translation, cv::Rect(0, 0, c.width, c.height));
}

}  // namespace hullpipe::gl
