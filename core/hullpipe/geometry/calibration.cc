#include "hullpipe/geometry/calibration.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <libxml/parser.h>
#include <yaml-cpp/yaml.h>

#include "hullpipe/geometry/conventions.h"
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
  } catch (const cv::Exception& e) {
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
// into c (hullpipe pixel centres). hullpipe's pinhole has no skew and a last
// row (0, 0, 1): any other K is refused rather than read in part (fx, fy, cx,
// cy alone would drop the skew and take a singular K). Bounds: fx, fy in
// [0.01, 10^4] x width (a horizontal field of view between 179.4 and 0.006
// degrees), the principal point inside the image.
void SetIntrinsics(const std::vector<double>& k, const std::string& path, const std::string& key, Camera* c) {
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
  if (std::abs(k[1]) > tiny)
    bad("has skew " + std::to_string(k[1]) +
        " (row 0, column 1); hullpipe's camera model has none: calibrate with zero skew (OpenCV's calibrateCamera "
        "does)");
  const double w = c->width, h = c->height;
  if (!(fx >= 0.01 * w && fx <= 1e4 * w && fy >= 0.01 * w && fy <= 1e4 * w))
    bad("has fx " + std::to_string(fx) + ", fy " + std::to_string(fy) + ": each must be in [0.01, 10000] x the width " +
        std::to_string(c->width) + " px (singular or implausible)");
  if (!(k[2] >= 0 && k[2] <= w && k[5] >= 0 && k[5] <= h))
    bad("has its principal point (" + std::to_string(k[2]) + ", " + std::to_string(k[5]) + ") outside the " +
        std::to_string(c->width) + "x" + std::to_string(c->height) + " image");
  c->fx = fx;
  c->fy = fy;
  c->cx = k[2] + kOpenCvToHullpipePixelOffset;
  c->cy = k[5] + kOpenCvToHullpipePixelOffset;
}

// Image size of a video or image file; {0,0} if it cannot be read.
cv::Size ProbeSize(const std::string& path) {
  if (path.empty() || !fs::exists(path)) return {0, 0};
  cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (!img.empty()) return img.size();
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
    if (entry.is_directory() && name.rfind("cam", 0) == 0 && name.size() > 3 &&
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
  rig.workspace = DefaultWorkspace(rig.Cameras());
  rig.workspace.max.z() = std::min(rig.workspace.max.z(), 0.02);
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
  RejectUnknownKeys(root, path, "", {"cameras", "workspace"});
  if (!root["cameras"] || !root["cameras"].IsSequence())
    throw CalibrationError(path + ": missing key 'cameras' (a list)");
  if (root["cameras"].size() > size_t(Rig::kMaxCameras))
    throw CalibrationError(path + ": key 'cameras' lists " + std::to_string(root["cameras"].size()) +
                           " cameras; at most " + std::to_string(Rig::kMaxCameras));
  Rig rig;
  rig.source = path;
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
                       "tracked", "latency"});
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
    for (int i = 0; i < 9; ++i) c.cam_from_world.rotation(i / 3, i % 3) = r[i];
    c.cam_from_world.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    try {
      c.Check();
    } catch (const std::invalid_argument& e) {
      throw CalibrationError(path + ": " + e.what());
    }
    rc.background = resolve(cam["background"]);
    rc.frames = resolve(cam["frames"]);
    rc.masks = resolve(cam["masks"]);
    rc.tracked = resolve(cam["tracked"]);
    if (const YAML::Node l = cam["latency"]) {
      try {
        rc.latency_s = l.as<double>();
      } catch (const YAML::Exception&) {
        rc.latency_s = -1;
      }
      if (!(rc.latency_s >= 0 && rc.latency_s <= 10))
        throw CalibrationError(path + ": camera " + std::to_string(c.id) + ": key 'latency' must be seconds in [0, 10]");
    }
    rig.cameras.push_back(std::move(rc));
    ++index;
  }
  rig.workspace = DefaultWorkspace(rig.Cameras());
  if (const YAML::Node ws = root["workspace"]) {
    if (!ws.IsMap()) throw CalibrationError(path + ": key 'workspace' must be a map {min: [x,y,z], max: [x,y,z]}");
    RejectUnknownKeys(ws, path, "workspace: ", {"min", "max"});
    const auto lo = ReadList(ws, path, "min", 3, true), hi = ReadList(ws, path, "max", 3, true);
    rig.workspace.min = Eigen::Vector3d(lo[0], lo[1], lo[2]);
    rig.workspace.max = Eigen::Vector3d(hi[0], hi[1], hi[2]);
    if (rig.workspace.empty()) throw CalibrationError(path + ": workspace min must be <= max");
  }
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
  } catch (const cv::Exception& e) {
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
  out << YAML::BeginMap << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (const auto& rc : rig.cameras) {
    const Camera& c = rc.camera;
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << c.id;
    out << YAML::Key << "width" << YAML::Value << c.width;
    out << YAML::Key << "height" << YAML::Value << c.height;
    out << YAML::Key << "K" << YAML::Value << YAML::Flow
        << std::vector<double>{c.fx, 0, c.cx - kOpenCvToHullpipePixelOffset, 0, c.fy,
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
  out << YAML::EndMap;
  std::ofstream f(path);
  if (!f) throw CalibrationError(path + ": cannot write");
  f << out.c_str() << "\n";
}

}  // namespace hullpipe
