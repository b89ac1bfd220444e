#include "hullpipe/scenes/particles.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_yaml.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/collision/hull_surface.h"

namespace hullpipe {

void ParticleConfig::Check() const {
  if (!emitter.allFinite() || !velocity.allFinite())
    throw std::invalid_argument("particles: emitter and velocity must be finite");
  if (!(emitter_radius >= 0)) throw std::invalid_argument("particles: emitter_radius must be >= 0");
  if (!(velocity_jitter >= 0)) throw std::invalid_argument("particles: velocity_jitter must be >= 0");
  if (!(rate >= 0 && rate <= 1e6)) throw std::invalid_argument("particles: rate must be in [0, 1e6]");
  if (max_particles < 1 || max_particles > 200000)
    throw std::invalid_argument("particles: max_particles must be in [1, 200000]");
  if (!(lifetime > 0)) throw std::invalid_argument("particles: lifetime must be > 0");
  if (!(restitution >= 0 && restitution <= 1)) throw std::invalid_argument("particles: restitution must be in [0, 1]");
  if (!(friction >= 0 && friction <= 1)) throw std::invalid_argument("particles: friction must be in [0, 1]");
  if (!(radius > 0)) throw std::invalid_argument("particles: radius must be > 0");
  if (!(clearance > 0)) throw std::invalid_argument("particles: clearance must be > 0");
  if (!(max_substep >= kMinSubstepS && max_substep <= kMaxSubstepS))
    throw std::invalid_argument("particles: max_substep must be in [1e-4, 0.1] s");
  if (!(sample_spacing > 0)) throw std::invalid_argument("particles: sample_spacing must be > 0");
}

ParticleSystem::ParticleSystem(const ParticleConfig& config, const Eigen::Vector3d& gravity, bool has_floor,
                               double floor)
    : config_(config), gravity_(gravity), has_floor_(has_floor), floor_(floor), rng_(config.seed) {
  config_.Check();
  g_hat_ = gravity.norm() > 0 ? Eigen::Vector3d(gravity.normalized()) : Eigen::Vector3d::UnitZ();
}

void ParticleSystem::Emit(double dt) {
  emit_debt_ += config_.rate * dt;
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  // Two directions across the stream (perpendicular to gravity) for the disc.
  Eigen::Vector3d e1 = g_hat_.unitOrthogonal(), e2 = g_hat_.cross(e1);
  while (emit_debt_ >= 1.0) {
    emit_debt_ -= 1.0;
    double a, b;
    do {
      a = uni(rng_), b = uni(rng_);
    } while (a * a + b * b > 1.0);
    const Eigen::Vector3d x = config_.emitter + config_.emitter_radius * (a * e1 + b * e2);
    const Eigen::Vector3d v =
        config_.velocity + config_.velocity_jitter * Eigen::Vector3d(uni(rng_), uni(rng_), uni(rng_));
    if (int(x_.size()) < config_.max_particles) {
      x_.push_back(x), v_.push_back(v), age_.push_back(0), touching_.push_back(0);
    } else {  // recycle the oldest slot, round robin
      const size_t k = next_recycle_++ % x_.size();
      x_[k] = x, v_[k] = v, age_[k] = 0, touching_[k] = 0;
    }
  }
}

ParticleStepStats ParticleSystem::Step(double dt, const VolumeQuery* hull, StopFlag stop) {
  ParticleStepStats stats;
  dt = std::clamp(dt, 0.0, 0.25);
  std::fill(touching_.begin(), touching_.end(), 0);
  const auto t0 = std::chrono::steady_clock::now();
  const int substeps = dt > 0 ? std::max(1, int(std::ceil(dt / config_.max_substep))) : 0;
  const double h = substeps ? dt / substeps : 0;
  const Aabb* box = hull && !hull->hull_box().empty() ? &hull->hull_box() : nullptr;
  for (int s = 0; s < substeps; ++s) {
    ThrowIfStopped(stop, "the particles' step");
    Emit(h);
    for (size_t i = 0; i < x_.size(); ++i) {
      age_[i] += h;
      // The hull moved onto the particle: out upward, to the hull's surface.
      if (box && box->Contains(x_[i]) && hull->Inside(x_[i])) {
        Eigen::Vector3d p = x_[i];
        if (PushOutAlong(*hull, -g_hat_, config_.clearance, 2.0, &p)) {
          x_[i] = p;
          v_[i] = Eigen::Vector3d::Zero();
          ++stats.pushed_out;
          touching_[i] = 1;
        }
      }
      v_[i] += h * gravity_;
      Eigen::Vector3d next = x_[i] + h * v_[i];
      if (box) {
        const Eigen::Vector3d d = next - x_[i];
        double s0 = 0, s1 = 1;
        // The first hull point along the segment, where it meets the hull box:
        // point queries every sample_spacing (so no hull part thicker than that
        // is skipped), then bisection between the last outside and the first
        // inside sample to 0.1 mm.
        std::optional<Eigen::Vector3d> entry;
        if (d.squaredNorm() > 0 && box->ClipRay(x_[i], d, &s0, &s1) && s0 <= 1.0) {
          const auto at = FirstSampledCrossing(*hull, x_[i], d, s0, s1, /*inside=*/true, config_.sample_spacing, 1e-4);
          if (at) entry = x_[i] + *at * d;
        }
        if (entry) {
          ++stats.hits;
          touching_[i] = 1;
          const double len = d.norm();
          const Eigen::Vector3d dhat = d / len;
          const double back = std::min(config_.clearance, (*entry - x_[i]).norm());
          next = *entry - back * dhat;
          // Split the velocity about N_hull (or -d where no normal is found).
          Eigen::Vector3d n = -dhat;
          if (const auto hn = HullSurfaceNormal(*hull, *entry)) n = hn->normal;
          if (n.dot(dhat) > 0) n = -n;  // outward, against the motion
          const double vn = v_[i].dot(n);
          if (vn < 0) {
            const Eigen::Vector3d vt = v_[i] - vn * n;
            v_[i] = (1.0 - config_.friction) * vt - config_.restitution * vn * n;
          }
          if (hull->Inside(next)) next = x_[i];  // a corner: stay where it was (outside)
        }
      }
      x_[i] = next;
      if (has_floor_ && g_hat_.dot(x_[i]) > floor_) {
        x_[i] -= (g_hat_.dot(x_[i]) - floor_) * g_hat_;
        const double vn = v_[i].dot(g_hat_);
        if (vn > 0) v_[i] = (1.0 - config_.friction) * (v_[i] - vn * g_hat_) - config_.restitution * vn * g_hat_;
      }
      if (age_[i] > config_.lifetime) {
        // Recycle: swap with the last.
        x_[i] = x_.back(), v_[i] = v_.back(), age_[i] = age_.back(), touching_[i] = touching_.back();
        x_.pop_back(), v_.pop_back(), age_.pop_back(), touching_.pop_back();
        --i;
      }
    }
  }
  if (box)
    for (const auto& x : x_)
      if (box->Contains(x) && hull->Inside(x)) ++stats.left_inside;
  stats.query_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return stats;
}

// ---- The particle stream as a scene element (scene_element.h).

void ParticleConfig::CheckIn(const SceneConfig&) const { Check(); }

namespace {

class ParticlesElement final : public SceneElement {
 public:
  ParticlesElement(const ParticleConfig& config, const SceneConfig& scene)
      : system_(config, scene.gravity, scene.has_floor, scene.floor) {}
  void Step(const StepContext& s) override { system_.Step(s.dt, s.hull, s.stop); }
  void Output(double, uint64_t, ElementOutput* out) override {
    VirtualMeshSample m;
    m.object_id = uint32_t(system_.config().id);
    m.kind = kMeshParticles;
    m.draw.vertices = system_.positions();
    m.draw.colliding = system_.touching();
    m.draw.colour = cv::Vec3b(230, 160, 60);
    m.draw.point_radius = system_.config().radius;
    out->meshes.push_back(std::move(m));
  }

 private:
  ParticleSystem system_;
};

}  // namespace

std::unique_ptr<SceneElement> ParticleConfig::Make(const SceneConfig& scene) const {
  return std::make_unique<ParticlesElement>(*this, scene);
}

std::shared_ptr<const SceneElementConfig> ReadParticlesSection(const YAML::Node& n, const std::string& path) {
  using namespace scene_yaml;
  auto c = std::make_shared<ParticleConfig>();
  Section(n, path, "particles")
      .Field("id", &c->id)
      .Vec("emitter", &c->emitter, Need::kRequired)
      .Field("emitter_radius", &c->emitter_radius)
      .Vec("velocity", &c->velocity, Need::kRequired)
      .Field("velocity_jitter", &c->velocity_jitter)
      .Field("rate", &c->rate)
      .Field("max_particles", &c->max_particles)
      .Field("lifetime", &c->lifetime)
      .Field("restitution", &c->restitution)
      .Field("friction", &c->friction)
      .Field("radius", &c->radius)
      .Field("clearance", &c->clearance)
      .Field("max_substep", &c->max_substep)
      .Field("seed", &c->seed)
      .Read();
  return c;
}

}  // namespace hullpipe
