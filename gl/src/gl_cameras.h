// What the GL passes share (private to hullpipe_gl): the GLSL of a camera's
// projection with OpenCV distortion and its vote on a point (as
// VolumeQuery::VoteFast), the upload of the n object-pixel maps and camera
// uniforms, and the eye-ray uniforms of the sweeps and the texturing pass.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "hullpipe/gl/gl_objects.h"
#include "hullpipe/gl/gl_plane_sweep.h"  // kMaxGlCameras
#include "hullpipe/reconstruction/plane_sweep.h"  // NovelView
#include "hullpipe/reconstruction/volume_query.h"

namespace hullpipe::gl {

// Shared GLSL: camera c's projection with OpenCV distortion and map lookup. The
// point is X_c = u_A[c] + u_M[c] * x, whose meaning each pass sets.
inline const char* kProjectGlsl = R"(
const int MAXCAM = 16;
uniform mat3 u_M[MAXCAM];
uniform vec3 u_A[MAXCAM];
uniform vec4 u_intr[MAXCAM];  // fx fy cx cy
uniform float u_skew[MAXCAM]; // K's row 0, column 1 (Camera::skew)
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
  vec2 uv = vec2(u_intr[c].x * xd.x + u_skew[c] * xd.y + u_intr[c].z, u_intr[c].y * xd.y + u_intr[c].w);
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

// Shared GLSL of the compute passes: cameras in a shader storage buffer (any
// number of them), their maps in one texture array, so every camera is tested in
// one invocation without indexing sampler arrays. Camera c's point for a pass
// parameter d and direction ray is X_c = a + d * (M ray), M's rows m0..m2.
inline const char* kCameraBufferGlsl = R"(
struct Cam {
  vec4 m0, m1, m2;  // rows of M
  vec4 a;           // xyz: A; w: skew (K's row 0, column 1)
  vec4 intr;        // fx fy cx cy
  vec4 k;           // k1 k2 k3 r2max
  vec4 p;           // p1 p2 width height
  vec4 rect;        // the map's object rectangle [x0, x1) x [y0, y1): background outside
};
layout(std430, binding = 0) readonly buffer Cams { Cam cams[]; };
// Where the camera of entry c sees camera-frame point X: its pixel, or (-1, -1)
// if unseen (as VolumeQuery::VoteFast and Camera::Project).
vec2 CamPixel(int c, vec3 X) {
  if (!(X.z > 1e-6)) return vec2(-1.0);
  float iz = 1.0 / X.z;
  vec2 xn = X.xy * iz;
  precise float r2 = xn.x * xn.x + xn.y * xn.y;
  vec4 k = cams[c].k, p = cams[c].p, intr = cams[c].intr;
  if (!(r2 <= k.w)) return vec2(-1.0);
  precise float radial = 1.0 + r2 * (k.x + r2 * (k.y + r2 * k.z));
  precise float xy = xn.x * xn.y;
  precise vec2 xd = vec2(xn.x * radial + 2.0 * p.x * xy + p.y * (r2 + 2.0 * xn.x * xn.x),
                         xn.y * radial + p.x * (r2 + 2.0 * xn.y * xn.y) + 2.0 * p.y * xy);
  precise vec2 uv = vec2(intr.x * xd.x + cams[c].a.w * xd.y + intr.z, intr.y * xd.y + intr.w);
  if (!(uv.x >= 0.0 && uv.y >= 0.0 && uv.x < p.z && uv.y < p.w)) return vec2(-1.0);
  return uv;
}
)";

/// One camera as kCameraBufferGlsl's Cam (std430: 32 floats).
struct GpuCamera {
  float m[12];
  float a[4];  ///< A, then the skew
  float intr[4];
  float k[4];
  float p[4];
  float rect[4];  ///< x0, y0, x1, y1 of the map's object pixels (the whole image if not known)
};

/// Packs a camera for a pass where X_c = A + d * (M ray): M and A in double, then
/// rounded to float; intrinsics and distortion as VolumeQuery's FastCamera (which
/// must be the camera's); `object_rect` its map's object pixels' rectangle.
GpuCamera PackCamera(const hullpipe::detail::FastCamera& f, const Eigen::Matrix3d& M, const Eigen::Vector3d& A,
                     const cv::Rect& object_rect);
/// The same for a Camera: X_c = A + M X with M, A its cam_from_world (texturing).
GpuCamera PackCamera(const Camera& camera);

/// Uploads maps as R8 textures (row 0 of the image = texel row 0) and sets the
/// per-camera uniforms of `program`; camera c's point is X_c = A[c] + M[c] * x.
/// Throws std::invalid_argument for more than kMaxGlCameras cameras, GlError on
/// a GL error.
void SetCameras(GLuint program, const VolumeQuery& q, std::vector<Texture>& maps,
                const std::vector<Eigen::Matrix3f>& M, const std::vector<Eigen::Vector3f>& A, bool upload = true);

/// Sets the eye-ray uniforms of `program` (in use) that the sweeps and the
/// texturing pass share: u_view (fx, fy, cx, cy), u_origin (the region's top-left
/// pixel in the view), u_Rwe and u_O (world_from_eye), and, when `hull_box` is
/// given, u_bmin and u_bmax (world metres).
void SetViewUniforms(GLuint program, const NovelView& view, cv::Point origin, const Aabb* hull_box = nullptr);

}  // namespace hullpipe::gl
