#include "hullpipe/scenes/ball.h"

#include <algorithm>
#include <cmath>

#include "hullpipe/reconstruction/exact_hull.h"

namespace hullpipe {

BallSimulation::BallSimulation(SceneConfig config) : config_(std::move(config)) {
  config_.Check();
  for (size_t i = 0; i < config_.balls.size(); ++i) {
    const BallConfig& b = config_.balls[i];
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
  const BallConfig& b = config_.balls[i];
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
        if (vn > 0) s.velocity -= (1 + config_.balls[i].restitution) * vn * g_hat;
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
      request.restitution = config_.balls[i].restitution;
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
