#include "hullpipe/gl/gl_objects.h"

#include <vector>

namespace hullpipe::gl {

void CheckGl(const char* what) {
  const GLenum e = glGetError();
  if (e != GL_NO_ERROR) throw GlError(std::string(what) + ": GL error 0x" + [&] {
    char buf[16];
    std::snprintf(buf, sizeof buf, "%04x", e);
    return std::string(buf);
  }());
}

Texture MakeTexture() {
  GLuint n = 0;
  glGenTextures(1, &n);
  return Texture(n);
}
Framebuffer MakeFramebuffer() {
  GLuint n = 0;
  glGenFramebuffers(1, &n);
  return Framebuffer(n);
}
Renderbuffer MakeRenderbuffer() {
  GLuint n = 0;
  glGenRenderbuffers(1, &n);
  return Renderbuffer(n);
}
Buffer MakeBuffer() {
  GLuint n = 0;
  glGenBuffers(1, &n);
  return Buffer(n);
}
VertexArray MakeVertexArray() {
  GLuint n = 0;
  glGenVertexArrays(1, &n);
  return VertexArray(n);
}

namespace {
GLuint Compile(GLenum type, const char* src) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
    std::vector<char> log(size_t(std::max(len, 1)));
    glGetShaderInfoLog(s, len, nullptr, log.data());
    glDeleteShader(s);
    throw GlError(std::string("shader compile: ") + log.data());
  }
  return s;
}
}  // namespace

Program BuildProgram(const char* vs, const char* fs) {
  const GLuint v = Compile(GL_VERTEX_SHADER, vs);
  GLuint f = 0;
  try {
    f = Compile(GL_FRAGMENT_SHADER, fs);
  } catch (...) {
    glDeleteShader(v);
    throw;
  }
  Program p(glCreateProgram());
  glAttachShader(p.get(), v);
  glAttachShader(p.get(), f);
  glLinkProgram(p.get());
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(p.get(), GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(p.get(), GL_INFO_LOG_LENGTH, &len);
    std::vector<char> log(size_t(std::max(len, 1)));
    glGetProgramInfoLog(p.get(), len, nullptr, log.data());
    throw GlError(std::string("program link: ") + log.data());
  }
  return p;
}

}  // namespace hullpipe::gl
