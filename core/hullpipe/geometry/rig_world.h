// The rig's world: which way is up, where the floor is, what the cameras can
// all see (the workspace) and where a viewer orbits it. Calibrations put their
// world axes anywhere (the Utrecht rig's z points down, COLMAP's and NeRF's
// worlds are wherever the reconstruction left them), so render_node, sim_node and
// the scenes take these from the rig (stated in its file, or derived here from
// the cameras), never from one rig's habits. docs/rigs.md.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/camera.h"

namespace hullpipe {

/// The world of a rig, in world metres. Rig file key `world` (calibration.h).
struct RigWorld {
  /// Unit world up vector (gravity points along -up).
  Eigen::Vector3d up{0, 0, -1};
  /// Where the floor is: a plane up . x = floor_height; under the first hull the
  /// nodes see (its lowest point along up: a person stands or sits on the floor);
  /// or no floor.
  enum class Floor { kPlane, kUnderHull, kNone };
  Floor floor = Floor::kUnderHull;
  double floor_height = 0;  ///< kPlane only: metres along up.
  /// Scripted-orbit radius (metres) around the hull box's centre, and the eye's
  /// height above that centre along up (metres).
  double orbit_radius = 3.0, orbit_height = 0.7;
  /// Which fields the rig file stated (the rest were derived).
  bool up_stated = false, floor_stated = false, orbit_stated = false;

  /// Throws std::invalid_argument naming the field (non-finite, zero up, radius <= 0).
  void Check() const;
  /// "plane 0.000 m", "under the hull" or "none".
  std::string FloorText() const;
};

/// Two estimates of the world's up from the cameras alone (world frame, unit).
struct UpEstimates {
  /// The cameras' mean image-up (each camera's -y axis, R^T (0,-1,0)),
  /// normalised; zero where they cancel out (mean shorter than 0.2). Leans
  /// toward the side of the room the cameras are on when they look down from
  /// one side only.
  Eigen::Vector3d mean_image_up = Eigen::Vector3d::Zero();
  /// The direction at right angles to every level camera's image x-axis (R^T
  /// (1,0,0)): cameras are mounted unrolled, so their x-axes are horizontal
  /// whatever their tilt. The least-squares normal (smallest eigenvector of
  /// sum x x^T), signed to agree with mean_image_up; cameras whose x-axis is
  /// more than 15 degrees off that plane are taken as rolled and left out once.
  /// nullopt where fewer than two cameras remain or their x-axes are all
  /// within ~16 degrees of one line (up is then any direction in a plane).
  std::optional<Eigen::Vector3d> level;
  int rolled = 0;  ///< Cameras left out of `level` as rolled.
};

/// UpEstimates of `cameras`.
UpEstimates EstimateUp(const std::vector<Camera>& cameras);

/// The world's up derived from the cameras: UpEstimates::level where there is
/// one, else the mean image-up; snapped to the nearest world axis when within
/// `snap_deg` degrees of it (calibrations usually align an axis with gravity).
/// *spread_deg, if given, gets the largest angle between one camera's image-up
/// and the result. Throws std::invalid_argument when the cameras' image-ups
/// cancel out (mean shorter than 0.2: cameras rolled every way; state `up`
/// instead): they give up its sign.
Eigen::Vector3d DeriveUp(const std::vector<Camera>& cameras, double snap_deg = 10.0, double* spread_deg = nullptr);

/// The box of the points every camera sees (in front of it and inside its image),
/// within DefaultWorkspace(cameras): the only place a visual hull of all the
/// cameras can be (paper §3.2: a point is inside iff it is on object pixels in
/// every camera). Empty when the cameras share no view.
Aabb CommonViewWorkspace(const std::vector<Camera>& cameras);

/// Orbit radius (metres) at which a view of horizontal field of view `hfov_deg`
/// frames `box` with a 10% margin: 1.1 * half-diagonal / tan(hfov/2).
double FramingRadius(const Aabb& box, double hfov_deg = 60.0);

/// The stage's axes for an up vector: z along up, x the world axis most
/// perpendicular to it projected onto the floor, y = z x x (columns; a rotation).
Eigen::Matrix3d StageAxes(const Eigen::Vector3d& up);

/// The world's "stage" frame, for scenes placed relative to the rig (scene key
/// `frame: stage`): origin on the floor (or the workspace's bottom) below the
/// workspace's centre, z along up, x the world axis most perpendicular to up
/// projected onto the floor, y = z x x. Returns world_from_stage.
Rigid3d StageFrame(const RigWorld& world, const Aabb& workspace);

/// What `hullpipe_rig check` prints about a camera.
struct CameraReport {
  int id = 0;
  Eigen::Vector3d centre, view_dir;  ///< World metres; unit optical axis.
  double hfov_deg = 0, vfov_deg = 0;
  bool sees_centre = false;  ///< The workspace centre projects inside its image.
};

/// The check of a rig: per camera, and warnings about what looks wrong (a camera
/// looking away from the others, a scale off by 1000, cameras that do not see
/// the workspace centre, a floor above a camera, an up far from the cameras').
struct RigReport {
  std::vector<CameraReport> cameras;
  /// What every camera sees (CommonViewWorkspace; empty if nothing).
  Aabb common_view;
  /// Centre of what every camera sees inside the workspace (else the workspace's).
  Eigen::Vector3d workspace_centre = Eigen::Vector3d::Zero();
  std::vector<std::string> warnings;
};

/// Checks `cameras` against `workspace` and `world` (see RigReport).
RigReport CheckRig(const std::vector<Camera>& cameras, const Aabb& workspace, const RigWorld& world);

}  // namespace hullpipe
