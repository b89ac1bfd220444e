#include "hullpipe/scenes/payload.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <Eigen/Geometry>

#include "hullpipe/models/model_import.h"
#include "hullpipe/scenes/model_scene.h"
#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/scene_yaml.h"
#include "hullpipe/util/csv.h"

namespace hullpipe {

double PayloadPart::SignedDistance(const Eigen::Vector3d& p) const {
  const Eigen::Vector3d d = p - centre;
  if (type == Type::kMesh) return shape->Signed(d);
  if (type == Type::kBox) {
    const Eigen::Vector3d q = d.cwiseAbs() - half_extents;
    return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
  }
  const double along = std::abs(d[axis]);
  Eigen::Vector3d radial = d;
  radial[axis] = 0;
  const Eigen::Vector2d q(radial.norm() - radius, along - half_length);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

Aabb PayloadPart::Bounds() const {
  Aabb b;
  Eigen::Vector3d h = half_extents;
  if (type == Type::kCylinder) {
    h = Eigen::Vector3d::Constant(radius);
    h[axis] = half_length;
  }
  b.min = centre - h;
  b.max = centre + h;
  return b;
}

TriangleMesh PayloadPart::Mesh() const {
  if (type == Type::kMesh) {
    Rigid3d pose;
    pose.translation = centre;
    return shape->mesh().Transformed(pose);
  }
  if (type == Type::kBox) {
    Rigid3d pose;
    pose.translation = centre;
    return TriangleMesh::Box(half_extents, 0.02).Transformed(pose);
  }
  // A closed cylinder of 24 sides, its axis along world axis `axis`.
  TriangleMesh m;
  const int n = 24;
  const int a = axis, b = (axis + 1) % 3, c = (axis + 2) % 3;
  auto at = [&](double along, double ang) {
    Eigen::Vector3d p = centre;
    p[a] += along;
    p[b] += radius * std::cos(ang);
    p[c] += radius * std::sin(ang);
    return p;
  };
  for (int i = 0; i < n; ++i) {
    const double ang = 2 * M_PI * i / n;
    m.vertices.push_back(at(-half_length, ang));
    m.vertices.push_back(at(half_length, ang));
  }
  Eigen::Vector3d lo = centre, hi = centre;
  lo[a] -= half_length;
  hi[a] += half_length;
  m.vertices.push_back(lo);
  m.vertices.push_back(hi);
  const int ilo = 2 * n, ihi = 2 * n + 1;
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    m.triangles.emplace_back(2 * i, 2 * j, 2 * j + 1);
    m.triangles.emplace_back(2 * i, 2 * j + 1, 2 * i + 1);
    m.triangles.emplace_back(ilo, 2 * j, 2 * i);
    m.triangles.emplace_back(ihi, 2 * i + 1, 2 * j + 1);
  }
  return m;
}

void PayloadConfig::Check() const {
  if (!pmt_centre.allFinite()) throw std::invalid_argument("payload: pmt_centre must be finite");
  if (!(pmt_half.minCoeff() > 0) || !(a_half.minCoeff() > 0))
    throw std::invalid_argument("payload: pmt_half and a_half must be > 0");
  for (const auto* m : {&pmt_model, &a_model})
    if (*m && !(std::isfinite((*m)->scale) && (*m)->scale >= 1e-6 && (*m)->scale <= 1000))
      throw std::invalid_argument(std::string("payload: ") + (m == &pmt_model ? "pmt_model" : "a_model") +
                                  ".scale must be in [1e-06, 1000] metres per file unit");
  if (axis < 0 || axis > 2) throw std::invalid_argument("payload: axis must be 0, 1 or 2");
  if (direction != 1 && direction != -1) throw std::invalid_argument("payload: direction must be 1 or -1");
  if (!(spacing >= 0 && spacing < 10)) throw std::invalid_argument("payload: spacing must be in [0, 10) m");
  if (!(shaft_radius > 0) || !(shaft_length > 0))
    throw std::invalid_argument("payload: shaft_radius and shaft_length must be > 0");
  if (!(max_clearance > 0 && max_clearance <= 2))
    throw std::invalid_argument("payload: max_clearance must be in (0, 2]");
  if (!(collision.max_pixel_size >= TriangleQueryOptions::kMinPixelSize && collision.max_pixel_size <= 1))
    throw std::invalid_argument("payload: max_pixel_size must be in [1e-05, 1] m");
  collision.Check();
}

std::vector<PayloadPart> PayloadConfig::Parts() const {
  // A model part: its mesh, its box's half extents standing for the box's.
  auto as_model = [](const std::optional<PayloadModel>& model, PayloadPart* part) {
    if (!model) return;
    if (!model->shape) throw std::logic_error("payload: " + part->name + "'s model " + model->file + " not imported");
    part->type = PayloadPart::Type::kMesh;
    part->shape = model->shape;
    const Aabb box = model->shape->bounds();
    part->half_extents = 0.5 * (box.max - box.min);
  };
  PayloadPart pmt;
  pmt.name = "PMT";
  pmt.centre = pmt_centre;
  pmt.half_extents = pmt_half;
  as_model(pmt_model, &pmt);
  PayloadPart a;
  a.name = "payload A";
  a.half_extents = a_half;
  as_model(a_model, &a);
  a.centre = pmt_centre;
  a.centre[axis] += direction * (pmt.half_extents[axis] + spacing + a.half_extents[axis]);
  if (a_model) return {pmt, a};
  PayloadPart shaft;
  shaft.name = "payload A shaft";
  shaft.type = PayloadPart::Type::kCylinder;
  shaft.axis = axis;
  shaft.radius = shaft_radius;
  shaft.half_length = 0.5 * shaft_length;
  shaft.centre = a.centre;
  shaft.centre[axis] += direction * (a.half_extents[axis] + 0.5 * shaft_length);
  return {pmt, a, shaft};
}

namespace {

// Inside-hull grid samples of box `b` at spacing h; calls f(point) for each.
template <typename F>
void ForEachInsideSample(const VolumeQuery& q, const Aabb& b, double h, F&& f) {
  ForEachGridPoint(b, h, [&](const Eigen::Vector3d& p) {
    if (q.Inside(p)) f(p);
  });
}

}  // namespace

ClearanceResult HullClearance(const VolumeQuery& q, const PayloadPart& part, double max_clearance) {
  ClearanceResult r;
  r.distance = max_clearance;
  Aabb region = part.Bounds();
  region.min -= Eigen::Vector3d::Constant(max_clearance);
  region.max += Eigen::Vector3d::Constant(max_clearance);
  region = region.Intersection(q.hull_box());
  if (region.empty()) return r;
  double best = std::numeric_limits<double>::infinity();
  Eigen::Vector3d best_p = Eigen::Vector3d::Zero();
  double h = 0.02;
  ForEachInsideSample(q, region, h, [&](const Eigen::Vector3d& p) {
    const double d = part.SignedDistance(p);
    if (d < best) best = d, best_p = p;
  });
  if (!std::isfinite(best)) return r;
  // Refine around the nearest sample on grids five times finer, three times.
  for (int level = 0; level < 3; ++level) {
    Aabb window;
    window.min = best_p - Eigen::Vector3d::Constant(2 * h);
    window.max = best_p + Eigen::Vector3d::Constant(2 * h);
    h /= 5;
    ForEachInsideSample(q, window.Intersection(q.hull_box()), h, [&](const Eigen::Vector3d& p) {
      const double d = part.SignedDistance(p);
      if (d < best) best = d, best_p = p;
    });
  }
  r.hull_near = best < max_clearance;
  r.colliding = best <= 0;
  r.distance = std::clamp(best, 0.0, max_clearance);
  r.hull_point = best_p;
  return r;
}

PayloadFrame EvaluatePayload(const PayloadConfig& config, const VolumeQuery* hull) {
  PayloadFrame f;
  f.parts = config.Parts();
  for (const auto& part : f.parts) {
    if (!hull) {
      f.collisions.emplace_back();
      ClearanceResult none;
      none.distance = config.max_clearance;
      f.clearance.push_back(none);
      continue;
    }
    if (part.type == PayloadPart::Type::kMesh) {
      // A model part through its hierarchy: the same result as every triangle
      // (part_bvh.h), without querying the triangles the hull cannot reach.
      Rigid3d world_from_body;
      world_from_body.translation = part.centre;
      f.collisions.push_back(
          DetectCollisionsBvh(*hull, part.shape->mesh(), part.shape->bvh(), world_from_body, config.collision));
    } else {
      f.collisions.push_back(DetectCollisions(*hull, part.Mesh(), config.collision));
    }
    f.clearance.push_back(HullClearance(*hull, part, config.max_clearance));
  }
  return f;
}

std::vector<PipePose> LoadPipeMotion(const std::string& path) {
  std::vector<PipePose> out;
  for (const CsvRow& row : ReadNumericCsv(path, 8, "t,px,py,pz,qx,qy,qz,radius")) {
    const auto& v = row.values;
    if (!(v[7] > 0)) throw std::runtime_error(CsvWhere(path, row.line) + "radius must be > 0");
    out.push_back({v[0], {v[1], v[2], v[3]}, {v[4], v[5], v[6]}, v[7]});
  }
  return out;
}

void SavePipeMotion(const std::string& path, const std::vector<PipePose>& motion) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out << "t,px,py,pz,qx,qy,qz,radius\n";
  out.precision(9);
  for (const auto& m : motion)
    out << m.t << ',' << m.p.x() << ',' << m.p.y() << ',' << m.p.z() << ',' << m.q.x() << ',' << m.q.y() << ','
        << m.q.z() << ',' << m.radius << '\n';
}

std::vector<PipePose> ExamplePipeMotion(const PayloadConfig& c, double travel, int frames, double* needed) {
  const int a = c.axis, b = (c.axis + 1) % 3;
  const double r = 0.02, half_segment = 0.05;  // 14 cm long in all, 4 cm across
  const double face = c.pmt_centre[a] + c.direction * c.pmt_half[a];
  std::vector<PipePose> m;
  for (int f = 0; f < frames; ++f) {
    const double t = 2.0 * f / std::max(1, frames - 1);
    const double s = 0.5 * (1 - std::cos(M_PI * t));  // 0 -> 1 -> 0 over 2 s
    Eigen::Vector3d centre = c.pmt_centre;
    centre[a] = face + c.direction * (0.01 + r + travel * s);
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[b] = half_segment;
    m.push_back({t, centre - e, centre + e, r});
  }
  if (needed) *needed = 0.01 + 2 * r + travel;
  return m;
}

namespace {
bool ACollides(const PayloadConfig& c, const VolumeQuery& q, double* clearance) {
  const auto parts = c.Parts();
  bool hit = false;
  for (size_t k = 1; k < parts.size(); ++k) {
    const ClearanceResult r = HullClearance(q, parts[k], c.max_clearance);
    *clearance = std::min(*clearance, r.distance);
    hit = hit || r.colliding;
  }
  return hit;
}
}  // namespace

SpacingSweepResult SweepSpacing(const PayloadConfig& config, const std::vector<VolumeQuery>& hulls, double from,
                                double to, double step, double resolution) {
  if (!(from >= 0 && to >= from && step > 0 && resolution > 0))
    throw std::invalid_argument("SweepSpacing: need 0 <= from <= to, step > 0, resolution > 0");
  SpacingSweepResult res;
  res.smallest_free = std::numeric_limits<double>::quiet_NaN();
  const auto pmt = config.Parts()[0];
  for (const auto& q : hulls) res.pmt_frames_colliding += HullClearance(q, pmt, config.max_clearance).colliding;
  auto collides_at = [&](double s, double* min_clearance, int* frames) {
    PayloadConfig c = config;
    c.spacing = s;
    *min_clearance = c.max_clearance;
    int n = 0;
    for (const auto& q : hulls) n += ACollides(c, q, min_clearance);
    if (frames) *frames = n;
    return n > 0;
  };
  double last_colliding = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; from + k * step <= to + 1e-12; ++k) {
    SpacingSweepResult::Row row;
    row.spacing = from + k * step;
    collides_at(row.spacing, &row.min_clearance, &row.frames_colliding);
    res.rows.push_back(row);
    if (row.frames_colliding > 0) {
      last_colliding = row.spacing;
    } else if (std::isnan(res.smallest_free)) {
      res.smallest_free = row.spacing;
    }
  }
  if (std::isnan(res.smallest_free) || std::isnan(last_colliding) || last_colliding > res.smallest_free)
    return res;  // none free, or free from the first row (nothing to bisect)
  double lo = last_colliding, hi = res.smallest_free;
  double ignored = 0;
  while (hi - lo > resolution) {
    const double mid = 0.5 * (lo + hi);
    (collides_at(mid, &ignored, nullptr) ? lo : hi) = mid;
  }
  res.smallest_free = hi;
  return res;
}

// ---- The payload task as a scene element (scene_element.h).

void PayloadConfig::CheckIn(const SceneConfig&) const { Check(); }

std::string PayloadConfig::Describe() const {
  std::string s = "the payload task";
  auto said = [](const char* who, const std::optional<PayloadModel>& m) {
    if (!m) return std::string();
    std::string t = std::string(who) + ": " + m->file + (m->part.empty() ? "" : " part '" + m->part + "'");
    if (m->shape && !m->shape->closed()) t += ", not closed: clearance to its surface";
    return t;
  };
  const std::string p = said("PMT", pmt_model), a = said("payload A", a_model);
  if (!p.empty() || !a.empty()) s += " (" + p + (p.empty() || a.empty() ? "" : "; ") + a + ")";
  return s;
}

namespace {

class PayloadElement final : public SceneElement {
 public:
  explicit PayloadElement(const PayloadConfig& config) : config_(config) {}
  void Step(const StepContext& s) override { frame_ = EvaluatePayload(config_, s.hull); }
  void Output(double source_time_s, uint64_t frame_seq, ElementOutput* out) override {
    colliding_.resize(frame_.parts.size(), false);
    for (size_t k = 0; k < frame_.parts.size(); ++k) {
      VirtualMeshSample m;
      m.object_id = uint32_t(config_.first_id + int(k));
      m.kind = kMeshPart;
      const TriangleMesh mesh = frame_.parts[k].Mesh();
      m.draw.vertices = mesh.vertices;
      m.draw.triangles = mesh.triangles;
      const bool hit = frame_.collisions[k].colliding() || frame_.clearance[k].colliding;
      // A part in collision is drawn red whole (§5.2); the PMT grey, the others green.
      m.draw.colliding.assign(mesh.triangles.size(), hit ? 1 : 0);
      m.draw.colour = k == 0 ? cv::Vec3b(160, 160, 160) : cv::Vec3b(90, 170, 90);
      m.clearance = frame_.clearance[k].distance;
      out->meshes.push_back(std::move(m));
      if (hit != colliding_[k])
        out->events.push_back({source_time_s, frame_seq, frame_.parts[k].name, hit, config_.spacing});
      colliding_[k] = hit;
    }
  }
  bool SetSpacing(double spacing_m) override {
    PayloadConfig c = config_;
    c.spacing = spacing_m;
    c.Check();
    config_ = c;
    return true;
  }

 private:
  PayloadConfig config_;
  PayloadFrame frame_;
  std::vector<bool> colliding_;  // parts colliding in the last output
};

}  // namespace

std::unique_ptr<SceneElement> PayloadConfig::Make(const SceneConfig&) const {
  return std::make_unique<PayloadElement>(*this);
}

namespace {

// One of the payload's model entries ({file, part, units | scale,
// rotation_deg}), imported unless `load` says not to.
PayloadModel ReadPayloadModel(const YAML::Node& n, const std::string& path, const std::string& where,
                              const SceneLoadOptions& load) {
  using namespace scene_yaml;
  PayloadModel m;
  std::optional<double> units;
  Section entry(n, path, where);
  entry.Field("file", &m.file, Need::kRequired)
      .Field("part", &m.part)
      .Choice<std::optional<double>>("units", &units, {{"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}})
      .Field("scale", &m.scale)
      .Vec("rotation_deg", &m.rotation_deg)
      .Read();
  const std::string dir = path.find('/') == std::string::npos ? "" : path.substr(0, path.rfind('/') + 1);
  m.path = !m.file.empty() && m.file[0] == '/' ? m.file : dir + m.file;
  const std::string ext = ModelFileExtension(m.file);
  if (units && entry.Has("scale")) throw std::runtime_error(path + ": '" + where + "': give units or scale, not both");
  if (units) {
    m.scale = *units;
  } else if (!entry.Has("scale") && ext != "gltf" && ext != "glb") {
    throw std::runtime_error(path + ": '" + where + "': " + m.file +
                             " carries no units (only glTF is metres by its specification): give units (m, cm, mm, "
                             "in) or scale");
  }
  if (!(std::isfinite(m.scale) && m.scale >= 1e-6 && m.scale <= 1000))
    throw std::runtime_error(path + ": '" + where + ".scale' must be in [1e-06, 1000] metres per file unit");
  if (!m.rotation_deg.allFinite()) throw std::runtime_error(path + ": '" + where + ".rotation_deg' must be finite");
  if (!load.import_models) return m;
  ImportLimits limits;
  limits.max_file_bytes = kMaxModelFileBytes;
  limits.max_triangles = kMaxSceneModelTriangles;  // the whole file; the part taken is capped below
  limits.stop = load.stop;
  const ImportedModel model = ImportModel(m.path, limits);
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(m.rotation_deg.z() * M_PI / 180, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(m.rotation_deg.y() * M_PI / 180, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(m.rotation_deg.x() * M_PI / 180, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  TriangleMesh mesh;
  std::string names;
  for (const ImportedPart& p : model.parts) {
    if (names.size() < 200) names += (names.empty() ? "" : ", ") + p.name;
    if (!m.part.empty() && p.name != m.part) continue;
    const int base = int(mesh.vertices.size());
    for (const auto& v : p.vertices) mesh.vertices.push_back(m.scale * (r * v.cast<double>()));
    for (const auto& t : p.triangles) mesh.triangles.emplace_back(t + Eigen::Vector3i::Constant(base));
  }
  if (mesh.triangles.empty())
    throw std::runtime_error(path + ": '" + where + ".part': " + m.file + " has no part '" + m.part +
                             "' (its parts: " + names + ")");
  if (int64_t(mesh.triangles.size()) > kMaxPayloadModelTriangles)
    throw std::runtime_error(path + ": '" + where + "': " + m.file + " gives " +
                             std::to_string(mesh.triangles.size()) + " triangles; a payload part is at most " +
                             std::to_string(kMaxPayloadModelTriangles) + " (take one of its parts: 'part')");
  if (mesh.vertices.size() > 200000)
    throw std::runtime_error(path + ": '" + where + "': " + m.file + " has " + std::to_string(mesh.vertices.size()) +
                             " vertices; a payload part is drawn whole every frame: at most 200000");
  const Aabb box = mesh.Bounds();
  const Eigen::Vector3d size = box.max - box.min, centre = box.Center();
  if (!(size.maxCoeff() <= 10))
    throw std::runtime_error(path + ": '" + where + "': " + m.file + " placed is " + std::to_string(size.maxCoeff()) +
                             " m across; a payload part is at most 10 m (units or scale?)");
  for (auto& v : mesh.vertices) v -= centre;
  m.shape = std::make_shared<const MeshSignedDistance>(std::move(mesh));
  return m;
}

}  // namespace

std::shared_ptr<const SceneElementConfig> ReadPayloadSection(const YAML::Node& n, const std::string& path,
                                                             const SceneLoadOptions& load) {
  using namespace scene_yaml;
  auto c = std::make_shared<PayloadConfig>();
  YAML::Node pmt_model, a_model;
  Section section(n, path, "payload");
  section.Field("first_id", &c->first_id)
      .Vec("pmt_centre", &c->pmt_centre)
      .Vec("pmt_half", &c->pmt_half)
      .Field("pmt_model", &pmt_model)
      .Field("axis", &c->axis)
      .Field("direction", &c->direction)
      .Field("spacing", &c->spacing)
      .Vec("a_half", &c->a_half)
      .Field("shaft_radius", &c->shaft_radius)
      .Field("shaft_length", &c->shaft_length)
      .Field("a_model", &a_model)
      .Field("max_clearance", &c->max_clearance)
      .Field("max_pixel_size", &c->collision.max_pixel_size)
      .Read();
  // A model stands for its box: the box's keys beside it would be unused.
  for (const auto& [model, unused] : {std::pair<const char*, std::vector<const char*>>{"pmt_model", {"pmt_half"}},
                                      {"a_model", {"a_half", "shaft_radius", "shaft_length"}}})
    for (const char* key : unused)
      if (section.Has(model) && section.Has(key))
        throw std::runtime_error(path + ": 'payload." + key + "' with 'payload." + model + "': the model's box is " +
                                 "used (give one or the other)");
  if (section.Has("pmt_model")) c->pmt_model = ReadPayloadModel(pmt_model, path, "payload.pmt_model", load);
  if (section.Has("a_model")) c->a_model = ReadPayloadModel(a_model, path, "payload.a_model", load);
  return c;
}

}  // namespace hullpipe
