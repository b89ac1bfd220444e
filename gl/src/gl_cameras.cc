#include "gl_cameras.h"

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

}  // namespace hullpipe::gl
