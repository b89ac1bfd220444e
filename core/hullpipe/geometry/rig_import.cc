#include "hullpipe/geometry/rig_import.h"

#include <Eigen/QR>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/image_file.h"

namespace fs = std::filesystem;

namespace hullpipe {
namespace {

// Calibration files are text of a few KB (a COLMAP images.txt with its 2-D
// points may be tens of MB): anything past this is refused, not read.
constexpr std::uintmax_t kMaxFileBytes = 256ull << 20;

// A line of a COLMAP text file that holds no data: blank or a # comment.
bool IsCommentOrBlank(const std::string& line) {
  return line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos;
}

std::string ReadText(const fs::path& p) {
  std::error_code ec;
  const auto size = fs::file_size(p, ec);
  if (ec) throw CalibrationError(p.string() + ": cannot open");
  if (size > kMaxFileBytes) throw CalibrationError(p.string() + ": larger than 256 MiB, not a calibration file");
  std::ifstream in(p, std::ios::binary);
  if (!in) throw CalibrationError(p.string() + ": cannot open");
  std::string text(size_t(size), '\0');
  in.read(text.data(), std::streamsize(size));
  return text;
}

std::string FormatNumber(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6g", v);
  return b;
}

cv::Size ProbeImage(const fs::path& p) {
  // The header only: an image is never decoded just for its size.
  const std::optional<ImageHeader> h = p.empty() ? std::nullopt : ProbeImageFile(p.string());
  return h ? cv::Size(h->width, h->height) : cv::Size(0, 0);
}

// The image size: the file's, else --width/--height, else the image's.
void SetSize(Camera* c, int file_w, int file_h, const ImportOptions& o, const fs::path& image,
             const std::string& where) {
  c->width = file_w > 0 ? file_w : o.width;
  c->height = file_h > 0 ? file_h : o.height;
  if (c->width <= 0 || c->height <= 0) {
    const cv::Size s = ProbeImage(image);
    c->width = s.width;
    c->height = s.height;
  }
  if (c->width <= 0 || c->height <= 0)
    throw CalibrationError(where + ": camera " + std::to_string(c->id) + ": the file has no image size and " +
                           (image.empty() ? std::string("names no image")
                                          : "the image " + image.string() + " cannot be read") +
                           ": give --width and --height");
  if (c->width > Camera::kMaxSide || c->height > Camera::kMaxSide)
    throw CalibrationError(where + ": camera " + std::to_string(c->id) + ": image size " + std::to_string(c->width) +
                           "x" + std::to_string(c->height) + " beyond " + std::to_string(Camera::kMaxSide) + " px");
}

// Sets extrinsics from a rotation that should be one (repaired within the
// tolerance, counted) and a translation in file units.
void SetPose(Camera* c, const Eigen::Matrix3d& r, const Eigen::Vector3d& t, const ImportOptions& o,
             const std::string& where, std::vector<std::pair<int, double>>* repaired) {
  double e = 0;
  c->cam_from_world.rotation = NearestRotation(r, where + ": camera " + std::to_string(c->id), &e);
  if (e > kRotationNoteAbove) repaired->push_back({c->id, e});
  if (!t.allFinite()) throw CalibrationError(where + ": camera " + std::to_string(c->id) + ": translation not finite");
  c->cam_from_world.translation = t * o.scale;
}

Rig Finish(Rig rig, const std::vector<std::pair<int, double>>& repaired) {
  if (rig.cameras.empty()) throw CalibrationError(rig.source + ": no cameras");
  if (rig.cameras.size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(rig.source + ": " + std::to_string(rig.cameras.size()) + " cameras; a rig has at most " +
                           std::to_string(Rig::kMaxCameras));
  CheckCameraIds(rig, rig.source);
  for (auto& rc : rig.cameras) {
    try {
      rc.camera.Check();
    } catch (const std::invalid_argument& e) {
      throw CalibrationError(rig.source + ": " + e.what());
    }
  }
  if (!repaired.empty()) rig.notes.push_back(RepairedRotationsNote(rig.source, repaired));
  try {
    CompleteRig(&rig);
  } catch (const std::invalid_argument& e) {
    throw CalibrationError(rig.source + ": " + e.what());
  }
  for (const auto& n : rig.notes) spdlog::warn("{}", n);
  return rig;
}

// ---- COLMAP ---------------------------------------------------------------

struct ColmapCamera {
  int model = -1;
  std::string model_name;
  uint64_t width = 0, height = 0;
  std::vector<double> params;
};

// Model names and parameter counts (COLMAP's src/colmap/sensor/models.h order).
struct ColmapModel {
  int id;
  const char* name;
  int params;
};
constexpr ColmapModel kColmapModels[] = {
    {0, "SIMPLE_PINHOLE", 3}, {1, "PINHOLE", 4},      {2, "SIMPLE_RADIAL", 4},        {3, "RADIAL", 5},
    {4, "OPENCV", 8},         {5, "OPENCV_FISHEYE", 8}, {6, "FULL_OPENCV", 12},        {7, "FOV", 5},
    {8, "SIMPLE_RADIAL_FISHEYE", 4}, {9, "RADIAL_FISHEYE", 5}, {10, "THIN_PRISM_FISHEYE", 12},
    {11, "RAD_TAN_THIN_PRISM_FISHEYE", 16}};

const ColmapModel* FindModel(int id, const std::string& name) {
  for (const auto& m : kColmapModels)
    if (m.id == id || (!name.empty() && name == m.name)) return &m;
  return nullptr;
}

// K and distortion of a COLMAP camera; refuses models hullpipe cannot represent.
void ColmapIntrinsics(const ColmapCamera& cc, const std::string& where, Camera* c) {
  const auto& p = cc.params;
  double fx, fy, cx, cy;
  Distortion d{};
  switch (cc.model) {
    case 0: fx = fy = p[0], cx = p[1], cy = p[2]; break;
    case 1: fx = p[0], fy = p[1], cx = p[2], cy = p[3]; break;
    case 2: fx = fy = p[0], cx = p[1], cy = p[2], d[0] = p[3]; break;
    case 3: fx = fy = p[0], cx = p[1], cy = p[2], d[0] = p[3], d[1] = p[4]; break;
    case 4:
    case 6:
      fx = p[0], fy = p[1], cx = p[2], cy = p[3];
      d = {p[4], p[5], p[6], p[7], cc.model == 6 ? p[8] : 0.0};
      if (cc.model == 6 && (p[9] != 0 || p[10] != 0 || p[11] != 0))
        throw CalibrationError(where + ": camera " + std::to_string(c->id) +
                               ": FULL_OPENCV with k4..k6 (the rational model) is not hullpipe's 5-parameter model; "
                               "recalibrate with OPENCV or undistort the images (colmap image_undistorter)");
      break;
    default:
      throw CalibrationError(where + ": camera " + std::to_string(c->id) + ": COLMAP camera model " + cc.model_name +
                             " is not supported (hullpipe's camera is a pinhole with OpenCV's k1 k2 p1 p2 k3): "
                             "undistort the images with colmap image_undistorter and import that model");
  }
  // COLMAP puts pixel centres at +0.5, as hullpipe does: no offset.
  SetCameraIntrinsics({fx, 0, cx, 0, fy, cy, 0, 0, 1}, 0.0, where, "params", c);
  c->distortion = d;
}

fs::path ColmapImagePath(const fs::path& dir, const std::string& name) {
  for (const fs::path& base : {dir.parent_path().parent_path() / "images", dir.parent_path() / "images", dir}) {
    std::error_code ec;
    if (fs::exists(base / name, ec)) return base / name;
  }
  return dir / name;
}

struct ColmapImage {
  uint32_t id = 0, camera = 0;
  Eigen::Vector4d q;  // w x y z
  Eigen::Vector3d t;
  std::string name;
};

void ReadColmapText(const fs::path& dir, std::map<uint32_t, ColmapCamera>* cams, std::vector<ColmapImage>* images) {
  {
    const std::string where = (dir / "cameras.txt").string();
    std::istringstream in(ReadText(dir / "cameras.txt"));
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
      ++n;
      if (IsCommentOrBlank(line)) continue;
      std::istringstream ls(line);
      uint32_t id;
      ColmapCamera c;
      if (!(ls >> id >> c.model_name >> c.width >> c.height))
        throw CalibrationError(where + ": line " + std::to_string(n) + ": not CAMERA_ID MODEL WIDTH HEIGHT PARAMS");
      const ColmapModel* m = FindModel(-1, c.model_name);
      if (!m) throw CalibrationError(where + ": line " + std::to_string(n) + ": unknown camera model " + c.model_name);
      c.model = m->id;
      double v;
      while (ls >> v) c.params.push_back(v);
      if (int(c.params.size()) != m->params)
        throw CalibrationError(where + ": line " + std::to_string(n) + ": " + c.model_name + " has " +
                               std::to_string(m->params) + " parameters, the line has " +
                               std::to_string(c.params.size()));
      (*cams)[id] = c;
    }
  }
  const std::string where = (dir / "images.txt").string();
  std::istringstream in(ReadText(dir / "images.txt"));
  std::string line, points;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (IsCommentOrBlank(line)) continue;
    std::istringstream ls(line);
    ColmapImage im;
    if (!(ls >> im.id >> im.q[0] >> im.q[1] >> im.q[2] >> im.q[3] >> im.t[0] >> im.t[1] >> im.t[2] >> im.camera >>
          im.name))
      throw CalibrationError(where + ": line " + std::to_string(n) +
                             ": not IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    images->push_back(im);
    std::getline(in, points);  // its 2-D points: one line, possibly empty
    ++n;
  }
}

template <typename T>
T ReadBinary(std::istream& in, const std::string& where) {
  T v;
  if (!in.read(reinterpret_cast<char*>(&v), sizeof v)) throw CalibrationError(where + ": truncated");
  return v;
}

void ReadColmapBinary(const fs::path& dir, std::map<uint32_t, ColmapCamera>* cams, std::vector<ColmapImage>* images) {
  {
    const std::string where = (dir / "cameras.bin").string();
    std::istringstream in(ReadText(dir / "cameras.bin"));
    const uint64_t n = ReadBinary<uint64_t>(in, where);
    if (n > 100000) throw CalibrationError(where + ": " + std::to_string(n) + " cameras: not a COLMAP model");
    for (uint64_t i = 0; i < n; ++i) {
      const uint32_t id = ReadBinary<uint32_t>(in, where);
      ColmapCamera c;
      c.model = ReadBinary<int32_t>(in, where);
      const ColmapModel* m = FindModel(c.model, "");
      if (!m) throw CalibrationError(where + ": camera " + std::to_string(id) + ": unknown model id " +
                                     std::to_string(c.model));
      c.model_name = m->name;
      c.width = ReadBinary<uint64_t>(in, where);
      c.height = ReadBinary<uint64_t>(in, where);
      for (int k = 0; k < m->params; ++k) c.params.push_back(ReadBinary<double>(in, where));
      (*cams)[id] = c;
    }
  }
  const std::string where = (dir / "images.bin").string();
  std::istringstream in(ReadText(dir / "images.bin"));
  const uint64_t n = ReadBinary<uint64_t>(in, where);
  if (n > 1000000) throw CalibrationError(where + ": " + std::to_string(n) + " images: not a COLMAP model");
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage im;
    im.id = ReadBinary<uint32_t>(in, where);
    for (int k = 0; k < 4; ++k) im.q[k] = ReadBinary<double>(in, where);
    for (int k = 0; k < 3; ++k) im.t[k] = ReadBinary<double>(in, where);
    im.camera = ReadBinary<uint32_t>(in, where);
    char ch;
    while ((ch = ReadBinary<char>(in, where)) != '\0') {
      im.name += ch;
      if (im.name.size() > 4096) throw CalibrationError(where + ": image name longer than 4096 bytes");
    }
    const uint64_t points = ReadBinary<uint64_t>(in, where);
    // x, y (double) and a point3D id (uint64) per 2-D point: skipped.
    if (points > uint64_t(kMaxFileBytes) / 24) throw CalibrationError(where + ": truncated");
    in.seekg(std::streamoff(points * 24), std::ios::cur);
    if (!in) throw CalibrationError(where + ": truncated");
    images->push_back(im);
  }
}

}  // namespace

void ImportOptions::Check() const {
  if (!(std::isfinite(scale) && scale > 0 && scale <= 1e6)) throw std::invalid_argument("--scale must be in (0, 1e6]");
  if (width < 0 || height < 0 || width > Camera::kMaxSide || height > Camera::kMaxSide)
    throw std::invalid_argument("--width/--height must be in [0, " + std::to_string(Camera::kMaxSide) + "]");
}

Rig ImportColmap(const std::string& path, const ImportOptions& o) {
  o.Check();
  fs::path dir = path;
  std::error_code ec;
  for (const fs::path& sub : {fs::path("sparse/0"), fs::path("sparse"), fs::path("0")})
    if (!fs::exists(dir / "cameras.txt", ec) && !fs::exists(dir / "cameras.bin", ec) &&
        (fs::exists(dir / sub / "cameras.txt", ec) || fs::exists(dir / sub / "cameras.bin", ec)))
      dir /= sub;
  std::map<uint32_t, ColmapCamera> cams;
  std::vector<ColmapImage> images;
  if (fs::exists(dir / "cameras.txt", ec) && fs::exists(dir / "images.txt", ec))
    ReadColmapText(dir, &cams, &images);
  else if (fs::exists(dir / "cameras.bin", ec) && fs::exists(dir / "images.bin", ec))
    ReadColmapBinary(dir, &cams, &images);
  else
    throw CalibrationError(path + ": not a COLMAP model (no cameras.txt + images.txt or cameras.bin + images.bin)");
  if (images.size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(path + ": " + std::to_string(images.size()) +
                           " registered images; a rig is at most " + std::to_string(Rig::kMaxCameras) +
                           " fixed cameras, one image each (a model of a moving camera is not a rig)");
  std::sort(images.begin(), images.end(), [](const auto& a, const auto& b) { return a.id < b.id; });
  Rig rig;
  rig.source = dir.string();
  std::vector<std::pair<int, double>> repaired;
  const std::string where = dir.string();
  for (const auto& im : images) {
    RigCamera rc;
    Camera& c = rc.camera;
    if (im.id > uint32_t(INT32_MAX))
      throw CalibrationError(where + ": IMAGE_ID " + std::to_string(im.id) + " is beyond 2147483647 (a camera id)");
    c.id = int(im.id);
    const auto it = cams.find(im.camera);
    if (it == cams.end())
      throw CalibrationError(where + ": image " + std::to_string(im.id) + " names camera " + std::to_string(im.camera) +
                             ", which the model does not have");
    if (it->second.width > uint64_t(Camera::kMaxSide) || it->second.height > uint64_t(Camera::kMaxSide))
      throw CalibrationError(where + ": camera " + std::to_string(im.camera) + ": image size beyond " +
                             std::to_string(Camera::kMaxSide) + " px");
    SetSize(&c, int(it->second.width), int(it->second.height), o, {}, where);
    ColmapIntrinsics(it->second, where, &c);
    const double qn = im.q.norm();
    if (!(std::abs(qn - 1) <= kRotationRepairTolerance))
      throw CalibrationError(where + ": image " + std::to_string(im.id) + ": quaternion of length " +
                             std::to_string(qn) + " is not a rotation");
    const Eigen::Quaterniond q(im.q[0] / qn, im.q[1] / qn, im.q[2] / qn, im.q[3] / qn);
    SetPose(&c, q.toRotationMatrix(), im.t, o, where, &repaired);
    rc.frames = ColmapImagePath(dir, im.name).string();
    rig.cameras.push_back(std::move(rc));
  }
  return Finish(std::move(rig), repaired);
}

namespace {
Rig ImportNerfChecked(const std::string& path, const ImportOptions& o);
}  // namespace

Rig ImportNerf(const std::string& path, const ImportOptions& o) {
  // Any JSON type surprise left unchecked below still names the file.
  try {
    return ImportNerfChecked(path, o);
  } catch (const nlohmann::json::exception& e) {
    throw CalibrationError(path + ": " + e.what());
  }
}

namespace {

Rig ImportNerfChecked(const std::string& path, const ImportOptions& o) {
  o.Check();
  nlohmann::json parsed;
  try {
    parsed = nlohmann::json::parse(ReadText(path));
  } catch (const nlohmann::json::exception& e) {
    throw CalibrationError(path + ": not JSON: " + e.what());
  }
  const nlohmann::json& j = parsed;
  if (!j.is_object() || !j.contains("frames") || !j["frames"].is_array())
    throw CalibrationError(path + ": not a NeRF transforms.json (no 'frames' list)");
  if (j["frames"].size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(path + ": " + std::to_string(j["frames"].size()) + " frames; a rig has at most " +
                           std::to_string(Rig::kMaxCameras) + " cameras");
  const fs::path base = fs::path(path).parent_path();
  Rig rig;
  rig.source = path;
  std::vector<std::pair<int, double>> repaired;
  int index = 0;
  for (const auto& fr : j["frames"]) {
    ++index;
    const std::string where = path + ": frame " + std::to_string(index);
    if (!fr.is_object()) throw CalibrationError(where + " is not an object");
    // A key of the frame, else of the file; NaN where neither has it.
    auto num = [&](const char* key) {
      for (const nlohmann::json* src : {&fr, static_cast<const nlohmann::json*>(&j)})
        if (src->contains(key)) {
          if (!(*src)[key].is_number()) throw CalibrationError(where + ": key '" + key + "' must be a number");
          return (*src)[key].get<double>();
        }
      return std::nan("");
    };
    RigCamera rc;
    Camera& c = rc.camera;
    c.id = index;
    if (fr.contains("file_path") && !fr["file_path"].is_string())
      throw CalibrationError(where + ": key 'file_path' must be text");
    std::string file = fr.value("file_path", std::string());
    fs::path image = file.empty() ? fs::path() : base / file;
    std::error_code ec;
    if (!image.empty() && !image.has_extension() && fs::exists(image.string() + ".png", ec)) image += ".png";
    const double w = num("w"), h = num("h");
    // Checked as numbers before they become ints ("2147483647x120" from 1e300).
    for (const auto& [key, v] : {std::pair<const char*, double>{"w", w}, {"h", h}})
      if (std::isfinite(v) && !(v >= 1 && v <= Camera::kMaxSide && v == std::floor(v)))
        throw CalibrationError(where + ": key '" + key + "' must be whole pixels in [1, " +
                               std::to_string(Camera::kMaxSide) + "], not " + FormatNumber(v));
    SetSize(&c, std::isfinite(w) ? int(w) : 0, std::isfinite(h) ? int(h) : 0, o, image, path);
    double fx = num("fl_x"), fy = num("fl_y");
    const double angle_x = num("camera_angle_x"), angle_y = num("camera_angle_y");
    if (!std::isfinite(fx) && std::isfinite(angle_x)) fx = 0.5 * c.width / std::tan(0.5 * angle_x);
    if (!std::isfinite(fy) && std::isfinite(angle_y)) fy = 0.5 * c.height / std::tan(0.5 * angle_y);
    if (!std::isfinite(fx) && std::isfinite(fy)) fx = fy;
    if (!std::isfinite(fy)) fy = fx;
    if (!std::isfinite(fx)) throw CalibrationError(where + ": no focal length (fl_x, fl_y or camera_angle_x)");
    double cx = num("cx"), cy = num("cy");
    if (!std::isfinite(cx)) cx = 0.5 * c.width;
    if (!std::isfinite(cy)) cy = 0.5 * c.height;
    // cx, cy as instant-ngp and nerfstudio use them: continuous coordinates with
    // pixel centres at +0.5, hullpipe's own (no offset).
    SetCameraIntrinsics({fx, 0, cx, 0, fy, cy, 0, 0, 1}, 0.0, where, "fl_x/fl_y/cx/cy", &c);
    for (int k = 0; k < 5; ++k) {
      const double v = num(std::array<const char*, 5>{"k1", "k2", "p1", "p2", "k3"}[size_t(k)]);
      c.distortion[size_t(k)] = std::isfinite(v) ? v : 0.0;
    }
    // Models other than hullpipe's: a fisheye's k4, or a camera_model that says so.
    const double k4 = num("k4");
    const nlohmann::json model =
        fr.contains("camera_model") ? fr["camera_model"] : j.value("camera_model", nlohmann::json());
    const bool other_model =
        model.is_string() && model.get<std::string>() != "OPENCV" && model.get<std::string>() != "PINHOLE";
    if (other_model || (std::isfinite(k4) && k4 != 0))
      throw CalibrationError(where + ": camera model " + (other_model ? model.dump() : "with k4 (a fisheye)") +
                             " is not hullpipe's (a pinhole with OpenCV's k1 k2 p1 p2 k3)");
    const nlohmann::json m = fr.value("transform_matrix", nlohmann::json());
    if (!m.is_array() || m.size() < 3)
      throw CalibrationError(where + ": key 'transform_matrix' must be a 4x4 (or 3x4) list of rows");
    Eigen::Matrix3d r_wc_gl;
    Eigen::Vector3d centre;
    for (int row = 0; row < 3; ++row) {
      if (!m[size_t(row)].is_array() || m[size_t(row)].size() != 4)
        throw CalibrationError(where + ": key 'transform_matrix' row " + std::to_string(row) + " must have 4 numbers");
      for (int col = 0; col < 4; ++col) {
        const auto& v = m[size_t(row)][size_t(col)];
        if (!v.is_number()) throw CalibrationError(where + ": key 'transform_matrix' must hold numbers");
        (col < 3 ? r_wc_gl(row, col) : centre(row)) = v.get<double>();
      }
    }
    // OpenGL camera axes (x right, y up, z backwards) to OpenCV's (y down, z forward).
    const Eigen::Matrix3d r_wc = r_wc_gl * Eigen::Vector3d(1, -1, -1).asDiagonal();
    double e = 0;
    const Eigen::Matrix3d r_cw = NearestRotation(r_wc, where + ": key 'transform_matrix'", &e).transpose();
    if (e > kRotationNoteAbove) repaired.push_back({c.id, e});
    c.cam_from_world.rotation = r_cw;
    c.cam_from_world.translation = -(r_cw * centre) * o.scale;
    rc.frames = image.string();
    rig.cameras.push_back(std::move(rc));
  }
  return Finish(std::move(rig), repaired);
}

}  // namespace

Rig ImportMiddlebury(const std::string& path, const ImportOptions& o) {
  o.Check();
  std::istringstream in(ReadText(path));
  const fs::path base = fs::path(path).parent_path();
  long count = -1;
  if (!(in >> count) || count < 1 || count > 100000)
    throw CalibrationError(path + ": line 1 must be the number of images");
  if (count > Rig::kMaxCameras)
    throw CalibrationError(path + ": " + std::to_string(count) + " images; a rig has at most " +
                           std::to_string(Rig::kMaxCameras) + " cameras");
  Rig rig;
  rig.source = path;
  std::vector<std::pair<int, double>> repaired;
  for (long i = 0; i < count; ++i) {
    const std::string where = path + ": image " + std::to_string(i + 1);
    std::string name;
    std::vector<double> v(21);
    if (!(in >> name)) throw CalibrationError(where + ": missing (the file says " + std::to_string(count) + ")");
    for (double& x : v)
      if (!(in >> x)) throw CalibrationError(where + ": needs name and 21 numbers (K, R, t)");
    RigCamera rc;
    Camera& c = rc.camera;
    c.id = int(i + 1);
    const fs::path image = base / name;
    SetSize(&c, 0, 0, o, image, path);
    // Middlebury's K puts pixel centres at integers (as OpenCV).
    SetCameraIntrinsics(std::vector<double>(v.begin(), v.begin() + 9), kOpenCvToHullpipePixelOffset, where, "K", &c);
    Eigen::Matrix3d r;
    for (int k = 0; k < 9; ++k) r(k / 3, k % 3) = v[size_t(9 + k)];
    SetPose(&c, r, Eigen::Vector3d(v[18], v[19], v[20]), o, where, &repaired);
    rc.frames = image.string();
    rig.cameras.push_back(std::move(rc));
  }
  return Finish(std::move(rig), repaired);
}

namespace {

cv::Mat Matrix(const cv::FileStorage& f, const std::string& key, const std::string& where, bool required = true) {
  const cv::FileNode n = f[key];
  if (n.empty()) {
    if (required) throw CalibrationError(where + ": missing key '" + key + "'");
    return {};
  }
  if (n.isMap()) {
    const cv::FileNode rows = n["rows"], cols = n["cols"];
    if (!rows.isInt() || !cols.isInt() || int(rows) < 1 || int(cols) < 1 || int(rows) > 16 || int(cols) > 16)
      throw CalibrationError(where + ": key '" + key + "' must be a small matrix");
  }
  cv::Mat m;
  try {
    n >> m;
  } catch (const std::exception&) {
    throw CalibrationError(where + ": key '" + key + "' is not a matrix");
  }
  if (m.empty()) throw CalibrationError(where + ": key '" + key + "' is not a matrix");
  m.convertTo(m, CV_64F);
  return m;
}

void SetDistortion(const cv::Mat& d, const std::string& where, const std::string& key, Camera* c) {
  if (d.empty()) return;
  const cv::Mat flat = d.reshape(1, 1);
  const int n = flat.cols;
  if (n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
    throw CalibrationError(where + ": key '" + key + "' must have 4, 5, 8, 12 or 14 coefficients");
  for (int k = 5; k < n; ++k)
    if (flat.at<double>(k) != 0)
      throw CalibrationError(where + ": key '" + key +
                             "': coefficients past k3 (rational, thin prism, tilt) are not hullpipe's 5-parameter "
                             "model; calibrate without CALIB_RATIONAL_MODEL etc.");
  for (int k = 0; k < std::min(n, 5); ++k) c->distortion[size_t(k)] = flat.at<double>(k);
}

}  // namespace

namespace {
Rig ImportOpenCvYamlChecked(const std::string& path, const ImportOptions& o);
}  // namespace

Rig ImportOpenCvYaml(const std::string& path, const ImportOptions& o) {
  // OpenCV's FileStorage throws cv::Exception and, from its YAML parser,
  // std::length_error (fuzz_rig_files found it): every one names the file.
  try {
    return ImportOpenCvYamlChecked(path, o);
  } catch (const CalibrationError&) {
    throw;
  } catch (const std::invalid_argument&) {
    throw;
  } catch (const std::exception& e) {
    throw CalibrationError(path + ": not a readable OpenCV calibration (" + e.what() + ")");
  }
}

namespace {

Rig ImportOpenCvYamlChecked(const std::string& path, const ImportOptions& o) {
  o.Check();
  std::vector<fs::path> files;
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    for (const char* n : {"intrinsics.yml", "extrinsics.yml", "intrinsics.yaml", "extrinsics.yaml"})
      if (fs::exists(fs::path(path) / n, ec)) files.push_back(fs::path(path) / n);
    if (files.empty()) throw CalibrationError(path + ": a directory without intrinsics.yml and extrinsics.yml");
  } else {
    files.push_back(path);
  }
  // One storage of every file's text (OpenCV reads YAML, XML or JSON by content).
  std::vector<cv::FileStorage> storages;
  for (const auto& f : files) {
    const std::string text = ReadText(f);
    // Checked before OpenCV reads it: its parser crashes on a cut-off XML
    // attribute and overflows the stack on deeply nested YAML.
    CheckOpenCvStorageText(text, f.string());
    cv::FileStorage fsr;
    try {
      if (!fsr.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_AUTO))
        throw CalibrationError(f.string() + ": not an OpenCV FileStorage file");
    } catch (const std::exception&) {  // cv::Exception, and std::length_error from its YAML parser
      throw CalibrationError(f.string() + ": not an OpenCV FileStorage file");
    }
    storages.push_back(std::move(fsr));
  }
  auto find = [&](const std::string& key) -> const cv::FileStorage* {
    for (const auto& s : storages)
      if (!s[key].empty()) return &s;
    return nullptr;
  };
  auto matrix = [&](const std::string& key, bool required = true) {
    const cv::FileStorage* s = find(key);
    if (!s) {
      if (required) throw CalibrationError(path + ": missing key '" + key + "'");
      return cv::Mat();
    }
    return Matrix(*s, key, path, required);
  };
  int w = 0, h = 0;
  if (const cv::FileStorage* s = find("image_width")) (*s)["image_width"] >> w;
  if (const cv::FileStorage* s = find("image_height")) (*s)["image_height"] >> h;
  Rig rig;
  rig.source = path;
  std::vector<std::pair<int, double>> repaired;
  auto add = [&](int id, const cv::Mat& k, const cv::Mat& d, const std::string& kkey, const std::string& dkey,
                 const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
    RigCamera rc;
    Camera& c = rc.camera;
    c.id = id;
    SetSize(&c, w, h, o, {}, path);
    if (k.total() != 9) throw CalibrationError(path + ": key '" + kkey + "' must be 3x3");
    SetCameraIntrinsics(std::vector<double>(k.begin<double>(), k.end<double>()), kOpenCvToHullpipePixelOffset, path,
                        kkey, &c);
    SetDistortion(d, path, dkey, &c);
    Eigen::Matrix3d rr = r;
    Eigen::Vector3d tt = t;
    if (o.poses_world_from_camera) {
      rr = r.transpose();
      tt = -(rr * t);
    }
    SetPose(&c, rr, tt, o, path, &repaired);
    rig.cameras.push_back(std::move(rc));
  };
  if (const cv::FileStorage* s = find("nCameras")) {
    int n = 0;
    (*s)["nCameras"] >> n;
    if (n < 1 || n > Rig::kMaxCameras)
      throw CalibrationError(path + ": key 'nCameras' must be in [1, " + std::to_string(Rig::kMaxCameras) + "]");
    for (int i = 0; i < n; ++i) {
      const std::string si = std::to_string(i);
      const cv::Mat pose = matrix("camera_pose_" + si);
      if (pose.rows != 4 || pose.cols != 4) throw CalibrationError(path + ": key 'camera_pose_" + si + "' must be 4x4");
      Eigen::Matrix3d r;
      Eigen::Vector3d t;
      for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b) r(a, b) = pose.at<double>(a, b);
        t(a) = pose.at<double>(a, 3);
      }
      add(i + 1, matrix("camera_matrix_" + si), matrix("camera_distortion_" + si, false), "camera_matrix_" + si,
          "camera_distortion_" + si, r, t);
    }
  } else if (find("M1") && find("M2")) {
    add(1, matrix("M1"), matrix("D1", false), "M1", "D1", Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
    const cv::Mat r = matrix("R"), t = matrix("T");
    // R is read by row and column: a 1x9 or 9x1 R has nine values but not
    // three rows (it read past its buffer).
    if (r.rows != 3 || r.cols != 3 || t.total() != 3)
      throw CalibrationError(path + ": keys 'R' and 'T' must be 3x3 and 3x1 (R is " + std::to_string(r.rows) + "x" +
                             std::to_string(r.cols) + ", T has " + std::to_string(t.total()) + " values)");
    Eigen::Matrix3d re;
    for (int k = 0; k < 9; ++k) re(k / 3, k % 3) = r.at<double>(k / 3, k % 3);
    const cv::Mat tf = t.reshape(1, 1);
    add(2, matrix("M2"), matrix("D2", false), "M2", "D2", re,
        Eigen::Vector3d(tf.at<double>(0), tf.at<double>(1), tf.at<double>(2)));
  } else {
    throw CalibrationError(path + ": neither a multi-camera calibration (nCameras, camera_matrix_i, camera_pose_i) "
                                  "nor a stereo one (M1, D1, M2, D2, R, T)");
  }
  return Finish(std::move(rig), repaired);
}

}  // namespace

bool DecomposeProjection(const Eigen::Matrix<double, 3, 4>& P_in, Eigen::Matrix3d* K, Eigen::Matrix3d* R,
                         Eigen::Vector3d* t) {
  if (!P_in.allFinite()) return false;
  Eigen::Matrix<double, 3, 4> P = P_in;
  Eigen::Matrix3d M = P.leftCols<3>();
  if (!(std::abs(M.determinant()) > 1e-12 * std::pow(M.norm(), 3))) return false;  // no camera centre
  if (M.determinant() < 0) P = -P, M = -M;  // P is known up to scale, its sign included
  // RQ: M = K R, K upper triangular. With J the row reversal, J M^T = Q U
  // (QR) gives M = (J U^T J)(J Q^T).
  Eigen::Matrix3d J = Eigen::Matrix3d::Zero();
  J(0, 2) = J(1, 1) = J(2, 0) = 1;
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr((J * M).transpose());
  const Eigen::Matrix3d Q = qr.householderQ();
  const Eigen::Matrix3d U = qr.matrixQR().triangularView<Eigen::Upper>();
  Eigen::Matrix3d k = J * U.transpose() * J, r = J * Q.transpose();
  // A positive diagonal in K: flip a column of K and the row of R with it.
  for (int i = 0; i < 3; ++i)
    if (k(i, i) < 0) k.col(i) *= -1, r.row(i) *= -1;
  if (r.determinant() < 0) return false;  // det M > 0 and diag K > 0 make det R > 0: rounding only
  const double s = k(2, 2);
  *K = k / s;
  *R = r;
  *t = k.triangularView<Eigen::Upper>().solve(Eigen::Vector3d(P.col(3)));
  return K->allFinite() && t->allFinite();
}

Rig ImportPmvs(const std::string& path, const ImportOptions& o) {
  o.Check();
  fs::path dir = path;
  if (fs::is_directory(dir / "txt")) dir /= "txt";
  if (!fs::is_directory(dir)) throw CalibrationError(path + ": not a directory (PMVS: <dir>/txt/*.txt)");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".txt") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  if (files.empty()) throw CalibrationError(dir.string() + ": no camera file (*.txt with CONTOUR and a 3x4 P)");
  if (files.size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(dir.string() + ": " + std::to_string(files.size()) + " cameras; a rig has at most " +
                           std::to_string(Rig::kMaxCameras));
  Rig rig;
  rig.source = path;
  std::vector<std::pair<int, double>> repaired;
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string where = files[i].string();
    std::ifstream in(files[i]);
    std::string head;
    if (!(in >> head) || head != "CONTOUR") throw CalibrationError(where + ": must start with CONTOUR");
    Eigen::Matrix<double, 3, 4> P;
    for (int k = 0; k < 12; ++k)
      if (!(in >> P(k / 4, k % 4))) throw CalibrationError(where + ": needs 12 numbers (a 3x4 P) after CONTOUR");
    Eigen::Matrix3d K, R;
    Eigen::Vector3d t;
    if (!DecomposeProjection(P, &K, &R, &t))
      throw CalibrationError(where + ": P is singular or not finite (its left 3x3 has no inverse): not a camera");
    RigCamera rc;
    Camera& c = rc.camera;
    c.id = int(i + 1);
    const std::string stem = files[i].stem().string();
    fs::path image;
    for (const char* ext : {".jpg", ".ppm", ".png"})
      if (fs::exists(dir.parent_path() / "visualize" / (stem + ext)))
        image = dir.parent_path() / "visualize" / (stem + ext);
    SetSize(&c, 0, 0, o, image, where);
    // PMVS samples images at integer pixel centres (as OpenCV).
    SetCameraIntrinsics({K(0, 0), K(0, 1), K(0, 2), K(1, 0), K(1, 1), K(1, 2), K(2, 0), K(2, 1), K(2, 2)},
                        kOpenCvToHullpipePixelOffset, where, "P", &c);
    SetPose(&c, R, t, o, where, &repaired);
    rc.frames = image.string();
    rig.cameras.push_back(std::move(rc));
  }
  return Finish(std::move(rig), repaired);
}

Rig ImportRig(const std::string& format, const std::string& path, const ImportOptions& o) {
  if (format == "colmap") return ImportColmap(path, o);
  if (format == "nerf") return ImportNerf(path, o);
  if (format == "middlebury") return ImportMiddlebury(path, o);
  if (format == "opencv-yaml") return ImportOpenCvYaml(path, o);
  if (format == "pmvs") return ImportPmvs(path, o);
  throw CalibrationError("--from " + format + ": not a known format (colmap, nerf, middlebury, opencv-yaml, pmvs)");
}

}  // namespace hullpipe
