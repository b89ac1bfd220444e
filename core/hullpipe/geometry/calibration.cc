#include "hullpipe/geometry/calibration.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <signal.h>
#include <sys/wait.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <libxml/parser.h>
#include <opencv2/imgproc.hpp>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Dense>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/bounded_child.h"
#include "hullpipe/util/image_file.h"
#include "hullpipe/util/yaml_keys.h"

namespace fs = std::filesystem;

namespace hullpipe {
namespace {

cv::Mat ReadMatrix(const cv::FileStorage& fs_in, const std::string& path, const char* key,
                   int expected_elements) {
  const cv::FileNode node = fs_in[key];
  if (node.empty()) throw CalibrationError(path + ": missing key '" + key + "'");
  // An opencv-matrix's rows and cols are checked before OpenCV allocates them
  // (a file saying <rows>1000000</rows> made it ask for 48 GB; fuzz_rig_files).
  if (node.isMap()) {
    const cv::FileNode rows = node["rows"], cols = node["cols"];
    const bool shaped = rows.isInt() && cols.isInt() && int(rows) >= 1 && int(cols) >= 1 &&
                        int64_t(int(rows)) * int64_t(int(cols)) == expected_elements;
    if (!shaped)
      throw CalibrationError(path + ": key '" + key + "' must be a matrix of " + std::to_string(expected_elements) +
                             " elements (its rows and cols say otherwise)");
  } else if (node.isSeq() && node.size() != size_t(expected_elements)) {
    throw CalibrationError(path + ": key '" + key + "' must have " + std::to_string(expected_elements) +
                           " elements, has " + std::to_string(node.size()));
  }
  cv::Mat m;
  try {
    node >> m;
  } catch (const std::exception&) {  // cv::Exception, and std::length_error from its YAML parser
    throw CalibrationError(path + ": key '" + key + "' is not a matrix");
  }
  if (m.empty() || static_cast<int>(m.total()) != expected_elements)
    throw CalibrationError(path + ": key '" + key + "' must have " +
                           std::to_string(expected_elements) + " elements, has " +
                           std::to_string(m.total()));
  m.convertTo(m, CV_64F);
  return m.reshape(1, 1);
}

// The intrinsics K (row-major 3x3, OpenCV pixel centres) of `key` in `path`
// into c (hullpipe pixel centres), skew included (Camera::skew). A last row
// other than (0, 0, 1) is refused rather than read in part. Bounds: fx, fy in
// [0.01, 10^4] x width (a horizontal field of view between 179.4 and 0.006
// degrees), |skew| <= fx (axes at least 45 degrees apart), the principal point
// inside the image.
}  // namespace

void SetCameraIntrinsics(const std::vector<double>& k, double offset, const std::string& path, const std::string& key,
                         Camera* c) {
  auto bad = [&](const std::string& what) {
    throw CalibrationError(path + ": camera " + std::to_string(c->id) + ": key '" + key + "' " + what);
  };
  for (double v : k)
    if (!std::isfinite(v)) bad("must be finite");
  const double fx = k[0], fy = k[4];
  // Exact zeros in calibration files; the tolerance only absorbs a printed 1e-17.
  const double tiny = 1e-9 * std::max({1.0, std::abs(fx), std::abs(fy)});
  if (std::abs(k[3]) > tiny || std::abs(k[6]) > tiny || std::abs(k[7]) > tiny || std::abs(k[8] - 1) > 1e-9)
    bad("must be [fx s cx; 0 fy cy; 0 0 1]: its last two rows are not (0 fy cy) and (0 0 1)");
  const double w = c->width, h = c->height;
  if (!(fx >= 0.01 * w && fx <= 1e4 * w && fy >= 0.01 * w && fy <= 1e4 * w))
    bad("has fx " + std::to_string(fx) + ", fy " + std::to_string(fy) + ": each must be in [0.01, 10000] x the width " +
        std::to_string(c->width) + " px (singular or implausible)");
  if (!(std::abs(k[1]) <= fx))
    bad("has skew " + std::to_string(k[1]) + " (row 0, column 1) larger than fx " + std::to_string(fx) +
        ": image axes less than 45 degrees apart (implausible)");
  if (!(k[2] >= 0 && k[2] <= w && k[5] >= 0 && k[5] <= h))
    bad("has its principal point (" + std::to_string(k[2]) + ", " + std::to_string(k[5]) + ") outside the " +
        std::to_string(c->width) + "x" + std::to_string(c->height) + " image");
  c->fx = fx;
  c->fy = fy;
  c->skew = std::abs(k[1]) > tiny ? k[1] : 0.0;  // a printed 1e-17 is zero
  c->cx = k[2] + offset;
  c->cy = k[5] + offset;
}

namespace {

void SetIntrinsics(const std::vector<double>& k, const std::string& path, const std::string& key, Camera* c) {
  SetCameraIntrinsics(k, kOpenCvToHullpipePixelOffset, path, key, c);
}

// Image size of a video or image file; {0,0} if it cannot be read.
cv::Size ProbeSize(const std::string& path) {
  std::error_code ec;
  if (path.empty() || !fs::is_regular_file(path, ec)) return {0, 0};  // a FIFO would block the open
  if (const std::optional<ImageHeader> h = ProbeImageFile(path)) return {h->width, h->height};  // never decoded
  cv::VideoCapture cap(path);
  if (!cap.isOpened()) return {0, 0};
  return {static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH)),
          static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT))};
}

Rig LoadUtrechtDir(const fs::path& dir) {
  Rig rig;
  rig.source = dir.string();
  std::vector<std::pair<int, fs::path>> cams;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    // cam<N> with N of at most 9 digits (std::stoi threw "stoi" on more).
    if (entry.is_directory() && name.rfind("cam", 0) == 0 && name.size() > 3 && name.size() <= 12 &&
        std::all_of(name.begin() + 3, name.end(), ::isdigit))
      cams.emplace_back(std::stoi(name.substr(3)), entry.path());
  }
  std::sort(cams.begin(), cams.end());
  if (cams.empty()) throw CalibrationError(dir.string() + ": no cam<N>/ directories");
  if (cams.size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(dir.string() + ": " + std::to_string(cams.size()) + " cam<N>/ directories; at most " +
                           std::to_string(Rig::kMaxCameras));
  for (const auto& [id, cam_dir] : cams) {
    RigCamera rc;
    rc.background = (cam_dir / "background.avi").string();
    rc.frames = (cam_dir / "video.avi").string();
    cv::Size size = ProbeSize(rc.frames);
    if (size.area() == 0) size = ProbeSize(rc.background);
    if (size.area() == 0)
      throw CalibrationError(cam_dir.string() + ": cannot read the image size from " +
                             rc.frames + " or " + rc.background);
    rc.camera = ReadOpenCvCameraConfig((cam_dir / "config.xml").string(), id, size.width,
                                       size.height);
    rig.cameras.push_back(std::move(rc));
  }
  // The layout's world: the calibration board is the floor, z = 0, and z points
  // down (the Utrecht rig) -- or up, if the cameras' image-up says so (a z-up
  // calibration in this layout used to load with its workspace capped on the
  // wrong side of the floor). The workspace ends 2 cm beyond the floor.
  const Eigen::Vector3d up = DeriveUp(rig.Cameras(), 30.0);
  rig.workspace = DefaultWorkspace(rig.Cameras());
  rig.world.floor = RigWorld::Floor::kPlane;
  rig.world.floor_height = 0;
  rig.world.up_stated = rig.world.floor_stated = rig.world.orbit_stated = true;
  if (up == Eigen::Vector3d(0, 0, -1)) {
    rig.world.up = up;
    rig.workspace.max.z() = std::min(rig.workspace.max.z(), 0.02);
  } else if (up == Eigen::Vector3d(0, 0, 1)) {
    rig.world.up = up;
    rig.workspace.min.z() = std::max(rig.workspace.min.z(), -0.02);
    rig.notes.push_back(dir.string() + ": the cameras say z points up in this calibration (the Utrecht rig's points "
                                       "down): floor z = 0 with up +z");
  } else {
    rig.world.up = up;
    rig.world.floor = RigWorld::Floor::kUnderHull;
    rig.world.floor_stated = false;
    rig.notes.push_back(dir.string() + ": the cameras' image-up is not along z; the board plane is not taken as the "
                                       "floor (floor under the first hull, workspace not capped)");
  }
  if (rig.workspace.empty())
    throw CalibrationError(dir.string() + ": the workspace is empty after the floor cap: the cameras see nothing "
                                          "on the floor's side (check the calibration's signs)");
  for (const auto& n : rig.notes) spdlog::warn("{}", n);
  return rig;
}

std::vector<double> ReadList(const YAML::Node& cam, const std::string& path,
                             const char* key, size_t n, bool required) {
  const YAML::Node node = cam[key];
  if (!node) {
    if (required) throw CalibrationError(path + ": missing key '" + key + "'");
    return std::vector<double>(n, 0.0);
  }
  std::vector<double> v;
  try {
    v = node.as<std::vector<double>>();
  } catch (const YAML::Exception&) {
    throw CalibrationError(path + ": key '" + key + "' must be a list of numbers");
  }
  if (v.size() != n)
    throw CalibrationError(path + ": key '" + key + "' must have " + std::to_string(n) +
                           " numbers, has " + std::to_string(v.size()));
  return v;
}

// A misspelt key ("distortio") would silently become a default: refused, named.
void RejectUnknownKeys(const YAML::Node& map, const std::string& path, const std::string& where,
                       std::initializer_list<const char*> known) {
  if (const auto key = FirstUnknownKey(map, known))
    throw CalibrationError(path + ": " + where + "unknown key '" + *key + "'");
}

Rig LoadYamlRig(const fs::path& file) {
  const std::string path = file.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    throw CalibrationError(path + ": " + e.what());
  }
  if (!root.IsMap()) throw CalibrationError(path + ": not a YAML map with key 'cameras'");
  RejectUnknownKeys(root, path, "", {"cameras", "workspace", "world"});
  if (!root["cameras"] || !root["cameras"].IsSequence())
    throw CalibrationError(path + ": missing key 'cameras' (a list)");
  if (root["cameras"].size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(path + ": key 'cameras' lists " + std::to_string(root["cameras"].size()) +
                           " cameras; at most " + std::to_string(Rig::kMaxCameras));
  Rig rig;
  rig.source = path;
  std::vector<std::pair<int, double>> repaired;  // camera id, ||R R^T - I||
  const fs::path base = file.parent_path();
  auto resolve = [&](const YAML::Node& n) -> std::string {
    if (!n) return {};
    const std::string spec = n.as<std::string>();
    if (RigCamera::IsLiveSpec(spec)) return spec;  // a device or a URL, not a path
    const fs::path p = spec;
    return p.is_absolute() ? p.string() : (base / p).string();
  };
  int index = 0;
  for (const auto& cam : root["cameras"]) {
    if (!cam.IsMap()) throw CalibrationError(path + ": camera " + std::to_string(index + 1) + " is not a map");
    RejectUnknownKeys(cam, path, "camera " + std::to_string(index + 1) + ": ",
                      {"id", "width", "height", "K", "distortion", "R", "t", "background", "frames", "masks",
                       "tracked", "latency", "mask_threshold", "mask_channel"});
    RigCamera rc;
    Camera& c = rc.camera;
    try {
      c.id = cam["id"] ? cam["id"].as<int>() : index + 1;
      if (!cam["width"] || !cam["height"])
        throw CalibrationError(path + ": missing key 'width' or 'height'");
      c.width = cam["width"].as<int>();
      c.height = cam["height"].as<int>();
    } catch (const YAML::Exception& e) {
      throw CalibrationError(path + ": bad id/width/height: " + e.what());
    }
    if (!(c.width >= 1 && c.width <= Camera::kMaxSide && c.height >= 1 && c.height <= Camera::kMaxSide))
      throw CalibrationError(path + ": camera " + std::to_string(c.id) + ": keys 'width', 'height' must be in [1, " +
                             std::to_string(Camera::kMaxSide) + "] pixels");
    SetIntrinsics(ReadList(cam, path, "K", 9, true), path, "K", &c);
    const auto d = ReadList(cam, path, "distortion", 5, false);
    std::copy(d.begin(), d.end(), c.distortion.begin());
    const auto r = ReadList(cam, path, "R", 9, true);
    const auto t = ReadList(cam, path, "t", 3, true);
    Eigen::Matrix3d rot;
    for (int i = 0; i < 9; ++i) rot(i / 3, i % 3) = r[i];
    double rot_error = 0;
    c.cam_from_world.rotation =
        NearestRotation(rot, path + ": camera " + std::to_string(c.id) + ": key 'R'", &rot_error);
    if (rot_error > kRotationNoteAbove) repaired.push_back({c.id, rot_error});
    c.cam_from_world.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    try {
      c.Check();
    } catch (const std::invalid_argument& e) {
      throw CalibrationError(path + ": " + e.what());
    }
    rc.background = resolve(cam["background"]);
    rc.frames = resolve(cam["frames"]);
    rc.masks = resolve(cam["masks"]);
    // The word `topic` (a live tracker) is not a path.
    const YAML::Node tracked = cam["tracked"];
    rc.tracked = tracked && tracked.IsScalar() && tracked.Scalar() == RigCamera::kTrackedByTopic
                     ? std::string(RigCamera::kTrackedByTopic)
                     : resolve(tracked);
    if (const YAML::Node l = cam["latency"]) {
      try {
        rc.latency_s = l.as<double>();
      } catch (const YAML::Exception&) {
        rc.latency_s = -1;
      }
      if (!(rc.latency_s >= 0 && rc.latency_s <= 10))
        throw CalibrationError(path + ": camera " + std::to_string(c.id) +
                               ": key 'latency' must be seconds in [0, 10]");
    }
    if (const YAML::Node m = cam["mask_threshold"]) {
      rc.mask_threshold = m.as<int>(-1);
      if (rc.mask_threshold < 1 || rc.mask_threshold > 255)
        throw CalibrationError(path + ": camera " + std::to_string(c.id) +
                               ": key 'mask_threshold' must be an integer in [1, 255]");
    }
    if (const YAML::Node m = cam["mask_channel"]) {
      const std::string name = m.as<std::string>("?");
      for (auto ch : {RigCamera::MaskChannel::kLuma, RigCamera::MaskChannel::kAlpha, RigCamera::MaskChannel::kRed,
                      RigCamera::MaskChannel::kGreen, RigCamera::MaskChannel::kBlue})
        if (MaskChannelName(ch) == name) rc.mask_channel = ch;
      if (rc.mask_channel == RigCamera::MaskChannel::kUnset)
        throw CalibrationError(path + ": camera " + std::to_string(c.id) + ": key 'mask_channel' must be one of luma, "
                                                                            "alpha, red, green, blue");
    }
    rig.cameras.push_back(std::move(rc));
    ++index;
  }
  CheckCameraIds(rig, path);
  if (!repaired.empty()) rig.notes.push_back(RepairedRotationsNote(path, repaired));
  if (const YAML::Node ws = root["workspace"]) {
    if (!ws.IsMap()) throw CalibrationError(path + ": key 'workspace' must be a map {min: [x,y,z], max: [x,y,z]}");
    RejectUnknownKeys(ws, path, "workspace: ", {"min", "max"});
    const auto lo = ReadList(ws, path, "min", 3, true), hi = ReadList(ws, path, "max", 3, true);
    rig.workspace.min = Eigen::Vector3d(lo[0], lo[1], lo[2]);
    rig.workspace.max = Eigen::Vector3d(hi[0], hi[1], hi[2]);
    // NaN compares false: a NaN box was "not empty" and passed.
    for (const double v : {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]})
      if (!(std::abs(v) <= kMaxStatedExtentM))
        throw CalibrationError(path + ": workspace: 'min' and 'max' must be finite metres within 10 km of the origin");
    if (rig.workspace.empty()) throw CalibrationError(path + ": workspace min must be <= max");
  }
  if (const YAML::Node w = root["world"]) {
    if (!w.IsMap())
      throw CalibrationError(path + ": key 'world' must be a map {up, floor, orbit_radius, orbit_height}");
    RejectUnknownKeys(w, path, "world: ", {"up", "floor", "orbit_radius", "orbit_height"});
    if (w["up"]) {
      const auto u = ReadList(w, path, "up", 3, true);
      rig.world.up = Eigen::Vector3d(u[0], u[1], u[2]);
      if (!rig.world.up.allFinite() || rig.world.up.norm() < 1e-9)
        throw CalibrationError(path + ": world: key 'up' must be a finite non-zero vector");
      rig.world.up.normalize();
      rig.world.up_stated = true;
    }
    if (const YAML::Node f = w["floor"]) {
      const std::string text = f.as<std::string>("");
      if (text == "hull") {
        rig.world.floor = RigWorld::Floor::kUnderHull;
      } else if (text == "none") {
        rig.world.floor = RigWorld::Floor::kNone;
      } else {
        rig.world.floor = RigWorld::Floor::kPlane;
        rig.world.floor_height = f.as<double>(std::nan(""));
        if (!(std::abs(rig.world.floor_height) <= kMaxStatedExtentM))
          throw CalibrationError(path +
                                 ": world: key 'floor' must be metres along up (within 10 km), 'hull' or 'none'");
      }
      rig.world.floor_stated = true;
    }
    for (const char* key : {"orbit_radius", "orbit_height"}) {
      if (!w[key]) continue;
      const double v = w[key].as<double>(std::nan(""));
      const bool radius = std::string(key) == "orbit_radius";
      if (!(std::abs(v) <= kMaxStatedExtentM) || (radius && !(v > 0)))
        throw CalibrationError(path + ": world: key '" + key + "' must be " +
                               (radius ? "in (0, 10000] m" : "finite metres within 10 km"));
      (radius ? rig.world.orbit_radius : rig.world.orbit_height) = v;
      rig.world.orbit_stated = true;
    }
  }
  try {
    CompleteRig(&rig);
  } catch (const std::invalid_argument& e) {
    throw CalibrationError(path + ": " + e.what());
  }
  for (const auto& n : rig.notes) spdlog::warn("{}", n);
  return rig;
}

}  // namespace

namespace {
// Throws CalibrationError naming the file and libxml2's first error unless
// `text` is one well-formed XML document (no network, no external DTD, no
// entity substitution: a calibration file needs none of them).
void CheckWellFormedXml(const std::string& text, const std::string& path) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos || (text[first] != '<' && text.compare(first, 3, "\xEF\xBB\xBF") != 0))
    throw CalibrationError(path + ": not XML (an OpenCV FileStorage .xml calibration file starts with '<')");
  xmlParserCtxtPtr ctxt = xmlNewParserCtxt();
  if (!ctxt) throw CalibrationError(path + ": cannot make an XML parser (out of memory)");
  xmlDocPtr doc = xmlCtxtReadMemory(ctxt, text.data(), int(text.size()), "config.xml", nullptr,
                                    XML_PARSE_NONET | XML_PARSE_NOERROR | XML_PARSE_NOWARNING);
  std::string error;
  if (!doc) {
    const xmlError* e = xmlCtxtGetLastError(ctxt);
    std::string message = e && e->message ? e->message : "unknown error";
    while (!message.empty() && (message.back() == '\n' || message.back() == ' ')) message.pop_back();
    error = path + ": not well-formed XML" + (e ? " (line " + std::to_string(e->line) + ": " + message + ")" : "");
  }
  xmlFreeDoc(doc);
  xmlFreeParserCtxt(ctxt);
  if (!error.empty()) throw CalibrationError(error);
}
}  // namespace

void CheckCameraIds(const Rig& rig, const std::string& where) {
  std::set<int> seen;
  for (const auto& rc : rig.cameras) {
    if (rc.camera.id < 0)
      throw CalibrationError(where + ": camera id " + std::to_string(rc.camera.id) + " is negative");
    if (!seen.insert(rc.camera.id).second)
      throw CalibrationError(where + ": two cameras have id " + std::to_string(rc.camera.id) +
                             " (a camera id names one camera on the wire)");
  }
}

namespace {
// OpenCV's YAML and JSON parsers on `text`, once, in a child process bounded to
// kMaxStorageParseSeconds: OpenCV 4.6's YAML parser loops forever on some
// malformed text (a '-' line where a second document would start: its
// document loop does not advance), and no check of the text short of a second
// parser rules every such input out. The parent throws CalibrationError if the
// child did not end in time or ended by a signal; what the parse itself says
// (accepted, cv::Exception) is the caller's parse's to say again.
void CheckOpenCvParseEnds(const std::string& text, const std::string& path) {
  BoundedChildResult child;
  try {
    child = RunBoundedChild(
        [&](int) {
          try {
            cv::FileStorage fs;
            fs.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_AUTO);
          } catch (...) {
          }
        },
        kMaxStorageParseSeconds, kMaxStorageParseSeconds, 0);
  } catch (const std::runtime_error& e) {
    throw CalibrationError(path + ": cannot check the file (" + e.what() + ")");
  }
  const int status = child.status;
  if (child.timed_out || (WIFSIGNALED(status) && (WTERMSIG(status) == SIGXCPU || WTERMSIG(status) == SIGKILL)))
    throw CalibrationError(path + ": OpenCV's parser did not finish reading it within " +
                           std::to_string(kMaxStorageParseSeconds) + " s: malformed YAML or JSON");
  if (WIFSIGNALED(status))
    throw CalibrationError(path + ": OpenCV's parser crashes on it (signal " + std::to_string(WTERMSIG(status)) +
                           "): malformed YAML or JSON");
  if (WEXITSTATUS(status) != 0)
    throw CalibrationError(path + ": OpenCV's parser fails on it (exit " + std::to_string(WEXITSTATUS(status)) +
                           "): malformed YAML or JSON");
}
}  // namespace

void CheckOpenCvStorageText(const std::string& text, const std::string& path) {
  if (text.size() > (1u << 20)) throw CalibrationError(path + ": larger than 1 MiB, not a calibration file");
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw CalibrationError(path + ": a NUL byte at offset " + std::to_string(nul) + ": not a text calibration file");
  size_t first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text.compare(first, 3, "\xEF\xBB\xBF") == 0)
    first = text.find_first_not_of(" \t\r\n", first + 3);
  if (first != std::string::npos && text[first] == '<') {
    CheckWellFormedXml(text, path);
    return;
  }
  // YAML or JSON: the nesting of [ and {. Brackets in quotes or comments are
  // counted too, and can hide nesting from the depth (a quoted ']' closes
  // nothing for OpenCV); the number of them cannot be hidden, and OpenCV's
  // recursion is never deeper than it.
  int depth = 0, line = 1, opened = 0;
  for (const char c : text) {
    if (c == '\n') {
      ++line;
    } else if (c == '[' || c == '{') {
      if (++opened > kMaxStorageCollections)
        throw CalibrationError(path + ": line " + std::to_string(line) + ": more than " +
                               std::to_string(kMaxStorageCollections) + " sequences and maps: not a calibration file");
      if (++depth > kMaxStorageNesting)
        throw CalibrationError(path + ": line " + std::to_string(line) + ": sequences and maps nested deeper than " +
                               std::to_string(kMaxStorageNesting) + ": not a calibration file");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  CheckOpenCvParseEnds(text, path);
}

Camera ReadOpenCvCameraConfig(const std::string& path, int camera_id, int width, int height) {
  // The text is read and checked here first: OpenCV 4.6's FileStorage parser
  // dereferences NULL on a NUL byte inside an XML attribute (fuzz_rig_files
  // found it), and a calibration file is a few KB of text.
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CalibrationError(path + ": cannot open calibration file");
  constexpr std::streamsize kMaxBytes = 1 << 20;
  std::string text(size_t(kMaxBytes) + 1, '\0');
  in.read(text.data(), kMaxBytes + 1);
  text.resize(size_t(in.gcount()));
  if (std::streamsize(text.size()) > kMaxBytes)
    throw CalibrationError(path + ": larger than 1 MiB, not a calibration file");
  if (const size_t nul = text.find('\0'); nul != std::string::npos)
    throw CalibrationError(path + ": a NUL byte at offset " + std::to_string(nul) + ": not a text calibration file");
  // Well-formed XML first (libxml2), then OpenCV: its 4.6 XML parser also
  // dereferences NULL on an attribute cut off at the end of the file
  // (fuzz_rig_files, in a 10-minute run), and reads YAML or JSON text with
  // other parsers. config.xml is XML.
  CheckWellFormedXml(text, path);
  cv::FileStorage fs_in;
  try {
    if (!fs_in.open(text, cv::FileStorage::READ | cv::FileStorage::MEMORY))
      throw CalibrationError(path + ": not a readable OpenCV FileStorage file");
  } catch (const std::exception&) {  // cv::Exception, and std::length_error from its YAML parser
    throw CalibrationError(path + ": not a readable OpenCV FileStorage file");
  }
  const cv::Mat k = ReadMatrix(fs_in, path, "CameraMatrix", 9);
  const cv::Mat d = ReadMatrix(fs_in, path, "DistortionCoeffs", 5);
  const cv::Mat rvec = ReadMatrix(fs_in, path, "Rotation", 3);
  const cv::Mat tvec = ReadMatrix(fs_in, path, "Translation", 3);
  Camera c;
  c.id = camera_id;
  c.width = width;
  c.height = height;
  if (!(width >= 1 && width <= Camera::kMaxSide && height >= 1 && height <= Camera::kMaxSide))
    throw CalibrationError(path + ": the camera's images are " + std::to_string(width) + "x" +
                           std::to_string(height) + " pixels; each side must be in [1, " +
                           std::to_string(Camera::kMaxSide) + "]");
  SetIntrinsics(std::vector<double>(k.begin<double>(), k.end<double>()), path, "CameraMatrix", &c);
  for (int i = 0; i < 5; ++i) c.distortion[i] = d.at<double>(i);
  cv::Mat rmat;
  cv::Rodrigues(rvec.reshape(1, 3), rmat);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) c.cam_from_world.rotation(r, col) = rmat.at<double>(r, col);
  c.cam_from_world.translation =
      Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)) *
      kMetresPerMillimetre;
  try {
    c.Check();
  } catch (const std::invalid_argument& e) {
    throw CalibrationError(path + ": " + e.what());
  }
  return c;
}

std::string RepairedRotationsNote(const std::string& source, const std::vector<std::pair<int, double>>& repaired) {
  std::string ids;
  double worst = 0;
  for (const auto& [id, e] : repaired) {
    ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    worst = std::max(worst, e);
  }
  char b[64];
  std::snprintf(b, sizeof b, "%.1e", worst);
  return source + ": the rotations of camera(s) " + ids + " are orthonormal only to " + b +
         " (printed decimals): took the nearest rotations (SVD)";
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& r, const std::string& where, double* error) {
  if (!r.allFinite()) throw CalibrationError(where + ": the rotation is not finite");
  const double e = (r * r.transpose() - Eigen::Matrix3d::Identity()).norm();
  const double det = r.determinant();
  if (error) *error = e;
  if (e > kRotationRepairTolerance || std::abs(det - 1) > kRotationRepairTolerance) {
    char b[160];
    std::snprintf(b, sizeof b, ": not a rotation (||R R^T - I|| = %.3g, det %.4g; within %.0e of one is repaired)", e,
                  det, kRotationRepairTolerance);
    throw CalibrationError(where + b);
  }
  if (e <= 1e-12 && std::abs(det - 1) <= 1e-12) return r;  // a rotation to machine precision: as it is
  // The nearest rotation (Frobenius), U V^T of r's SVD, as r (r^T r)^(-1/2): r
  // is within 1e-3 of a rotation, so r^T r is near I and its eigenvalues near 1.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(r.transpose() * r);
  const Eigen::Matrix3d inv_sqrt =
      eig.eigenvectors() * eig.eigenvalues().cwiseSqrt().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  return r * inv_sqrt;  // det +1 as det r > 0
}

void CompleteRig(Rig* rig) {
  const auto cams = rig->Cameras();
  if (rig->workspace.empty()) {
    // What every camera sees (paper §3.2: the hull lies in every view). Outside
    // it fewer cameras vote: in front of a ring camera, which cannot rule out
    // what it sees at every angle, the camera opposite sees the person behind,
    // and a kUnknown hull's box reaches out to the cameras (docs/rigs.md).
    rig->workspace = CommonViewWorkspace(cams);
    if (rig->workspace.empty()) {
      rig->workspace = DefaultWorkspace(cams);
      rig->notes.push_back(rig->source + ": the cameras share no view: the workspace is the box around them");
    }
  }
  if (!rig->world.up_stated) {
    try {
      rig->world.up = DeriveUp(cams);
    } catch (const std::invalid_argument& e) {
      rig->notes.push_back(rig->source + ": up not derived (" + e.what() + "); taking (0, 0, 1)");
      rig->world.up = Eigen::Vector3d(0, 0, 1);
    }
  }
  if (!rig->world.orbit_stated) {
    Aabb common = CommonViewWorkspace(cams);
    if (common.empty()) {
      common = rig->workspace;
      rig->notes.push_back(rig->source + ": the cameras share no view: the orbit frames the workspace");
    }
    rig->world.orbit_radius = FramingRadius(common);
    rig->world.orbit_height = 0.25 * rig->world.orbit_radius;
  }
  rig->world.Check();
}

std::string MaskChannelName(RigCamera::MaskChannel c) {
  switch (c) {
    case RigCamera::MaskChannel::kLuma: return "luma";
    case RigCamera::MaskChannel::kAlpha: return "alpha";
    case RigCamera::MaskChannel::kRed: return "red";
    case RigCamera::MaskChannel::kGreen: return "green";
    case RigCamera::MaskChannel::kBlue: return "blue";
    case RigCamera::MaskChannel::kUnset: break;
  }
  return "unset";
}

cv::Mat MaskToObjectPixelMap(const cv::Mat& mask, const RigCamera& rc) {
  const std::string who = "camera " + std::to_string(rc.camera.id) + ": mask: ";
  if (mask.empty()) throw std::invalid_argument(who + "empty image");
  cv::Mat m = mask;
  if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 1.0 / 257);
  if (m.depth() != CV_8U) throw std::invalid_argument(who + "must be 8 or 16 bit per channel");
  using Ch = RigCamera::MaskChannel;
  const int n = m.channels();
  cv::Mat one;
  if (n == 1) {
    one = m;
  } else if (n == 3 || n == 4) {
    Ch ch = rc.mask_channel;
    if (ch == Ch::kUnset) {
      if (n == 4)
        throw std::invalid_argument(who + "has 4 channels (BGRA): say which holds the mask (mask_channel: alpha or "
                                          "luma)");
      ch = Ch::kLuma;
    }
    if (ch == Ch::kAlpha && n != 4) throw std::invalid_argument(who + "mask_channel alpha, but it has no alpha");
    if (ch == Ch::kLuma) cv::cvtColor(m, one, n == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    else cv::extractChannel(m, one, ch == Ch::kBlue ? 0 : ch == Ch::kGreen ? 1 : ch == Ch::kRed ? 2 : 3);
  } else {
    throw std::invalid_argument(who + "has " + std::to_string(n) + " channels; 1, 3 or 4 are read");
  }
  return one >= rc.mask_threshold;
}

bool RigCamera::IsLiveSpec(const std::string& spec) {
  return spec.rfind("v4l2:", 0) == 0 || spec.find("://") != std::string::npos;
}

std::vector<Camera> Rig::Cameras() const {
  std::vector<Camera> out;
  for (const auto& rc : cameras) out.push_back(rc.camera);
  return out;
}

Rig LoadRig(const std::string& path) {
  const fs::path p(path);
  if (!fs::exists(p)) throw CalibrationError(path + ": no such file or directory");
  if (fs::is_directory(p)) {
    if (fs::exists(p / "rig.yaml")) return LoadYamlRig(p / "rig.yaml");
    return LoadUtrechtDir(p);
  }
  return LoadYamlRig(p);
}

void WriteRigYaml(const Rig& rig, const std::string& path) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // round trips to the last bit
  out << YAML::BeginMap << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (const auto& rc : rig.cameras) {
    const Camera& c = rc.camera;
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << c.id;
    out << YAML::Key << "width" << YAML::Value << c.width;
    out << YAML::Key << "height" << YAML::Value << c.height;
    out << YAML::Key << "K" << YAML::Value << YAML::Flow
        << std::vector<double>{c.fx, c.skew, c.cx - kOpenCvToHullpipePixelOffset, 0, c.fy,
                               c.cy - kOpenCvToHullpipePixelOffset, 0, 0, 1};
    out << YAML::Key << "distortion" << YAML::Value << YAML::Flow
        << std::vector<double>(c.distortion.begin(), c.distortion.end());
    std::vector<double> r(9);
    for (int i = 0; i < 9; ++i) r[i] = c.cam_from_world.rotation(i / 3, i % 3);
    out << YAML::Key << "R" << YAML::Value << YAML::Flow << r;
    const auto& t = c.cam_from_world.translation;
    out << YAML::Key << "t" << YAML::Value << YAML::Flow << std::vector<double>{t.x(), t.y(), t.z()};
    if (!rc.background.empty()) out << YAML::Key << "background" << YAML::Value << rc.background;
    if (!rc.frames.empty()) out << YAML::Key << "frames" << YAML::Value << rc.frames;
    if (!rc.masks.empty()) out << YAML::Key << "masks" << YAML::Value << rc.masks;
    if (rc.latency_s != 0) out << YAML::Key << "latency" << YAML::Value << rc.latency_s;
    if (!rc.tracked.empty()) out << YAML::Key << "tracked" << YAML::Value << rc.tracked;
    if (rc.mask_threshold != 128) out << YAML::Key << "mask_threshold" << YAML::Value << rc.mask_threshold;
    if (rc.mask_channel != RigCamera::MaskChannel::kUnset)
      out << YAML::Key << "mask_channel" << YAML::Value << MaskChannelName(rc.mask_channel);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!rig.workspace.empty()) {
    const auto& a = rig.workspace.min;
    const auto& b = rig.workspace.max;
    out << YAML::Key << "workspace" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "min" << YAML::Value << YAML::Flow << std::vector<double>{a.x(), a.y(), a.z()};
    out << YAML::Key << "max" << YAML::Value << YAML::Flow << std::vector<double>{b.x(), b.y(), b.z()};
    out << YAML::EndMap;
  }
  {
    const RigWorld& w = rig.world;
    out << YAML::Key << "world" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "up" << YAML::Value << YAML::Flow << std::vector<double>{w.up.x(), w.up.y(), w.up.z()};
    out << YAML::Key << "floor" << YAML::Value;
    if (w.floor == RigWorld::Floor::kPlane) out << w.floor_height;
    else out << (w.floor == RigWorld::Floor::kNone ? "none" : "hull");
    out << YAML::Key << "orbit_radius" << YAML::Value << w.orbit_radius;
    out << YAML::Key << "orbit_height" << YAML::Value << w.orbit_height;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  std::ofstream f(path);
  if (!f) throw CalibrationError(path + ": cannot write");
  f << out.c_str() << "\n";
  f.close();
  // A full disk or a quota: said, never a "wrote" over a cut file.
  if (!f) throw CalibrationError(path + ": could not be written in full (a full disk?)");
}

}  // namespace hullpipe
