// Move-only RAII owners of OpenGL objects, and shader compilation. Each owner
// deletes its object on destruction; the context must be current.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

#define GL_GLEXT_PROTOTYPES
#include <GL/glcorearb.h>

namespace hullpipe::gl {

/// A GL call or shader build failed; what() names it.
class GlError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Throws GlError naming `what` if glGetError reports an error.
void CheckGl(const char* what);

/// Generic owner: Deleter(GLuint) frees the name.
template <void (*Deleter)(GLuint)>
class GlName {
 public:
  GlName() = default;
  explicit GlName(GLuint name) : name_(name) {}
  ~GlName() {
    if (name_) Deleter(name_);
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  GlName(GlName&& o) noexcept : name_(std::exchange(o.name_, 0)) {}
  GlName& operator=(GlName&& o) noexcept {
    if (this != &o) {
      if (name_) Deleter(name_);
      name_ = std::exchange(o.name_, 0);
    }
    return *this;
  }
  GLuint get() const { return name_; }

 private:
  GLuint name_ = 0;
};

namespace detail {
inline void DeleteTexture(GLuint n) { glDeleteTextures(1, &n); }
inline void DeleteFramebuffer(GLuint n) { glDeleteFramebuffers(1, &n); }
inline void DeleteRenderbuffer(GLuint n) { glDeleteRenderbuffers(1, &n); }
inline void DeleteBuffer(GLuint n) { glDeleteBuffers(1, &n); }
inline void DeleteVertexArray(GLuint n) { glDeleteVertexArrays(1, &n); }
inline void DeleteProgram(GLuint n) { glDeleteProgram(n); }
inline void DeleteQuery(GLuint n) { glDeleteQueries(1, &n); }
}  // namespace detail

using Texture = GlName<detail::DeleteTexture>;
using Framebuffer = GlName<detail::DeleteFramebuffer>;
using Renderbuffer = GlName<detail::DeleteRenderbuffer>;
using Buffer = GlName<detail::DeleteBuffer>;
using VertexArray = GlName<detail::DeleteVertexArray>;
using Program = GlName<detail::DeleteProgram>;
using Query = GlName<detail::DeleteQuery>;

Texture MakeTexture();
/// A texture created for `target` (glCreateTextures: usable with the DSA calls at once).
Texture MakeTexture(GLenum target);
Framebuffer MakeFramebuffer();
Renderbuffer MakeRenderbuffer();
Buffer MakeBuffer();
VertexArray MakeVertexArray();
/// A query object of `target` (glCreateQueries), e.g. GL_TIMESTAMP for
/// glQueryCounter: where the GPU's time goes, for the benchmarks.
Query MakeQuery(GLenum target);

/// Compiles and links a vertex + fragment shader pair (GLSL 450 core). Throws
/// GlError with the compiler's log.
Program BuildProgram(const char* vertex_src, const char* fragment_src);

/// Compiles and links a compute shader (GLSL 450 core). Throws GlError with the
/// compiler's log.
Program BuildComputeProgram(const char* compute_src);

/// A GL fence (glFenceSync), move-only: Insert() after commands, Wait() blocks
/// until the GPU has finished them (throws GlError if the wait fails).
class Fence {
 public:
  Fence() = default;
  ~Fence();
  Fence(const Fence&) = delete;
  Fence& operator=(const Fence&) = delete;
  Fence(Fence&& o) noexcept : sync_(std::exchange(o.sync_, nullptr)) {}
  Fence& operator=(Fence&& o) noexcept;
  /// Replaces any earlier fence with one after the commands issued so far.
  void Insert();
  /// Returns once the fenced commands are done (at once if none is pending).
  void Wait();

 private:
  GLsync sync_ = nullptr;
};

}  // namespace hullpipe::gl
