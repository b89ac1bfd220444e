#include "hullpipe/scenes/model_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <yaml-cpp/yaml.h>

#include "hullpipe/collision/collision.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/collision/collision_response.h"
#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_yaml.h"
#include "hullpipe/util/parallel.h"

namespace hullpipe {

void ModelEntry::Check() const {
  if (!(scale >= kMinModelScale && scale <= kMaxModelScale))
    throw std::invalid_argument("models: scale must be in [1e-06, 1000] metres per file unit");
  if (!(position.cwiseAbs().maxCoeff() <= kMaxStatedExtentM))
    throw std::invalid_argument("models: position must be finite and within 10000 m of the origin");
  if (!position.allFinite()) throw std::invalid_argument("models: position must be finite");
  if (!std::isfinite(yaw_deg)) throw std::invalid_argument("models: yaw_deg must be finite");
  if (first_id < 0) throw std::invalid_argument("models: first_id must be >= 0");
  if (!(warn_distance >= 0 && warn_distance <= 1))
    throw std::invalid_argument("models: warn_distance must be in [0, 1] m");
  if (!(max_clearance > 0 && max_clearance <= 1 && max_clearance >= warn_distance))
    throw std::invalid_argument("models: max_clearance must be in (0, 1] m and >= warn_distance");
  if (!(max_pixel_size >= 1e-4 && max_pixel_size <= 0.1))
    throw std::invalid_argument("models: max_pixel_size must be in [1e-4, 0.1] m");
  if (!(restitution >= 0 && restitution <= 1)) throw std::invalid_argument("models: restitution must be in [0, 1]");
  if (motion == Motion::kDynamic && imported && imported->triangles() > kMaxDynamicModelTriangles)
    throw std::invalid_argument("models: " + file + " has " + std::to_string(imported->triangles()) +
                                " triangles, over the cap of " + std::to_string(kMaxDynamicModelTriangles) +
                                " for motion: dynamic (use motion: static)");
}

std::vector<ObjectIdRange> ModelsConfig::ObjectIds() const {
  std::vector<ObjectIdRange> out;
  for (const ModelEntry& m : models) {
    const int64_t parts = m.imported ? int64_t(std::max<size_t>(1, m.imported->parts.size())) : 1;
    out.push_back({m.first_id, m.first_id + parts - 1, "models: " + m.file});
  }
  return out;
}

std::string ModelsConfig::Describe() const {
  std::ostringstream s;
  for (size_t k = 0; k < models.size(); ++k) {
    const auto& m = models[k];
    s << (k ? ", " : "") << "model " << m.file;
    if (m.imported)
      s << " (" << m.imported->parts.size() << " parts, " << m.imported->triangles() << " triangles; skipped "
        << m.imported->counts.lines_and_points << " line/point primitives, " << m.imported->counts.degenerate_triangles
        << " degenerate triangles)";
  }
  return s.str();
}

void ModelsConfig::CheckIn(const SceneConfig&) const {
  int64_t triangles = 0;
  for (const auto& m : models) {
    m.Check();
    if (m.imported) triangles += m.imported->triangles();
  }
  if (triangles > kMaxSceneModelTriangles)
    throw std::invalid_argument("models: " + std::to_string(triangles) + " triangles in all, over the cap of " +
                                std::to_string(kMaxSceneModelTriangles) + " per scene");
  // Object ids may not overlap between models.
  for (size_t a = 0; a < models.size(); ++a)
    for (size_t b = a + 1; b < models.size(); ++b) {
      if (!models[a].imported || !models[b].imported) continue;
      const int64_t a0 = models[a].first_id, a1 = a0 + int64_t(models[a].imported->parts.size());
      const int64_t b0 = models[b].first_id, b1 = b0 + int64_t(models[b].imported->parts.size());
      if (a0 < b1 && b0 < a1) throw std::invalid_argument("models: the object ids of " + models[a].file + " and " +
                                                          models[b].file + " overlap (first_id)");
    }
}

std::shared_ptr<const SceneElementConfig> ModelsConfig::PlaceOnStage(const Rigid3d& world_from_stage) const {
  auto placed = std::make_shared<ModelsConfig>(*this);
  for (auto& m : placed->models) m.world_from_stage = world_from_stage;
  return placed;
}

Rigid3d ModelPlacement(const ModelEntry& e, const Eigen::Vector3d& world_up, const Aabb& file_box) {
  if (e.world_from_stage) {
    // The same placement in the stage's frame (its up is +z), then onto the world.
    ModelEntry in_stage = e;
    in_stage.world_from_stage.reset();
    return *e.world_from_stage * ModelPlacement(in_stage, Eigen::Vector3d::UnitZ(), file_box);
  }
  const Eigen::Vector3d up = world_up.norm() > 0 ? Eigen::Vector3d(world_up.normalized()) : Eigen::Vector3d::UnitZ();
  const Eigen::Matrix3d align = Eigen::Quaterniond::FromTwoVectors(e.up_file.normalized(), up).toRotationMatrix();
  const Eigen::Matrix3d yaw = Eigen::AngleAxisd(e.yaw_deg * M_PI / 180.0, up).toRotationMatrix();
  Rigid3d T;
  T.rotation = yaw * align;
  // The anchor in the scaled file frame.
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  if (e.anchor != ModelEntry::Anchor::kOrigin && !file_box.empty()) {
    anchor = e.scale * file_box.Center();
    if (e.anchor == ModelEntry::Anchor::kBottom) {
      // The centre of the box's face lowest along the world's up.
      const Eigen::Vector3d up_body = T.rotation.transpose() * up;
      const Eigen::Vector3d half = 0.5 * e.scale * (file_box.max - file_box.min);
      anchor -= up_body.cwiseProduct(half);  // up_body is the file's up axis: that face's centre
    }
  }
  T.translation = e.position - T.rotation * anchor;
  return T;
}

std::vector<ScenePart> PlaceModel(const ImportedModel& model, const ModelEntry& e, const Eigen::Vector3d& world_up) {
  Aabb file_box;
  for (const auto& p : model.parts)
    for (const auto& v : p.vertices) file_box.Extend(v.cast<double>());
  const Rigid3d T = ModelPlacement(e, world_up, file_box);
  std::vector<ScenePart> parts;
  parts.reserve(model.parts.size());
  for (const auto& ip : model.parts) {
    ScenePart p;
    p.name = ip.name;
    p.dynamic = e.motion == ModelEntry::Motion::kDynamic;
    p.colour = ip.colour;
    p.world_from_body = T;
    p.body.reserve(ip.vertices.size());
    p.mesh.vertices.reserve(ip.vertices.size());
    for (const auto& v : ip.vertices) {
      const Eigen::Vector3d b = e.scale * v.cast<double>();
      p.body.push_back(b.cast<float>());
      p.mesh.vertices.push_back(p.dynamic ? b : T * b);
    }
    p.mesh.triangles = ip.triangles;
    p.bvh = TriangleBvh(p.mesh);
    parts.push_back(std::move(p));
  }
  return parts;
}

namespace {

// Clearances below warn_distance + this are refined to 0.27 mm; above, they
// are the 2 cm grid's (at most 17 mm above the hull's distance): 2 cm is more
// than that, so the amber state is decided on refined distances.
constexpr double kRefineMargin = 0.02;

Eigen::Vector4d Quaternion(const Eigen::Matrix3d& r) {
  const Eigen::Quaterniond q(r);
  return {q.w(), q.x(), q.y(), q.z()};
}

class ModelsElement final : public SceneElement {
 public:
  ModelsElement(const ModelsConfig& config, const SceneConfig& scene) : scene_(scene) {
    const double g = scene.gravity.norm();
    g_hat_ = g > 0 ? Eigen::Vector3d(scene.gravity / g) : Eigen::Vector3d(0, 0, 1);
    for (const auto& e : config.models) {
      if (!e.imported) throw std::invalid_argument("models: " + e.file + " was not imported");
      Model m;
      m.entry = e;
      m.parts = PlaceModel(*e.imported, e, -g_hat_);
      m.colliding.assign(m.parts.size(), false);
      m.state.parts.resize(m.parts.size());
      m.bodies.resize(m.parts.size());
      for (size_t k = 0; k < m.parts.size(); ++k) {
        const ScenePart& p = m.parts[k];
        m.triangles += p.mesh.triangles.size();
        if (!p.dynamic) continue;
        // A dynamic part's reference point (RP_obj, §4.2) is its box's centre;
        // its lowest point along gravity and its smallest half extent (the
        // farthest it may move in one substep) are fixed by its orientation.
        Body& b = m.bodies[k];
        Aabb box;
        for (const auto& v : p.mesh.vertices) box.Extend(v);
        b.centre_body = box.empty() ? Eigen::Vector3d::Zero() : box.Center();
        b.support = -1e300;
        for (const auto& v : p.mesh.vertices)
          b.support = std::max(b.support, g_hat_.dot(p.world_from_body.rotation * v));
        b.reach = box.empty() ? kMinReach : std::max(kMinReach, 0.5 * (box.max - box.min).minCoeff());
      }
      m.results.resize(m.parts.size());
      SetPoses(m);
      models_.push_back(std::move(m));
    }
    threads_ = ThreadsOrCores(config.threads);
    query_ = config.query;
  }

  void Step(const StepContext& step) override {
    const VolumeQuery* hull = step.hull;
    const StopFlag stop = step.stop;
    scene_.TakeFloorUnderHull(hull);  // as the balls take it
    for (Model& m : models_) {
      const auto t0 = std::chrono::steady_clock::now();
      BvhQueryStats stats;
      stats.triangles_in_scene = int64_t(m.triangles);
      for (auto& r : m.results) r = {};
      if (m.entry.motion == ModelEntry::Motion::kDynamic)
        Move(m, std::clamp(step.dt, 0.0, 0.25), hull, step.hull_motion, stop, &stats);
      else if (hull)
        Detect(m, *hull, stop, &stats);
      if (hull) Clearances(m, *hull, stop);
      SetPoses(m);
      m.state.triangles = uint64_t(stats.triangles_in_scene);
      m.state.boxes_tested = uint64_t(stats.boxes_tested);
      m.state.triangles_queried = uint64_t(stats.triangles_queried);
      m.state.query_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
  }

  void Output(double source_time_s, uint64_t frame_seq, ElementOutput* out) override {
    for (Model& m : models_) {
      const uint32_t id0 = uint32_t(m.entry.first_id);
      if (!geometry_sent_) {
        for (size_t k = 0; k < m.parts.size(); ++k) {
          ModelPartSample g;
          g.object_id = id0 + uint32_t(k);
          g.model_id = id0;
          g.part_index = uint32_t(k);
          g.part_count = uint32_t(m.parts.size());
          g.name = m.parts[k].name;
          g.file = m.entry.file;
          g.vertices = m.parts[k].body;
          g.triangles = m.parts[k].mesh.triangles;
          g.colour = m.parts[k].colour;
          out->model_parts.push_back(std::move(g));
        }
      }
      m.state.model_id = id0;
      out->model_states.push_back(m.state);
      for (size_t k = 0; k < m.parts.size(); ++k) {
        const bool hit = m.state.parts[k].contact == kPartColliding;
        if (hit) {
          CollisionReportSample r;
          r.object_id = id0 + uint32_t(k);
          for (int t : m.results[k].triangle_ids) r.triangle_ids.push_back(uint32_t(t));
          r.collision_points = m.results[k].collision_points;
          if (const auto& resp = m.bodies[k].response) {
            r.has_response = true;
            r.cp_obj = resp->cp_obj;
            r.cp_hull = resp->cp_hull;
            r.v_rec = resp->v_rec;
            r.d_rec = resp->d_rec;
            r.n_hull = resp->n_hull;
            r.hull_velocity_status = uint8_t(resp->hull_velocity.status);
            r.hull_normal_speed = resp->hull_velocity.normal_speed;
            r.hull_velocity_interval = resp->hull_velocity.interval_s;
          }
          out->reports.push_back(std::move(r));
          if (m.parts[k].dynamic) ++out->colliding_bodies;
        }
        if (hit != m.colliding[k]) out->events.push_back({source_time_s, frame_seq, m.parts[k].name, hit, 0.0});
        m.colliding[k] = hit;
      }
    }
    geometry_sent_ = true;
  }

 private:
  // The least distance a dynamic part may move in one substep (its smallest
  // half extent, but not less than this: a flat part would take no step).
  static constexpr double kMinReach = 0.005;
  // Substeps per step at most for a dynamic model (each queries its parts).
  static constexpr int kMaxSubsteps = 200;

  struct Body {  // a dynamic part's motion
    Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
    Eigen::Vector3d centre_body = Eigen::Vector3d::Zero();
    double support = 0;  // max over its vertices of g_hat . (R v)
    double reach = kMinReach;
    std::optional<CollisionResponse> response;  // of its last colliding substep
  };

  struct Model {
    ModelEntry entry;
    std::vector<ScenePart> parts;
    std::vector<Body> bodies;      // per part (dynamic models)
    std::vector<bool> colliding;   // in the last output
    std::vector<CollisionResult> results;
    ModelStateSample state;
    size_t triangles = 0;
  };

  static void SetPoses(Model& m) {
    for (size_t k = 0; k < m.parts.size(); ++k) {
      m.state.parts[k].position = m.parts[k].world_from_body.translation;
      m.state.parts[k].orientation = Quaternion(m.parts[k].world_from_body.rotation);
    }
  }

  // Static parts (§4.1 through each part's hierarchy): every part's surviving
  // triangles queried in one batch.
  void Detect(Model& m, const VolumeQuery& hull, StopFlag stop, BvhQueryStats* stats) {
    const TriangleQueryOptions options{m.entry.max_pixel_size, 0, 32};
    std::vector<Triangle> tris;
    std::vector<int> ids;          // the mesh triangle of each
    std::vector<size_t> first{0};  // part k's triangles are [first[k], first[k + 1])
    for (const ScenePart& p : m.parts) {
      GatherBvhTriangles(hull, p.mesh, p.bvh, p.world_from_mesh(), &tris, &ids, stats);
      first.push_back(tris.size());
    }
    ThrowIfStopped(stop, "the models' step");
    const std::vector<TriangleQueryResult> rs =
        tris.empty() ? std::vector<TriangleQueryResult>{}
        : query_     ? query_(hull, tris, options)
                     : QueryTrianglesCpu(hull, tris, options, threads_);
    if (rs.size() != tris.size()) throw std::runtime_error("models: the triangle query returned the wrong count");
    for (size_t k = 0; k < m.parts.size(); ++k) {
      CollisionResult& r = m.results[k];
      r.triangles_queried = int(first[k + 1] - first[k]);
      for (size_t i = first[k]; i < first[k + 1]; ++i) AddTriangleResult(ids[i], rs[i], &r);
    }
  }

  // Dynamic parts: rigid bodies under gravity on the floor, each substep's
  // collision with the hull answered by §4.2 as the balls' is (ball.h): moved
  // by D_rec along V_rec (plus 1 mm) so CP_obj reaches the hull's surface, the
  // normal velocity reflected about N_hull with the restitution. Substeps are
  // short in time (max_substep) and in space (no part moves more than its
  // smallest half extent), at most kMaxSubsteps a step.
  void Move(Model& m, double dt, const VolumeQuery* hull, const HullMotion* motion, StopFlag stop,
            BvhQueryStats* stats) {
    const TriangleQueryOptions options{m.entry.max_pixel_size, 0, 32};
    int substeps = std::max(1, int(std::ceil(dt / scene_.max_substep)));
    const double g_norm = scene_.gravity.norm();
    for (const Body& b : m.bodies) {
      const double reach = (b.velocity.norm() + g_norm * dt) * dt;
      substeps = std::max(substeps, int(std::min(double(kMaxSubsteps), std::ceil(reach / b.reach))));
    }
    const double h = dt / substeps;
    const double e = m.entry.restitution;
    for (auto& b : m.bodies) b.response.reset();
    std::vector<bool> collided(m.parts.size(), false);
    TriangleBatchQuery batch;  // empty: the CPU query
    if (query_ && hull) batch = [&](const std::vector<Triangle>& tris) { return query_(*hull, tris, options); };
    const bool exact = scene_.response == SceneConfig::Response::kExact;
    for (int s = 0; s < substeps; ++s) {
      ThrowIfStopped(stop, "the models' step");
      for (size_t k = 0; k < m.parts.size(); ++k) {
        ScenePart& p = m.parts[k];
        Body& b = m.bodies[k];
        Eigen::Vector3d& t = p.world_from_body.translation;
        const Eigen::Vector3d previous = t;
        b.velocity += scene_.gravity * h;
        t += b.velocity * h;
        if (scene_.has_floor && b.support + g_hat_.dot(t) > scene_.floor) {
          t -= (b.support + g_hat_.dot(t) - scene_.floor) * g_hat_;
          const double vn = b.velocity.dot(g_hat_);
          if (vn > 0) b.velocity -= (1 + e) * vn * g_hat_;
        }
        if (!hull || p.mesh.triangles.empty()) continue;
        BvhQueryStats one;
        CollisionResult c =
            DetectCollisionsBvh(*hull, p.mesh, p.bvh, p.world_from_body, options, batch, threads_, &one);
        stats->boxes_tested += one.boxes_tested;
        stats->triangles_queried += one.triangles_queried;
        if (!c.colliding()) continue;
        // §4.2, as for the balls (the world mesh only for the exact CP_obj).
        const TriangleMesh world = exact ? p.mesh.Transformed(p.world_from_body) : TriangleMesh{};
        RigidBodyResponseRequest request;
        request.world_mesh = &world;
        request.rp_obj = p.world_from_body * b.centre_body;
        request.query = options;
        request.exact = exact;
        request.restitution = e;
        request.previous = previous;
        request.fallback_normal = -g_hat_;
        request.motion = motion;
        b.response = RespondAsRigidBody(*hull, request, &c, &t, &b.velocity);
        collided[k] = true;
        m.results[k] = std::move(c);
      }
    }
    for (size_t k = 0; k < m.parts.size(); ++k)
      if (!collided[k]) m.results[k] = {};
  }

  // Clearance (§4.5): the hull sampled once over the model's box grown by the
  // range, shared by its parts; the parts spread over the threads. A part that
  // collided is colliding, clearance 0.
  void Clearances(Model& m, const VolumeQuery& hull, StopFlag stop) {
    ThrowIfStopped(stop, "the models' step");
    Aabb region;
    for (const ScenePart& p : m.parts) {
      if (p.bvh.empty()) continue;
      const Aabb box = TransformBox(p.world_from_mesh(), p.bvh.nodes()[0].box);
      region.Extend(box.min), region.Extend(box.max);
    }
    if (region.empty()) return;
    region.min -= Eigen::Vector3d::Constant(m.entry.max_clearance);
    region.max += Eigen::Vector3d::Constant(m.entry.max_clearance);
    const HullSamples coarse = SampleHull(hull, region);
    ForEachRowDynamic(int(m.parts.size()), threads_, [&](int k, int) {
      PartStateSample& s = m.state.parts[size_t(k)];
      if (m.results[size_t(k)].colliding()) {
        s.contact = kPartColliding;
        s.clearance = 0;
        return;
      }
      const ScenePart& p = m.parts[size_t(k)];
      // Refined where the state depends on it (near warn_distance) or the hull
      // is close; farther, the coarse grid's distance (models/part_bvh.h).
      const PartClearance c = HullToPartClearance(hull, p.mesh, p.bvh, p.world_from_mesh(), m.entry.max_clearance,
                                                  coarse, m.entry.warn_distance + kRefineMargin);
      s.clearance = c.distance;
      s.contact = m.entry.warn_distance > 0 && c.distance < m.entry.warn_distance ? kPartNear : kPartClear;
    });
  }

  SceneConfig scene_;  // gravity, floor (set under the first hull where the rig says so), response
  Eigen::Vector3d g_hat_;
  std::vector<Model> models_;
  bool geometry_sent_ = false;
  int threads_ = 1;
  TriangleQueryFunction query_;
};

}  // namespace

std::unique_ptr<SceneElement> ModelsConfig::Make(const SceneConfig& scene) const {
  return std::make_unique<ModelsElement>(*this, scene);
}

std::shared_ptr<const SceneElementConfig> ReadModelsSection(const YAML::Node& n, const std::string& path,
                                                            const SceneLoadOptions& load) {
  using namespace scene_yaml;
  if (!n.IsSequence() || n.size() == 0) throw std::runtime_error(path + ": 'models' must be a list of model entries");
  auto c = std::make_shared<ModelsConfig>();
  const std::string dir = path.find('/') == std::string::npos ? "" : path.substr(0, path.rfind('/') + 1);
  int next_id = 1000;
  int64_t triangles = 0, parts = 0;
  for (size_t k = 0; k < n.size(); ++k) {
    const YAML::Node m = n[k];
    const std::string where = "models[" + std::to_string(k) + "]";
    ModelEntry e;
    e.first_id = next_id;
    std::optional<double> units;  // metres per file unit
    std::optional<Eigen::Vector3d> up;
    const Eigen::Vector3d ux = Eigen::Vector3d::UnitX(), uy = Eigen::Vector3d::UnitY(), uz = Eigen::Vector3d::UnitZ();
    using Motion = ModelEntry::Motion;
    using Anchor = ModelEntry::Anchor;
    Section entry(m, path, where);
    entry.Field("file", &e.file, Need::kRequired)
        .Choice<std::optional<double>>("units", &units, {{"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}})
        .Field("scale", &e.scale)
        .Choice<std::optional<Eigen::Vector3d>>("up", &up,
                                                {{"+x", ux},
                                                 {"x", ux},
                                                 {"-x", -ux},
                                                 {"+y", uy},
                                                 {"y", uy},
                                                 {"-y", -uy},
                                                 {"+z", uz},
                                                 {"z", uz},
                                                 {"-z", -uz}},
                                                "one of +x -x +y -y +z -z")
        .Choice("anchor", &e.anchor,
                {{"origin", Anchor::kOrigin},
                 {"centre", Anchor::kCentre},
                 {"center", Anchor::kCentre},
                 {"bottom", Anchor::kBottom}},
                "origin, centre or bottom")
        .Vec("position", &e.position)
        .Field("yaw_deg", &e.yaw_deg)
        .Choice("motion", &e.motion, {{"static", Motion::kStatic}, {"dynamic", Motion::kDynamic}})
        .Field("restitution", &e.restitution)
        .Field("first_id", &e.first_id)
        .Field("warn_distance", &e.warn_distance)
        .Field("max_clearance", &e.max_clearance)
        .Field("max_pixel_size", &e.max_pixel_size)
        .Read();
    e.path = !e.file.empty() && e.file[0] == '/' ? e.file : dir + e.file;
    const std::string ext = ModelFileExtension(e.file);
    if (units && entry.Has("scale"))
      throw std::runtime_error(path + ": '" + where + "': give units or scale, not both");
    if (units) {
      e.scale = *units;
    } else if (!entry.Has("scale") && ext != "gltf" && ext != "glb") {  // glTF: metres by its specification
      throw std::runtime_error(path + ": '" + where + "': " + e.file +
                               " carries no units (only glTF is metres by its specification): give units (m, cm, "
                               "mm, in) or scale");
    }
    // The file's up: as said, else its format's convention (STL and PLY +z, the rest +y).
    e.up_file = up ? *up : (ext == "stl" || ext == "ply") ? uz : uy;
    try {
      e.Check();
    } catch (const std::invalid_argument& x) {
      throw std::runtime_error(path + ": '" + where + "': " + x.what());
    }
    if (load.import_models) {
      ImportLimits limits;
      limits.max_file_bytes = kMaxModelFileBytes;
      limits.max_triangles = kMaxSceneModelTriangles - triangles;
      if (limits.max_triangles < 1)
        throw std::runtime_error(path + ": '" + where + "': the scene's models already hold the cap of " +
                                 std::to_string(kMaxSceneModelTriangles) + " triangles");
      limits.max_parts = kMaxSceneModelParts - parts;
      limits.stop = load.stop;
      if (limits.max_parts < 1)
        throw std::runtime_error(path + ": '" + where + "': the scene's models already hold the cap of " +
                                 std::to_string(kMaxSceneModelParts) + " parts");
      e.imported = std::make_shared<const ImportedModel>(ImportModel(e.path, limits));
      // Placed, every vertex lies within 10 km of the origin (before the up
      // rotation and yaw, which keep distances from the anchor).
      double reach = 0;
      for (const auto& p : e.imported->parts)
        for (const auto& v : p.vertices) reach = std::max(reach, double(v.cast<double>().norm()));
      const double placed = 2 * reach * e.scale + e.position.norm();  // the anchor moves by at most the reach
      if (!(placed <= kMaxStatedExtentM))
        throw std::runtime_error(path + ": '" + where + ".scale': " + e.file + " reaches " +
                                 std::to_string(reach) + " file units from its origin; at scale " +
                                 std::to_string(e.scale) + " it would lie up to " + std::to_string(placed) +
                                 " m from the world's origin, over 10000 m");
      triangles += e.imported->triangles();
      parts += int64_t(e.imported->parts.size());
      next_id = e.first_id + int(e.imported->parts.size());
    }
    c->models.push_back(std::move(e));
  }
  return c;
}

}  // namespace hullpipe
