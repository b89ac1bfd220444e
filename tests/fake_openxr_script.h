// The headset script of tests/fake_openxr_runtime.cc, shared with the tests
// that check what hullpipe_openxr makes of it. OpenXR's conventions: the
// reference space y up, a view looking along its -z, XrFovf angles in radians.
#pragma once

#include <cmath>
#include <cstdint>

namespace hullpipe::fake_xr {

/// The head's turn about the space's +y axis, radians, and half the IPD, metres.
constexpr double kYaw = 0.3, kHalfIpd = 0.032;

struct ScriptedEye {
  double position[3];          ///< In the reference space, metres.
  double orientation_xyzw[4];  ///< space_from_view, OpenXR's view axes.
  float fov[4];                ///< left, right, up, down.
};

/// Eye `eye` (0 left, 1 right) at frame n: the head at (0.001 n, 1.6, -0.5),
/// turned kYaw about +y, the eye kHalfIpd along the head's -x or +x.
inline ScriptedEye EyeAt(uint64_t n, int eye) {
  const double side = eye == 0 ? -kHalfIpd : kHalfIpd;
  // The head's x axis: the turn about +y takes (1, 0, 0) to (cos, 0, -sin).
  return ScriptedEye{{0.001 * double(n) + side * std::cos(kYaw), 1.6, -0.5 - side * std::sin(kYaw)},
                     {0.0, std::sin(kYaw / 2), 0.0, std::cos(kYaw / 2)},
                     {eye == 0 ? -0.9f : -0.7f, eye == 0 ? 0.7f : 0.9f, 0.8f, -0.8f}};
}

}  // namespace hullpipe::fake_xr
