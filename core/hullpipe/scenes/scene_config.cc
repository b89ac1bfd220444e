#include "hullpipe/scenes/scene_config.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "hullpipe/reconstruction/exact_hull.h"
#include "hullpipe/scenes/limits.h"
#include "hullpipe/scenes/scene_yaml.h"
#include "hullpipe/util/yaml_keys.h"

namespace hullpipe {

void SceneConfig::PlaceInWorld(const RigWorld& world, const Aabb& workspace) {
  if (frame != Frame::kStage) return;
  const Eigen::Matrix3d r = StageAxes(world.up);
  const Rigid3d world_from_stage = StageFrame(world, workspace);
  for (auto& e : elements) {
    auto placed = e->PlaceOnStage(world_from_stage);
    if (!placed) throw std::invalid_argument("scene: frame stage: " + e->Key() + " cannot be placed on the stage");
    e = std::move(placed);
  }
  gravity = r * gravity;
  for (auto& b : balls) {
    b.start = r * b.start;
    b.target = r * b.target;
    b.relative_to_hull = true;
  }
  const Eigen::Vector3d up = world.up.normalized();
  // Floor along g_hat = -up: g_hat . x = floor.
  has_floor = world.floor == RigWorld::Floor::kPlane;  // under the hull: once a hull is seen
  floor = world.floor == RigWorld::Floor::kPlane ? -world.floor_height : 0.0;
  floor_under_hull = world.floor == RigWorld::Floor::kUnderHull;
  if (gravity.norm() > 0 && std::abs(gravity.normalized().dot(up) + 1) > 1e-9)
    throw std::invalid_argument("scene: frame stage: gravity must point down the stage's z axis");
  frame = Frame::kWorld;
}

void SceneConfig::TakeFloorUnderHull(const VolumeQuery* hull) {
  if (!floor_under_hull || !hull || hull->hull_box().empty()) return;
  const double g = gravity.norm();
  const Eigen::Vector3d g_hat = g > 0 ? Eigen::Vector3d(gravity / g) : Eigen::Vector3d::UnitZ();
  // Its lowest point along -gravity (not the hull box's corner, which lies
  // below the hull where up is not an axis).
  if (const auto lowest = HullExtentAlong(*hull, g_hat)) {
    floor = *lowest;
    has_floor = true;
    floor_under_hull = false;
  }
}

void SceneConfig::Check() const {
  if (frame == Frame::kStage) {
    std::string which;
    for (const auto& e : elements)
      if (!e->CanBeOnStage()) which += (which.empty() ? "" : ", ") + e->Key();
    if (light) which += (which.empty() ? "" : ", ") + std::string("light");
    if (!which.empty())
      throw std::invalid_argument("scene: frame stage places balls and models only: " + which +
                                  " are in world coordinates (use frame: world)");
  }
  if (!gravity.allFinite()) throw std::invalid_argument("scene: gravity must be finite");
  if (!(max_substep >= kMinSubstepS && max_substep <= kMaxSubstepS))
    throw std::invalid_argument("scene: max_substep must be in [1e-4, 0.1] s");
  collision.Check();
  try {
    hull_velocity.Check();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("scene: ") + e.what());
  }
  for (const auto& e : elements) e->CheckIn(*this);
  if (light) light->Check();
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
  // One object id, one thing drawn: render_node keys states and meshes by id.
  std::vector<ObjectIdRange> ids;
  for (const auto& b : balls) ids.push_back({b.id, b.id, "ball " + std::to_string(b.id)});
  for (const auto& e : elements)
    for (ObjectIdRange& r : e->ObjectIds()) ids.push_back(std::move(r));
  std::sort(ids.begin(), ids.end(), [](const ObjectIdRange& a, const ObjectIdRange& b) { return a.first < b.first; });
  auto text = [](const ObjectIdRange& r) {
    return r.what + " (" + std::to_string(r.first) + (r.last > r.first ? ".." + std::to_string(r.last) : "") + ")";
  };
  for (const ObjectIdRange& r : ids)
    if (r.first < 0 || r.last > int64_t(UINT32_MAX))
      throw std::invalid_argument("scene: object id of " + text(r) + " must be in [0, 4294967295]");
  for (size_t k = 1, widest = 0; k < ids.size(); ++k) {  // widest: the range reaching furthest so far
    if (ids[k].first <= ids[widest].last)
      throw std::invalid_argument("scene: object ids overlap: " + text(ids[widest]) + " and " + text(ids[k]) +
                                  " (set id or first_id apart)");
    widest = ids[k].last > ids[widest].last ? k : widest;
  }
}

namespace {

using scene_yaml::Keys;
using scene_yaml::Need;
using scene_yaml::Section;
using scene_yaml::Vec3;

LightConfig ParseLight(const YAML::Node& n, const std::string& path) {
  LightConfig c;
  Section(n, path, "light")
      .Vec("position", &c.position, Need::kRequired)
      .Vec("target", &c.target, Need::kRequired)
      .Field("fov_deg", &c.fov_deg)
      .Field("map_size", &c.map_size)
      .Field("planes", &c.planes)
      .Field("refine", &c.refine)
      .Field("bias", &c.bias)
      .Field("ambient", &c.ambient)
      .Field("hull_diffuse", &c.hull_diffuse)
      .Read();
  return c;
}

}  // namespace

SceneConfig LoadSceneConfig(const std::string& path, const SceneLoadOptions& load) {
  SceneConfig cfg;
  {
    // Bounded before it is parsed; a FIFO or a directory is not opened.
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
      throw std::runtime_error(path + ": not a regular file (a scene file is YAML text)");
    const auto bytes = std::filesystem::file_size(path, ec);
    if (ec) throw std::runtime_error(path + ": cannot read the scene file");
    if (bytes > uintmax_t(kMaxSceneFileBytes))
      throw std::runtime_error(path + ": " + std::to_string(bytes >> 20) +
                               " MiB; a scene file is at most 1 MiB (models go in their own files)");
  }
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (!root.IsMap() || root.size() == 0)
      throw std::runtime_error(path + ": not a scene (empty, or not a YAML map of keys)");
    // 'balls' is required (balls: [] for none): a file without it would get the
    // default ball unasked.
    std::vector<std::string> known = {"gravity", "floor", "collision", "response", "hull_velocity",
                                      "max_substep", "balls", "light", "frame"};
    for (const auto& kind : SceneElementKinds()) known.push_back(kind.key);
    Keys(root, path, "", known, {"balls"});
    if (const YAML::Node f = root["frame"]) {
      const std::string frame = f.as<std::string>("?");
      if (frame != "world" && frame != "stage")
        throw std::runtime_error(path + ": 'frame' must be world or stage, not " + frame);
      cfg.frame = frame == "stage" ? SceneConfig::Frame::kStage : SceneConfig::Frame::kWorld;
      if (cfg.frame == SceneConfig::Frame::kStage) {
        cfg.gravity = Eigen::Vector3d(0, 0, -9.81);
        if (root["floor"])
          throw std::runtime_error(path + ": 'floor' with frame stage: the stage's floor is the rig's (rig file "
                                          "world: floor)");
      }
    }
    cfg.gravity = Vec3(root, path, "gravity", cfg.gravity);
    if (root["floor"]) {
      if (root["floor"].IsNull()) {
        cfg.has_floor = false;
      } else {
        cfg.floor = root["floor"].as<double>();
      }
    }
    if (const YAML::Node c = root["collision"]) {
      Section(c, path, "collision")
          .Field("max_pixel_size", &cfg.collision.max_pixel_size)
          .Field("fixed_viewport", &cfg.collision.fixed_viewport)
          .Field("max_viewport", &cfg.collision.max_viewport)
          .Read();
    }
    if (root["response"]) {
      const std::string r = root["response"].as<std::string>();
      if (r != "exact" && r != "paper") throw std::runtime_error(path + ": 'response' must be exact or paper, not " + r);
      cfg.response = r == "exact" ? SceneConfig::Response::kExact : SceneConfig::Response::kPaper;
    }
    if (const YAML::Node v = root["hull_velocity"]) {
      Section(v, path, "hull_velocity")
          .Field("enabled", &cfg.hull_velocity.enabled)
          .Field("max_speed", &cfg.hull_velocity.max_speed)
          .Field("max_interval", &cfg.hull_velocity.max_interval)
          .Read();
    }
    if (root["max_substep"]) cfg.max_substep = root["max_substep"].as<double>();
    if (const YAML::Node balls = root["balls"]) {
      if (!balls.IsSequence()) throw std::runtime_error(path + ": 'balls' must be a list ([] for none)");
      cfg.balls.clear();
      int index = 0;
      for (const auto& b : balls) {
        BallConfig bc;
        bc.id = index + 1;
        Section(b, path, "balls[" + std::to_string(index) + "]")
            .Field("id", &bc.id)
            .Field("radius", &bc.radius, Need::kRequired)
            .Vec("start", &bc.start, Need::kRequired)
            .Vec("target", &bc.target, Need::kRequired)
            .Field("flight_time", &bc.flight_time)
            .Field("restitution", &bc.restitution)
            .Field("rethrow_period", &bc.rethrow_period)
            .Field("subdivisions", &bc.subdivisions)
            .Read();
        cfg.balls.push_back(bc);
        ++index;
      }
    }
    for (const auto& kind : SceneElementKinds())
      if (const YAML::Node section = root[kind.key]) cfg.elements.push_back(kind.read(section, path, load));
    if (root["light"]) cfg.light = ParseLight(root["light"], path);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  try {
    cfg.Check();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  return cfg;
}

}  // namespace hullpipe
