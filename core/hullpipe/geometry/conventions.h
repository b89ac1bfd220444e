// hullpipe conventions: units, frames and pixel coordinates. Every other header
// refers to this one instead of restating it.
//
// Units
//   * Lengths in metres, times in seconds, angles in radians, inside all code and
//     on every DDS topic. Files convert at their boundary: the Utrecht rig's
//     config.xml stores translations in millimetres (calibration.h converts).
//   * Timestamps on the wire are integer nanoseconds of CLOCK_REALTIME
//     (`NowNs()`), so that stamps from several machines compare under NTP/PTP.
//
// Frames and transforms
//   * A transform named `a_from_b` maps coordinates in frame b to frame a:
//       x_a = a_from_b * x_b = R * x_b + t.
//   * World frame: whatever the rig's calibration defines. The Utrecht rig's world
//     z axis points down (towards the floor, which is z = 0); gravity is therefore a
//     scene setting, never assumed to be -z.
//   * Camera frame (real cameras and the novel "eye" view alike): OpenCV's,
//     x right, y down, z forward (optical axis). A point is in front of a camera iff
//     its camera-frame z > 0.
//
// Pixels
//   * Continuous image coordinates (u, v) have their origin at the top-left corner of
//     the top-left pixel; pixel (col, row) covers [col, col+1) x [row, row+1) and its
//     centre is at (col + 0.5, row + 0.5) (as COLMAP). A projected point lies on
//     pixel (floor(u), floor(v)).
//   * A projected coordinate becomes a pixel index through FloorPixel/CeilPixel,
//     which clamp in floating point first: a point far outside a distorted
//     camera's view projects to 1e11 px or more, past int.
//   * OpenCV calibration files put pixel centres at integers; readers add 0.5 to the
//     principal point on load (`kOpenCvToHullpipePixelOffset`).
//   * Images are row-major, row 0 at the top. Object-pixel maps are CV_8UC1 with
//     0 = background and 255 = object (any non-zero value counts as object).
//
// Depth
//   * "Depth" of a novel-view pixel is the eye-frame z of the first hull point along
//     the pixel's ray (not the ray length), in metres; kNoDepth marks "no hull".
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>

namespace hullpipe {

/// Added to an OpenCV principal point (pixel centres at integers) to get hullpipe's.
inline constexpr double kOpenCvToHullpipePixelOffset = 0.5;

/// Millimetres to metres, for file boundaries only.
inline constexpr double kMetresPerMillimetre = 1e-3;

/// Depth value meaning "the ray meets no hull" (in depth images and HullView tiles).
inline constexpr float kNoDepth = std::numeric_limits<float>::infinity();

/// Beyond this many pixels from an image, every coordinate is as far as this:
/// no image is that large, and int holds it with room for arithmetic.
inline constexpr double kFarPixels = 1e7;

/// floor(x) as an int, x clamped to [-kFarPixels, kFarPixels] in floating point
/// first (NaN gives -kFarPixels). For projected coordinates and bounds
/// computed from them; callers clamp to their image after.
inline int FloorPixel(double x) {
  if (!(x > -kFarPixels)) return -int(kFarPixels);
  if (!(x < kFarPixels)) return int(kFarPixels);
  return int(std::floor(x));
}

/// ceil(x) as an int, clamped as FloorPixel.
inline int CeilPixel(double x) {
  if (!(x > -kFarPixels)) return -int(kFarPixels);
  if (!(x < kFarPixels)) return int(kFarPixels);
  return int(std::ceil(x));
}

/// Nanoseconds of CLOCK_REALTIME, the clock of every timestamp on the wire.
inline int64_t NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Seconds of a monotonic clock, for measuring durations inside one process.
inline double MonotonicSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace hullpipe
