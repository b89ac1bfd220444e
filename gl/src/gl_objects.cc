#include "hullpipe/gl/gl_objects.h"

#include <initializer_list>
#include <utility>

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
Texture MakeTexture(GLenum target) {
  GLuint n = 0;
  glCreateTextures(target, 1, &n);
  return Texture(n);
}
Framebuffer MakeFramebuffer() {
  GLuint n = 0;
  glCreateFramebuffers(1, &n);
  return Framebuffer(n);
}
Renderbuffer MakeRenderbuffer() {
  GLuint n = 0;
  glGenRenderbuffers(1, &n);
  return Renderbuffer(n);
}
Query MakeQuery(GLenum target) {
  GLuint n = 0;
  glCreateQueries(target, 1, &n);
  if (!n) throw GlError("glCreateQueries failed");
  return Query(n);
}

Buffer MakeBuffer() {
  GLuint n = 0;
  glCreateBuffers(1, &n);  // exists at once: usable with the DSA calls
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

namespace {
Program Link(std::initializer_list<GLuint> shaders) {
  Program p(glCreateProgram());
  for (GLuint s : shaders) glAttachShader(p.get(), s);
  glLinkProgram(p.get());
  for (GLuint s : shaders) glDeleteShader(s);
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
  return Link({v, f});
}

Program BuildComputeProgram(const char* cs) { return Link({Compile(GL_COMPUTE_SHADER, cs)}); }

Fence::~Fence() {
  if (sync_) glDeleteSync(sync_);
}

Fence& Fence::operator=(Fence&& o) noexcept {
  if (this != &o) {
    if (sync_) glDeleteSync(sync_);
    sync_ = std::exchange(o.sync_, nullptr);
  }
  return *this;
}

void Fence::Insert() {
  if (sync_) glDeleteSync(sync_);
  sync_ = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
}

void Fence::Wait() {
  if (!sync_) return;
  // Flush on the first wait so the fence is sure to be signalled; 1 s slices.
  GLbitfield flags = GL_SYNC_FLUSH_COMMANDS_BIT;
  for (;;) {
    const GLenum r = glClientWaitSync(sync_, flags, 1000000000ull);
    if (r == GL_ALREADY_SIGNALED || r == GL_CONDITION_SATISFIED) break;
    if (r == GL_WAIT_FAILED) throw GlError("glClientWaitSync failed");
    flags = 0;
  }
  glDeleteSync(sync_);
  sync_ = nullptr;
}

}  // namespace hullpipe::gl
