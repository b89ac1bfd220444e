#include "hullpipe/scenes/ball.h"

#include <algorithm>
#include <cmath>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/scenes/limits.h"
#include "hullpipe/scenes/scene_yaml.h"

namespace hullpipe {

std::string BallsConfig::Describe() const { return std::to_string(balls.size()) + " ball(s)"; }

void BallsConfig::CheckIn(const SceneConfig&) const {
  if (balls.size() > size_t(kMaxBalls))
    throw std::invalid_argument("scene: " + std::to_string(balls.size()) + " balls; at most " +
                                std::to_string(kMaxBalls));
  long long triangles = 0;
  for (const auto& b : balls) {
    if (!(b.radius > 0)) throw std::invalid_argument("scene: ball radius must be > 0");
    if (!b.start.allFinite() || !b.target.allFinite())
      throw std::invalid_argument("scene: ball start and target must be finite");
    if (!(b.flight_time > 0)) throw std::invalid_argument("scene: ball flight_time must be > 0");
    if (b.restitution < 0 || b.restitution > 1)
      throw std::invalid_argument("scene: ball restitution must be in [0, 1]");
    if (b.subdivisions < 0 || b.subdivisions > 5)
      throw std::invalid_argument("scene: ball subdivisions must be in [0, 5]");
    triangles += 20LL << (2 * b.subdivisions);
  }
  if (triangles > kMaxBallTriangles)
    throw std::invalid_argument("scene: the balls have " + std::to_string(triangles) + " triangles together; at most " +
                                std::to_string(kMaxBallTriangles) + " (fewer balls or subdivisions)");
}

std::unique_ptr<SceneElement> BallsConfig::Make(const SceneConfig& scene) const {
  return std::make_unique<BallsElement>(scene, *this);
}

std::vector<ObjectIdRange> BallsConfig::ObjectIds() const {
  std::vector<ObjectIdRange> ids;
  for (const auto& b : balls) ids.push_back({b.id, b.id, "ball " + std::to_string(b.id)});
  return ids;
}

std::shared_ptr<const SceneElementConfig> BallsConfig::PlaceOnStage(const Rigid3d& world_from_stage) const {
  auto placed = std::make_shared<BallsConfig>(*this);
  for (auto& b : placed->balls) {
    b.start = world_from_stage.rotation * b.start;
    b.target = world_from_stage.rotation * b.target;
    b.relative_to_hull = true;
  }
  return placed;
}

std::shared_ptr<const SceneElementConfig> ReadBallsSection(const YAML::Node& n, const std::string& path) {
  if (!n.IsSequence()) throw std::runtime_error(path + ": 'balls' must be a list ([] for none)");
  auto c = std::make_shared<BallsConfig>();
  int index = 0;
  for (const auto& b : n) {
    BallConfig bc;
    bc.id = index + 1;
    scene_yaml::Section(b, path, "balls[" + std::to_string(index) + "]")
        .Field("id", &bc.id)
        .Field("radius", &bc.radius, scene_yaml::Need::kRequired)
        .Vec("start", &bc.start, scene_yaml::Need::kRequired)
        .Vec("target", &bc.target, scene_yaml::Need::kRequired)
        .Field("flight_time", &bc.flight_time)
        .Field("restitution", &bc.restitution)
        .Field("rethrow_period", &bc.rethrow_period)
        .Field("subdivisions", &bc.subdivisions)
        .Read();
    c->balls.push_back(bc);
    ++index;
  }
  return c;
}

BallSimulation::BallSimulation(const SceneConfig& scene)
    : BallSimulation(scene, scene.Find<BallsConfig>() ? *scene.Find<BallsConfig>() : BallsConfig{}) {}

BallSimulation::BallSimulation(SceneConfig scene, BallsConfig balls)
    : config_(std::move(scene)), balls_(std::move(balls)) {
  config_.Check();
  balls_.CheckIn(config_);
  for (size_t i = 0; i < balls_.balls.size(); ++i) {
    const BallConfig& b = balls_.balls[i];
    meshes_.push_back(TriangleMesh::Icosphere(b.radius, b.subdivisions));
    BodyState s;
    s.id = b.id;
    s.radius = b.radius;
    bodies_.push_back(s);
    next_throw_.push_back(0.0);
    waiting_.push_back(0);
    Throw(i, nullptr);
  }
}

void BallSimulation::Throw(size_t i, const VolumeQuery* hull) {
  const BallConfig& b = balls_.balls[i];
  BodyState& s = bodies_[i];
  Eigen::Vector3d start = b.start, target = b.target;
  if (b.relative_to_hull) {
    // Offsets from the hull's box centre: no hull yet, no throw (parked far
    // below, motionless, and tried again next substep).
    waiting_[i] = !hull || hull->hull_box().empty();
    if (waiting_[i]) {
      s.position = b.start;  // parked at the offset, motionless, not simulated
      s.velocity.setZero();
      s.colliding = false;
      next_throw_[i] = time_;
      return;
    }
    const Eigen::Vector3d centre = SampledHullBox(*hull).Center();  // the hull's own box
    start += centre;
    target += centre;
  }
  s.position = start;
  // Ballistic: start + v T + g T^2 / 2 = target.
  const double T = b.flight_time;
  s.velocity = (target - start) / T - 0.5 * config_.gravity * T;
  s.colliding = false;
  next_throw_[i] = b.rethrow_period > 0 ? time_ + b.rethrow_period : 1e300;
}

TriangleMesh BallSimulation::WorldMesh(size_t i) const {
  Rigid3d world_from_body;
  world_from_body.translation = bodies_[i].position;
  return meshes_[i].Transformed(world_from_body);
}

void BallSimulation::Step(double dt, const VolumeQuery* hull, StopFlag stop, const HullMotion* motion) {
  dt = std::clamp(dt, 0.0, 0.25);
  for (auto& s : bodies_) s.colliding = false;
  // Substeps short in time, and short in space: no ball moves more than its own
  // radius in one (speed bounded by the current speed plus what gravity adds), so
  // consecutive positions overlap and a thin part of the hull across the path
  // cannot be skipped (no tunnelling). Capped at 2000 substeps per step.
  int substeps = std::max(1, int(std::ceil(dt / config_.max_substep)));
  for (const auto& b : bodies_) {
    if (!(b.radius > 0)) continue;
    const double reach = (b.velocity.norm() + config_.gravity.norm() * dt) * dt;
    substeps = std::max(substeps, int(std::min(2000.0, std::ceil(reach / b.radius))));
  }
  const double h = dt / substeps;
  const double g_norm = config_.gravity.norm();
  const Eigen::Vector3d g_hat = g_norm > 0 ? Eigen::Vector3d(config_.gravity / g_norm)
                                           : Eigen::Vector3d::UnitZ();
  config_.TakeFloorUnderHull(hull);
  for (int k = 0; k < substeps; ++k) {
    ThrowIfStopped(stop, "the balls' step");
    time_ += h;
    for (size_t i = 0; i < bodies_.size(); ++i) {
      if (time_ >= next_throw_[i]) Throw(i, hull);
      if (waiting_[i]) continue;  // no hull to throw at yet
      BodyState& s = bodies_[i];
      const Eigen::Vector3d previous = s.position;
      s.velocity += config_.gravity * h;
      s.position += s.velocity * h;
      // Floor: keep the ball above g_hat . x = floor.
      if (config_.has_floor && g_hat.dot(s.position) + s.radius > config_.floor) {
        s.position -= (g_hat.dot(s.position) + s.radius - config_.floor) * g_hat;
        const double vn = s.velocity.dot(g_hat);
        if (vn > 0) s.velocity -= (1 + balls_.balls[i].restitution) * vn * g_hat;
      }
      if (!hull) continue;
      const TriangleMesh mesh = WorldMesh(i);
      CollisionResult c = DetectCollisions(*hull, mesh, config_.collision);
      if (!c.colliding()) continue;
      // Paper §4.2: move the ball by D_rec along V_rec so its deepest collision
      // point reaches the hull's surface, and reflect its velocity about N_hull
      // (relative to the surface's own velocity there, given the hull's motion).
      RigidBodyResponseRequest request;
      request.world_mesh = &mesh;
      request.rp_obj = s.position;
      request.query = config_.collision;
      request.exact = config_.response == SceneConfig::Response::kExact;
      request.restitution = balls_.balls[i].restitution;
      request.previous = previous;
      request.fallback_normal =
          s.velocity.norm() > 1e-9 ? Eigen::Vector3d(-s.velocity.normalized()) : Eigen::Vector3d(-g_hat);
      request.motion = motion;
      const std::optional<CollisionResponse> resp = RespondAsRigidBody(*hull, request, &c, &s.position, &s.velocity);
      s.colliding = true;
      s.last_collision = std::move(c);
      s.last_response = resp;
    }
  }
}

void BallsElement::Output(double, uint64_t, ElementOutput* out) {
  for (const BodyState& b : sim_.bodies()) {
    VirtualObjectSample s;
    s.object_id = uint32_t(b.id);
    s.sim_time = sim_.time();
    s.radius = b.radius;
    s.position = b.position;
    s.velocity = b.velocity;
    s.colliding = b.colliding;
    out->states.push_back(s);

    CollisionReportSample r;
    r.object_id = uint32_t(b.id);
    if (b.colliding) {
      ++out->colliding_bodies;
      for (int t : b.last_collision.triangle_ids) r.triangle_ids.push_back(uint32_t(t));
      r.collision_points = b.last_collision.collision_points;
    }
    r.has_response = b.colliding && b.last_response.has_value();
    if (r.has_response) {
      const CollisionResponse& resp = *b.last_response;
      r.cp_obj = resp.cp_obj;
      r.cp_hull = resp.cp_hull;
      r.v_rec = resp.v_rec;
      r.d_rec = resp.d_rec;
      r.n_hull = resp.n_hull;
      r.hull_velocity_status = uint8_t(resp.hull_velocity.status);
      r.hull_normal_speed = resp.hull_velocity.normal_speed;
      r.hull_velocity_interval = resp.hull_velocity.interval_s;
    }
    out->reports.push_back(std::move(r));
  }
}

}  // namespace hullpipe
