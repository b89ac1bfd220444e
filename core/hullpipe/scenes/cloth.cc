#include "hullpipe/scenes/cloth.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_yaml.h"
#include "hullpipe/collision/collision.h"
#include "hullpipe/collision/hull_surface.h"

namespace hullpipe {

void ClothConfig::Check() const {
  if (nx < 2 || ny < 2) throw std::invalid_argument("cloth: nx and ny must be >= 2");
  // In 64 bits: each side may be as large as an int, and their product is not.
  if (int64_t(nx) * int64_t(ny) > 100000) throw std::invalid_argument("cloth: nx * ny must be <= 100000");
  if (!rod_a.allFinite() || !rod_b.allFinite() || (rod_b - rod_a).norm() < 1e-6)
    throw std::invalid_argument("cloth: rod_a and rod_b must be finite and distinct");
  if (!(length > 0)) throw std::invalid_argument("cloth: length must be > 0");
  if (iterations < 1 || iterations > 200) throw std::invalid_argument("cloth: iterations must be in [1, 200]");
  if (!(damping >= 0 && damping < 1)) throw std::invalid_argument("cloth: damping must be in [0, 1)");
  if (!(max_substep >= kMinSubstepS && max_substep <= kMaxSubstepS))
    throw std::invalid_argument("cloth: max_substep must be in [1e-4, 0.1] s");
  if (!(clearance >= 0)) throw std::invalid_argument("cloth: clearance must be >= 0");
  if (!(max_search > clearance)) throw std::invalid_argument("cloth: max_search must be > clearance");
  if (!(collision.max_pixel_size >= TriangleQueryOptions::kMinPixelSize && collision.max_pixel_size <= 1))
    throw std::invalid_argument("cloth: max_pixel_size must be in [1e-05, 1] m");
  collision.Check();
}

bool PushOutAlong(const VolumeQuery& hull, const Eigen::Vector3d& dir, double clearance, double max_search,
                  Eigen::Vector3d* p) {
  // The exit: 2 mm samples, bisected to 0.05 mm; then `clearance` beyond it if
  // that is outside too.
  const auto exit = FirstSampledCrossing(hull, *p, dir, 0.0, max_search, /*inside=*/false, 0.002, 5e-5);
  if (!exit) return false;
  const Eigen::Vector3d out = *p + (*exit + clearance) * dir;
  *p = hull.Inside(out) ? Eigen::Vector3d(*p + *exit * dir) : out;
  return true;
}

ClothSimulation::ClothSimulation(const ClothConfig& config, const Eigen::Vector3d& gravity)
    : config_(config), gravity_(gravity) {
  config_.Check();
  if (!(gravity.norm() > 0) || !gravity.allFinite()) throw std::invalid_argument("cloth: gravity must be non-zero");
  const Eigen::Vector3d down = gravity.normalized();
  const int nx = config_.nx, ny = config_.ny;
  x_.resize(size_t(nx * ny));
  v_.assign(x_.size(), Eigen::Vector3d::Zero());
  inv_mass_.assign(x_.size(), 1.0);
  for (int iy = 0; iy < ny; ++iy)
    for (int ix = 0; ix < nx; ++ix) {
      const double a = double(ix) / (nx - 1), b = double(iy) / (ny - 1);
      x_[size_t(Index(ix, iy))] = config_.rod_a + a * (config_.rod_b - config_.rod_a) + b * config_.length * down;
      if (iy == 0) inv_mass_[size_t(Index(ix, iy))] = 0;  // on the rod
    }
  auto add = [&](int i, int j) { constraints_.push_back({i, j, (x_[size_t(i)] - x_[size_t(j)]).norm()}); };
  for (int iy = 0; iy < ny; ++iy)
    for (int ix = 0; ix < nx; ++ix) {
      if (ix + 1 < nx) add(Index(ix, iy), Index(ix + 1, iy));
      if (iy + 1 < ny) add(Index(ix, iy), Index(ix, iy + 1));
      if (ix + 1 < nx && iy + 1 < ny) {
        add(Index(ix, iy), Index(ix + 1, iy + 1));
        add(Index(ix + 1, iy), Index(ix, iy + 1));
      }
      if (ix + 2 < nx) add(Index(ix, iy), Index(ix + 2, iy));
      if (iy + 2 < ny) add(Index(ix, iy), Index(ix, iy + 2));
    }
  for (int iy = 0; iy + 1 < ny; ++iy)
    for (int ix = 0; ix + 1 < nx; ++ix) {
      triangles_.emplace_back(Index(ix, iy), Index(ix, iy + 1), Index(ix + 1, iy + 1));
      triangles_.emplace_back(Index(ix, iy), Index(ix + 1, iy + 1), Index(ix + 1, iy));
    }
  colliding_.assign(triangles_.size(), 0);
}

TriangleMesh ClothSimulation::Mesh() const {
  TriangleMesh m;
  m.vertices = x_;
  m.triangles = triangles_;
  return m;
}

std::vector<Eigen::Vector3d> ClothSimulation::VertexNormals() const {
  std::vector<Eigen::Vector3d> n(x_.size(), Eigen::Vector3d::Zero());
  for (const auto& t : triangles_) {
    const Eigen::Vector3d a = x_[size_t(t[0])], b = x_[size_t(t[1])], c = x_[size_t(t[2])];
    const Eigen::Vector3d area_n = (b - a).cross(c - a);
    for (int k = 0; k < 3; ++k) n[size_t(t[k])] += area_n;
  }
  for (auto& v : n) v = v.norm() > 1e-15 ? Eigen::Vector3d(v.normalized()) : Eigen::Vector3d::Zero();
  return n;
}

void ClothSimulation::Respond(const VolumeQuery& hull, const std::vector<Eigen::Vector3d>& previous,
                              ClothStepStats* stats) {
  // §4.1: the cloth is a virtual object like any other: box test, then each
  // triangle volume-queried in its own viewport.
  const TriangleMesh mesh = Mesh();
  const CollisionResult c = DetectCollisions(hull, mesh, config_.collision);
  std::fill(colliding_.begin(), colliding_.end(), 0);
  std::vector<uint8_t> candidate(x_.size(), 0);
  for (int t : c.triangle_ids) {
    colliding_[size_t(t)] = 1;
    for (int k = 0; k < 3; ++k) candidate[size_t(triangles_[size_t(t)][k])] = 1;
  }
  stats->colliding_triangles = int(c.triangle_ids.size());
  // A vertex can be inside while every triangle's pixels miss the hull (a thin
  // part between pixel centres): point queries of the vertices inside the hull
  // box catch it, so no vertex is left inside.
  const Aabb& box = hull.hull_box();
  const std::vector<Eigen::Vector3d> normals = VertexNormals();
  for (size_t i = 0; i < x_.size(); ++i) {
    if (inv_mass_[i] == 0) continue;
    if (!candidate[i] && !box.Contains(x_[i])) continue;
    if (!hull.Inside(x_[i])) continue;
    // Constrained V_rec (§4.2): along the vertex normal, to whichever side of
    // the cloth reaches the hull's surface sooner (the least motion; where the
    // hull pushed into the cloth that is the side it pushes toward); on a tie
    // (within 1 mm), the side the vertex came from.
    Eigen::Vector3d n = normals[i];
    if (n.squaredNorm() == 0) n = (x_[i] - box.Center()).normalized();
    const Eigen::Vector3d came = previous[i] - x_[i];
    Eigen::Vector3d p_pos = x_[i], p_neg = x_[i];
    const bool pos = PushOutAlong(hull, n, config_.clearance, config_.max_search, &p_pos);
    const bool neg = PushOutAlong(hull, -n, config_.clearance, config_.max_search, &p_neg);
    Eigen::Vector3d p = x_[i];
    bool out = pos || neg;
    if (pos && neg) {
      const double dp = (p_pos - x_[i]).norm(), dn = (p_neg - x_[i]).norm();
      if (std::abs(dp - dn) < 1e-3) p = n.dot(came) >= 0 ? p_pos : p_neg;
      else p = dp < dn ? p_pos : p_neg;
    } else if (out) {
      p = pos ? p_pos : p_neg;
    }
    if (!out && !hull.Inside(previous[i])) p = previous[i], out = true;
    if (out) {
      x_[i] = p;
      ++stats->vertices_moved;
    }
  }
}

ClothStepStats ClothSimulation::Step(double dt, const VolumeQuery* hull, StopFlag stop) {
  ClothStepStats stats;
  dt = std::clamp(dt, 0.0, 0.25);
  if (dt <= 0) {
    if (hull) Respond(*hull, x_, &stats);
  }
  const int substeps = dt > 0 ? std::max(1, int(std::ceil(dt / config_.max_substep))) : 0;
  const double h = substeps ? dt / substeps : 0;
  std::vector<Eigen::Vector3d> previous;
  for (int s = 0; s < substeps; ++s) {
    ThrowIfStopped(stop, "the cloth's step");
    previous = x_;
    for (size_t i = 0; i < x_.size(); ++i) {
      if (inv_mass_[i] == 0) continue;
      v_[i] = (v_[i] + h * gravity_) * (1.0 - config_.damping);
      x_[i] += h * v_[i];
    }
    for (int it = 0; it < config_.iterations; ++it) {
      // A substep of a 100,000-vertex cloth at 200 iterations takes seconds.
      ThrowIfStopped(stop, "the cloth's step");
      for (const Constraint& c : constraints_) {
        const double wi = inv_mass_[size_t(c.i)], wj = inv_mass_[size_t(c.j)];
        if (wi + wj == 0) continue;
        Eigen::Vector3d d = x_[size_t(c.j)] - x_[size_t(c.i)];
        const double len = d.norm();
        if (len < 1e-12) continue;
        const Eigen::Vector3d corr = (len - c.rest) / (len * (wi + wj)) * d;
        x_[size_t(c.i)] += wi * corr;
        x_[size_t(c.j)] -= wj * corr;
      }
    }
    if (hull) Respond(*hull, previous, &stats);
    for (size_t i = 0; i < x_.size(); ++i)
      if (inv_mass_[i] > 0) v_[i] = (x_[i] - previous[i]) / h;
  }
  if (hull)
    for (size_t i = 0; i < x_.size(); ++i)
      if (inv_mass_[i] > 0 && hull->Inside(x_[i])) ++stats.vertices_left_inside;
  return stats;
}

// ---- The curtain as a scene element (scene_element.h).

void ClothConfig::CheckIn(const SceneConfig& scene) const {
  Check();
  if (!(scene.gravity.norm() > 0)) throw std::invalid_argument("scene: a cloth needs non-zero gravity");
}

namespace {

class ClothElement final : public SceneElement {
 public:
  ClothElement(const ClothConfig& config, const Eigen::Vector3d& gravity) : sim_(config, gravity) {}
  void Step(const StepContext& s) override { sim_.Step(s.dt, s.hull, s.stop); }
  void Output(double, uint64_t, ElementOutput* out) override {
    VirtualMeshSample m;
    m.object_id = uint32_t(sim_.config().id);
    m.kind = kMeshCloth;
    const TriangleMesh mesh = sim_.Mesh();
    m.draw.vertices = mesh.vertices;
    m.draw.triangles = mesh.triangles;
    m.draw.colliding = sim_.colliding();
    m.draw.colour = cv::Vec3b(150, 90, 60);
    out->meshes.push_back(std::move(m));
  }

 private:
  ClothSimulation sim_;
};

}  // namespace

std::unique_ptr<SceneElement> ClothConfig::Make(const SceneConfig& scene) const {
  return std::make_unique<ClothElement>(*this, scene.gravity);
}

std::shared_ptr<const SceneElementConfig> ReadClothSection(const YAML::Node& n, const std::string& path) {
  using namespace scene_yaml;
  auto c = std::make_shared<ClothConfig>();
  Section(n, path, "cloth")
      .Field("id", &c->id)
      .Vec("rod_a", &c->rod_a, Need::kRequired)
      .Vec("rod_b", &c->rod_b, Need::kRequired)
      .Field("length", &c->length, Need::kRequired)
      .Field("nx", &c->nx)
      .Field("ny", &c->ny)
      .Field("iterations", &c->iterations)
      .Field("damping", &c->damping)
      .Field("max_substep", &c->max_substep)
      .Field("clearance", &c->clearance)
      .Field("max_search", &c->max_search)
      .Field("max_pixel_size", &c->collision.max_pixel_size)
      .Read();
  return c;
}

}  // namespace hullpipe
