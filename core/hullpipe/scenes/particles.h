// A stream of particles (water or sand) falling on the real objects (paper §4).
// A particle is a point, so it is volume-queried as a point (§4.1:
// QueryPoints), not as triangles. World metres and seconds, frame of the rig.
//
// Each substep a particle moves from x to x + v h. Where the segment meets the
// hull box it is point-queried every `sample_spacing` (4 mm), and the first inside
// sample's entry found by bisection to 0.1 mm, so a particle cannot pass through
// a part of the hull thicker than the spacing within a step. A particle that
// enters the hull stops `clearance` before the entry point CP_hull, and its
// velocity is split about the hull's normal there (N_hull, hull_surface.h):
// the normal part is reflected with `restitution`, the tangential part kept
// less `friction` (sand: restitution ~0, friction high, it slides and settles;
// water: it bounces and runs off). A particle that the hull moved onto (inside at
// the start of a substep) is pushed out upward (against gravity) to the hull's
// surface (PushOutAlong). So no particle ends a step inside the hull.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/scenes/limits.h"
#include "hullpipe/scenes/scene_element.h"
#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// Settings of a particle stream (scene file key `particles`; a scene element:
/// scene_element.h).
struct ParticleConfig final : SceneElementConfig {
  int id = 200;                                 ///< Object id in messages.
  Eigen::Vector3d emitter{0.3, 0.0, -2.2};      ///< Emitter centre, world metres.
  double emitter_radius = 0.05;                 ///< Particles start on a disc of this radius.
  Eigen::Vector3d velocity{0.0, 0.0, 0.5};      ///< Initial velocity, world m/s.
  double velocity_jitter = 0.1;                 ///< Random velocity added, m/s (per axis, uniform).
  double rate = 2000;                           ///< Particles emitted per second.
  int max_particles = 4000;                     ///< Oldest recycled beyond this.
  double lifetime = 3.0;                        ///< Seconds before a particle is recycled.
  double restitution = 0.2;                     ///< Normal velocity kept (reflected) on impact, [0, 1].
  double friction = 0.3;                        ///< Tangential velocity lost on impact, [0, 1].
  double radius = 0.006;                        ///< Drawn radius, metres (collision treats points).
  double clearance = 0.001;                     ///< Stop this far before the hull's surface, metres.
  double max_substep = 1.0 / 60.0;              ///< Longest substep, seconds.
  double sample_spacing = 0.004;                ///< Segment point-query spacing, metres (thinner hull may be skipped).
  uint32_t seed = 7;                            ///< Emission is deterministic given the seed.
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;

  std::string Key() const override { return "particles"; }
  std::string Describe() const override { return "particles"; }
  void CheckIn(const SceneConfig& scene) const override;
  std::vector<ObjectIdRange> ObjectIds() const override { return {{id, id, "particles"}}; }
  /// A ParticleSystem under the scene's gravity and floor, published as a
  /// VirtualMesh point set of kind particles with the touching ones.
  std::unique_ptr<SceneElement> Make(const SceneConfig& scene) const override;
};

/// Reads a scene file's `particles` section (keys as ParticleConfig's; emitter
/// and velocity required). Throws std::runtime_error naming the file and key.
std::shared_ptr<const SceneElementConfig> ReadParticlesSection(const YAML::Node& section, const std::string& path);

/// What a particle step did.
struct ParticleStepStats {
  int hits = 0;             ///< Impacts with the hull (all substeps).
  int pushed_out = 0;       ///< Particles the hull moved onto, pushed out.
  int left_inside = 0;      ///< Particles inside the hull after the step (should be 0).
  double query_ms = 0;      ///< Time spent in point queries and searches.
};

/// Deterministic given its config and the hulls it is stepped against.
class ParticleSystem {
 public:
  /// Throws std::invalid_argument if the config fails Check().
  ParticleSystem(const ParticleConfig& config, const Eigen::Vector3d& gravity, bool has_floor, double floor);
  /// Advances by dt seconds (clamped to [0, 0.25]): emits, integrates, collides
  /// with `hull` (nullptr: none) and the floor, recycles old particles. Throws
  /// Interrupted (util/interrupt.h) between substeps once `stop` is set.
  ParticleStepStats Step(double dt, const VolumeQuery* hull, StopFlag stop = nullptr);
  const std::vector<Eigen::Vector3d>& positions() const { return x_; }
  const std::vector<Eigen::Vector3d>& velocities() const { return v_; }
  /// Per particle: 1 if it touched the hull in the last step.
  const std::vector<uint8_t>& touching() const { return touching_; }
  const ParticleConfig& config() const { return config_; }

 private:
  void Emit(double dt);
  ParticleConfig config_;
  Eigen::Vector3d gravity_, g_hat_;
  bool has_floor_;
  double floor_;
  std::vector<Eigen::Vector3d> x_, v_;
  std::vector<double> age_;
  std::vector<uint8_t> touching_;
  double emit_debt_ = 0;
  size_t next_recycle_ = 0;
  std::mt19937 rng_;
};

}  // namespace hullpipe
