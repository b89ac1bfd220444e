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
  const Eigen::Vector3d up = world.up.normalized();
  // Floor along g_hat = -up: g_hat . x = floor.
  has_floor = world.floor == RigWorld::Floor::kPlane;  // under the hull: once a hull is seen
  floor = world.floor == RigWorld::Floor::kPlane ? -world.floor_height : 0.0;
  floor_under_hull = world.floor == RigWorld::Floor::kUnderHull;
  if (gravity.norm() > 0 && std::abs(gravity.normalized().dot(up) + 1) > 1e-9)
    throw std::invalid_argument("scene: frame stage: gravity must point down the stage's z axis");
  frame = Frame::kWorld;
}

void SceneConfig::Put(std::shared_ptr<const SceneElementConfig> config) {
  for (auto& e : elements)
    if (e->Key() == config->Key()) {
      e = std::move(config);
      return;
    }
  // Where the registry orders it (the order elements step and publish in).
  auto rank = [](const std::string& key) {
    const auto& kinds = SceneElementKinds();
    size_t i = 0;
    while (i < kinds.size() && kinds[i].key != key) ++i;
    return i;
  };
  const size_t r = rank(config->Key());
  auto at = elements.begin();
  while (at != elements.end() && rank((*at)->Key()) <= r) ++at;
  elements.insert(at, std::move(config));
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
  for (size_t i = 0; i < elements.size(); ++i) {
    elements[i]->CheckIn(*this);
    for (size_t j = 0; j < i; ++j)
      if (elements[j]->Key() == elements[i]->Key())
        throw std::invalid_argument("scene: two '" + elements[i]->Key() + "' elements; at most one of each kind");
  }
  if (light) light->Check();
  // One object id, one thing drawn: render_node keys states and meshes by id.
  std::vector<ObjectIdRange> ids;
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
    std::vector<std::string> known = {"gravity", "floor", "collision", "response", "hull_velocity",
                                      "max_substep", "light", "frame"};
    std::vector<const char*> required;
    for (const auto& kind : SceneElementKinds()) {
      known.push_back(kind.key);
      if (kind.required) required.push_back(kind.key.c_str());
    }
    Keys(root, path, "", known, required);
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
      if (r != "exact" && r != "paper")
        throw std::runtime_error(path + ": 'response' must be exact or paper, not " + r);
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
