#include "hullpipe/dds/convert.h"

#include <cmath>
#include <cstring>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/dds/topics.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/segmentation/object_pixel_map.h"
#include "hullpipe/util/image_file.h"

namespace hullpipe::dds {

// A reader of camera-keyed best-effort topics keeps every camera a rig may
// have, four times over (topics.h).
static_assert(kCameraInstances == 4 * Rig::kMaxCameras);

namespace {
bool AllFinite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}
constexpr uint32_t kMaxSide = 16384;
}  // namespace

hullpipe_msg_CameraInfo CameraToMsg(const Camera& c, const Aabb& ws) {
  hullpipe_msg_CameraInfo m{};
  m.camera_id = uint32_t(c.id);
  m.width = uint32_t(c.width);
  m.height = uint32_t(c.height);
  const Eigen::Matrix3d K = c.K();
  for (int i = 0; i < 9; ++i) {
    m.K[i] = K(i / 3, i % 3);
    m.cam_from_world_rotation[i] = c.cam_from_world.rotation(i / 3, i % 3);
  }
  for (int i = 0; i < 5; ++i) m.distortion[i] = c.distortion[size_t(i)];
  for (int i = 0; i < 3; ++i) {
    m.cam_from_world_translation[i] = c.cam_from_world.translation[i];
    m.workspace_min[i] = ws.min[i];
    m.workspace_max[i] = ws.max[i];
  }
  return m;
}

Camera CameraFromMsg(const hullpipe_msg_CameraInfo& m, Aabb* ws) {
  const std::string who = "CameraInfo of camera " + std::to_string(m.camera_id) + ": ";
  if (m.width == 0 || m.height == 0 || m.width > kMaxSide || m.height > kMaxSide)
    throw MessageError(who + "image size out of range");
  if (!AllFinite(m.K, 9) || !AllFinite(m.distortion, 5) || !AllFinite(m.cam_from_world_rotation, 9) ||
      !AllFinite(m.cam_from_world_translation, 3))
    throw MessageError(who + "non-finite calibration");
  Camera c;
  c.id = int(m.camera_id);
  c.width = int(m.width);
  c.height = int(m.height);
  c.fx = m.K[0];
  c.fy = m.K[4];
  c.cx = m.K[2];
  c.skew = m.K[1];
  c.cy = m.K[5];
  for (int i = 0; i < 5; ++i) c.distortion[size_t(i)] = m.distortion[i];
  for (int i = 0; i < 9; ++i) c.cam_from_world.rotation(i / 3, i % 3) = m.cam_from_world_rotation[i];
  for (int i = 0; i < 3; ++i) c.cam_from_world.translation[i] = m.cam_from_world_translation[i];
  try {
    c.Check();
  } catch (const std::invalid_argument& e) {
    throw MessageError(who + e.what());
  }
  if (ws) {
    for (int i = 0; i < 3; ++i) {
      ws->min[i] = m.workspace_min[i];
      ws->max[i] = m.workspace_max[i];
    }
    if (!ws->min.allFinite() || !ws->max.allFinite()) *ws = Aabb{};
  }
  return c;
}

OwnedSample<hullpipe_msg_ObjectPixelMap> MakeMapMessage(const FrameStamp& stamp, uint32_t camera_count,
                                                        const cv::Mat& map, const Rigid3d* cam_from_world) {
  OwnedSample<hullpipe_msg_ObjectPixelMap> s;
  s.words = RunLengthEncode(map);
  auto& m = s.msg;
  m.camera_id = stamp.camera_id;
  m.frame_seq = stamp.seq;
  m.capture_time_ns = stamp.capture_time_ns;
  m.source_time = stamp.source_time_s;
  m.width = uint32_t(map.cols);
  m.height = uint32_t(map.rows);
  m.camera_count = camera_count;
  m.encoding = hullpipe_msg_MAP_ENCODING_RLE;
  Borrow(&m.runs, s.words);
  m.tracked = cam_from_world != nullptr;
  if (cam_from_world) {
    for (int i = 0; i < 9; ++i) m.cam_from_world_rotation[i] = cam_from_world->rotation(i / 3, i % 3);
    for (int i = 0; i < 3; ++i) m.cam_from_world_translation[i] = cam_from_world->translation[i];
  }
  return s;
}

std::optional<Rigid3d> MapPoseFromMsg(const hullpipe_msg_ObjectPixelMap& m) {
  if (!m.tracked) return std::nullopt;
  Rigid3d pose;
  for (int i = 0; i < 9; ++i) pose.rotation(i / 3, i % 3) = m.cam_from_world_rotation[i];
  for (int i = 0; i < 3; ++i) pose.translation[i] = m.cam_from_world_translation[i];
  const bool finite = pose.rotation.allFinite() && pose.translation.allFinite();
  if (!finite || (pose.rotation * pose.rotation.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6 ||
      pose.rotation.determinant() < 0)
    throw MessageError("ObjectPixelMap of camera " + std::to_string(m.camera_id) +
                       ": its tracked pose is not a rotation and a finite translation");
  return pose;
}

cv::Mat MapFromMsg(const hullpipe_msg_ObjectPixelMap& m) { return DecodedMapFromMsg(m).map; }

DecodedMap DecodedMapFromMsg(const hullpipe_msg_ObjectPixelMap& m) {
  if (m.encoding != hullpipe_msg_MAP_ENCODING_RLE)
    throw MessageError("ObjectPixelMap of camera " + std::to_string(m.camera_id) +
                       ": unknown encoding " + std::to_string(int(m.encoding)));
  try {
    return RunLengthDecodeMap(m.runs._buffer, m.runs._length, int(std::min(m.width, kMaxSide + 1)),
                              int(std::min(m.height, kMaxSide + 1)));
  } catch (const MapDecodeError& e) {
    throw MessageError("ObjectPixelMap of camera " + std::to_string(m.camera_id) + ": " + e.what());
  }
}

OwnedSample<hullpipe_msg_CameraImage> MakeImageRegionMessage(uint32_t camera_id, uint64_t frame_seq, int64_t t,
                                                             const cv::Mat& part, const cv::Rect& rect, cv::Size whole,
                                                             int jpeg_quality) {
  CV_Assert(part.empty() || part.type() == CV_8UC3);
  CV_Assert(part.size() == rect.size() && (rect & cv::Rect(cv::Point(0, 0), whole)) == rect);
  OwnedSample<hullpipe_msg_CameraImage> s;
  auto& m = s.msg;
  m.camera_id = camera_id;
  m.frame_seq = frame_seq;
  m.capture_time_ns = t;
  if (rect != cv::Rect(cv::Point(0, 0), whole)) {
    m.x = rect.area() ? uint32_t(rect.x) : 0;
    m.y = rect.area() ? uint32_t(rect.y) : 0;
    m.full_width = uint32_t(whole.width);
    m.full_height = uint32_t(whole.height);
  }
  m.width = rect.area() ? uint32_t(rect.width) : 0;
  m.height = rect.area() ? uint32_t(rect.height) : 0;
  if (rect.area() == 0) {
    // No object pixels: nothing of the image is sent.
    m.encoding = hullpipe_msg_IMAGE_ENCODING_BGR8;
  } else if (jpeg_quality > 0) {
    m.encoding = hullpipe_msg_IMAGE_ENCODING_JPEG;
    cv::imencode(".jpg", part, s.bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
  } else {
    m.encoding = hullpipe_msg_IMAGE_ENCODING_BGR8;
    const cv::Mat cont = part.isContinuous() ? part : part.clone();
    s.bytes.assign(cont.datastart, cont.dataend);
  }
  Borrow(&m.data, s.bytes);
  return s;
}

OwnedSample<hullpipe_msg_CameraImage> MakeImageMessage(uint32_t camera_id, uint64_t frame_seq, int64_t t,
                                                       const cv::Mat& bgr, int jpeg_quality,
                                                       const std::optional<cv::Rect>& region) {
  CV_Assert(bgr.type() == CV_8UC3);
  const cv::Rect whole(0, 0, bgr.cols, bgr.rows);
  const cv::Rect part = region ? *region & whole : whole;
  return MakeImageRegionMessage(camera_id, frame_seq, t, part.area() ? bgr(part) : cv::Mat(), part, bgr.size(),
                                jpeg_quality);
}

namespace {

// The image `data` holds, width x height (checked to be in range).
cv::Mat DecodeImageData(const std::string& who, const hullpipe_msg_CameraImage& m) {
  if (m.encoding == hullpipe_msg_IMAGE_ENCODING_BGR8) {
    if (uint64_t(m.data._length) != uint64_t(m.width) * m.height * 3)
      throw MessageError(who + "data has " + std::to_string(m.data._length) + " bytes, expected " +
                         std::to_string(uint64_t(m.width) * m.height * 3));
    return cv::Mat(int(m.height), int(m.width), CV_8UC3, m.data._buffer).clone();
  }
  if (m.encoding == hullpipe_msg_IMAGE_ENCODING_JPEG) {
    // The header first: only a JPEG of the stated size reaches a decoder
    // (hullpipe/util/image_file.h), never bytes of another format or a
    // header claiming more than the message says.
    CheckJpegOfSize(who, m.data._buffer, m.data._length, m.width, m.height);
    std::string why;
    cv::Mat img = DecodeImage(m.data._buffer, m.data._length, cv::IMREAD_COLOR, &why);
    if (img.empty()) throw MessageError(who + why);
    return img;
  }
  throw MessageError(who + "unknown encoding " + std::to_string(int(m.encoding)));
}

}  // namespace

bool ImageHasRegion(const hullpipe_msg_CameraImage& m) { return m.full_width != 0 || m.full_height != 0; }

cv::Size WholeImageSize(const hullpipe_msg_CameraImage& m) {
  const bool region = ImageHasRegion(m);
  return {int(std::min(region ? m.full_width : m.width, 1u << 30)),
          int(std::min(region ? m.full_height : m.height, 1u << 30))};
}

void CheckImageWithin(const hullpipe_msg_CameraImage& m, int width, int height) {
  const cv::Size whole = WholeImageSize(m);
  if (whole.width > width || whole.height > height)
    throw MessageError("CameraImage of camera " + std::to_string(m.camera_id) + ": " +
                       (ImageHasRegion(m) ? "whole image " : "") + std::to_string(whole.width) + "x" +
                       std::to_string(whole.height) + " is larger than its calibration's " + std::to_string(width) +
                       "x" + std::to_string(height));
}

void RegionBounds::Calibrated(uint32_t camera_id, int width, int height) {
  if (sizes_.size() < kMaxCameras || sizes_.count(camera_id)) sizes_[camera_id] = cv::Size(width, height);
}

void RegionBounds::CheckRegion(const hullpipe_msg_CameraImage& m) const {
  if (!ImageHasRegion(m)) return;
  // Its whole image is made from two numbers: only within the calibration.
  const auto cal = sizes_.find(m.camera_id);
  if (cal == sizes_.end())
    throw MessageError("CameraImage region of camera " + std::to_string(m.camera_id) + " before its calibration");
  CheckImageWithin(m, cal->second.width, cal->second.height);
}

cv::Mat ImageFromMsg(const hullpipe_msg_CameraImage& m) {
  const std::string who = "CameraImage of camera " + std::to_string(m.camera_id) + ": ";
  if (!ImageHasRegion(m)) {
    if (m.width == 0 || m.height == 0 || m.width > kMaxSide || m.height > kMaxSide)
      throw MessageError(who + "image size out of range");
    return DecodeImageData(who, m);
  }
  if (m.full_width == 0 || m.full_height == 0 || m.full_width > kMaxSide || m.full_height > kMaxSide)
    throw MessageError(who + "whole image size " + std::to_string(m.full_width) + "x" +
                       std::to_string(m.full_height) + " out of range");
  if (uint64_t(m.x) + m.width > m.full_width || uint64_t(m.y) + m.height > m.full_height)
    throw MessageError(who + "region " + std::to_string(m.width) + "x" + std::to_string(m.height) + " at (" +
                       std::to_string(m.x) + ", " + std::to_string(m.y) + ") is not within the whole image " +
                       std::to_string(m.full_width) + "x" + std::to_string(m.full_height));
  cv::Mat whole(int(m.full_height), int(m.full_width), CV_8UC3, cv::Scalar::all(0));
  if (m.width == 0 || m.height == 0) {
    if (m.width != 0 || m.height != 0 || m.data._length != 0)
      throw MessageError(who + "an empty region (" + std::to_string(m.width) + "x" + std::to_string(m.height) +
                         ") with " + std::to_string(m.data._length) + " bytes of data");
    return whole;
  }
  DecodeImageData(who, m).copyTo(whole(cv::Rect(int(m.x), int(m.y), int(m.width), int(m.height))));
  return whole;
}

void CheckJpegOfSize(const std::string& who, const uint8_t* data, size_t n, uint32_t width, uint32_t height) {
  const std::optional<ImageHeader> h = ParseImageHeader(data, n);
  if (!h || h->format != "jpeg" || int64_t(h->width) != int64_t(width) || int64_t(h->height) != int64_t(height))
    throw MessageError(who + "data is not a JPEG of the stated size " + std::to_string(width) + "x" +
                       std::to_string(height));
}

OwnedSample<hullpipe_msg_CompositedView> MakeCompositedViewMessage(const cv::Mat& bgr, uint64_t pose_seq,
                                                                   uint64_t frame_seq, int64_t t, uint64_t run_id,
                                                                   const ViewEncoding& encoding, ViewEye eye) {
  const int max_side = encoding.max_side, jpeg_quality = encoding.jpeg_quality;
  if (bgr.empty() || bgr.type() != CV_8UC3) throw MessageError("CompositedView: the frame must be non-empty BGR");
  if (max_side < 16 || max_side > int(kMaxSide))
    throw MessageError("CompositedView: the largest side must be in [16, 16384], not " + std::to_string(max_side));
  if (jpeg_quality < 1 || jpeg_quality > 100)
    throw MessageError("CompositedView: the JPEG quality must be in [1, 100], not " + std::to_string(jpeg_quality));
  cv::Mat image = bgr;
  const int longer = std::max(bgr.cols, bgr.rows);
  if (longer > max_side) {
    const double s = double(max_side) / longer;
    const cv::Size size(std::max(1, int(std::lround(bgr.cols * s))), std::max(1, int(std::lround(bgr.rows * s))));
    cv::resize(bgr, image, size, 0, 0, cv::INTER_AREA);
  }
  OwnedSample<hullpipe_msg_CompositedView> s;
  auto& m = s.msg;
  m.pose_seq = pose_seq;
  m.frame_seq = frame_seq;
  m.capture_time_ns = t;
  m.width = uint32_t(image.cols);
  m.height = uint32_t(image.rows);
  m.view_width = uint32_t(bgr.cols);
  m.view_height = uint32_t(bgr.rows);
  m.run_id = run_id;
  m.eye = uint8_t(eye);
  if (!cv::imencode(".jpg", image, s.bytes, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality}))
    throw MessageError("CompositedView: the JPEG encoder failed");
  Borrow(&m.data, s.bytes);
  return s;
}

ViewEye ViewEyeFromMsg(const std::string& who, uint8_t eye) {
  if (eye > hullpipe_msg_VIEW_EYE_RIGHT)
    throw MessageError(who + "eye " + std::to_string(eye) + " is none of VIEW_EYE_MONO (0), VIEW_EYE_LEFT (1), "
                       "VIEW_EYE_RIGHT (2)");
  return ViewEye(eye);
}

void CheckCompositedViewMsg(const hullpipe_msg_CompositedView& m) {
  const std::string who = "CompositedView of frame " + std::to_string(m.frame_seq) + ": ";
  (void)ViewEyeFromMsg(who, m.eye);
  for (const uint32_t side : {m.width, m.height, m.view_width, m.view_height})
    if (side == 0 || side > kMaxSide) throw MessageError(who + "a size out of [1, 16384]");
  if (m.width > m.view_width || m.height > m.view_height)
    throw MessageError(who + "the image (" + std::to_string(m.width) + "x" + std::to_string(m.height) +
                       ") is larger than its view (" + std::to_string(m.view_width) + "x" +
                       std::to_string(m.view_height) + ")");
  CheckJpegOfSize(who, m.data._buffer, m.data._length, m.width, m.height);
}

cv::Mat CompositedViewFromMsg(const hullpipe_msg_CompositedView& m) {
  CheckCompositedViewMsg(m);
  std::string why;
  cv::Mat img = DecodeImage(m.data._buffer, m.data._length, cv::IMREAD_COLOR, &why);
  if (img.empty()) throw MessageError("CompositedView of frame " + std::to_string(m.frame_seq) + ": " + why);
  return img;
}

hullpipe_msg_ViewPose ViewToMsg(const NovelView& v, uint64_t pose_seq, uint64_t frame_seq, int64_t stamp,
                                uint64_t run_id, ViewEye eye) {
  hullpipe_msg_ViewPose m{};
  m.run_id = run_id;
  m.eye = uint8_t(eye);
  m.pose_seq = pose_seq;
  m.stamp_ns = stamp;
  m.frame_seq = frame_seq;
  m.width = uint32_t(v.width);
  m.height = uint32_t(v.height);
  m.fx = v.fx, m.fy = v.fy, m.cx = v.cx, m.cy = v.cy;
  for (int i = 0; i < 9; ++i) m.world_from_eye_rotation[i] = v.world_from_eye.rotation(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) m.world_from_eye_translation[i] = v.world_from_eye.translation[i];
  return m;
}

NovelView ViewFromMsg(const hullpipe_msg_ViewPose& m) {
  if (m.width == 0 || m.height == 0 || m.width > 8192 || m.height > 8192)
    throw MessageError("ViewPose " + std::to_string(m.pose_seq) + ": view size out of range");
  (void)ViewEyeFromMsg("ViewPose " + std::to_string(m.pose_seq) + ": ", m.eye);
  const double k[4] = {m.fx, m.fy, m.cx, m.cy};
  if (!AllFinite(k, 4) || !AllFinite(m.world_from_eye_rotation, 9) ||
      !AllFinite(m.world_from_eye_translation, 3))
    throw MessageError("ViewPose " + std::to_string(m.pose_seq) + ": non-finite values");
  NovelView v;
  v.width = int(m.width);
  v.height = int(m.height);
  v.fx = m.fx, v.fy = m.fy, v.cx = m.cx, v.cy = m.cy;
  for (int i = 0; i < 9; ++i) v.world_from_eye.rotation(i / 3, i % 3) = m.world_from_eye_rotation[i];
  for (int i = 0; i < 3; ++i) v.world_from_eye.translation[i] = m.world_from_eye_translation[i];
  const Eigen::Matrix3d& R = v.world_from_eye.rotation;
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6)
    throw MessageError("ViewPose " + std::to_string(m.pose_seq) + ": rotation is not orthonormal");
  try {
    v.Check();
  } catch (const std::invalid_argument& e) {
    throw MessageError(std::string("ViewPose: ") + e.what());
  }
  return v;
}

OwnedSample<hullpipe_msg_HullView> MakeHullViewMessage(const HullTile& t, uint32_t planes) {
  CV_Assert(t.depth.type() == CV_32FC1 && t.colour.type() == CV_8UC3);
  CV_Assert(t.depth.size() == t.rect.size() && t.colour.size() == t.rect.size());
  OwnedSample<hullpipe_msg_HullView> s;
  const cv::Mat d = t.depth.isContinuous() ? t.depth : t.depth.clone();
  const cv::Mat c = t.colour.isContinuous() ? t.colour : t.colour.clone();
  s.floats.assign(d.ptr<float>(0), d.ptr<float>(0) + d.total());
  // On the wire "no hull" is 0 (eye depth of hull is always > 0): no NaN or
  // infinity leaves a node.
  for (float& v : s.floats)
    if (!std::isfinite(v) || !(v > 0)) v = 0.0f;
  s.bytes.assign(c.datastart, c.dataend);
  auto& m = s.msg;
  m.node_id = t.node_id;
  m.tile_index = t.tile_index;
  m.tile_count = t.tile_count;
  m.x = uint32_t(t.rect.x), m.y = uint32_t(t.rect.y);
  m.width = uint32_t(t.rect.width), m.height = uint32_t(t.rect.height);
  m.pose_seq = t.pose_seq;
  m.frame_seq = t.frame_seq;
  m.capture_time_ns = t.capture_time_ns;
  Borrow(&m.depth, s.floats);
  Borrow(&m.colour, s.bytes);
  m.planes = planes;
  m.render_ms = t.render_ms;
  m.run_id = t.run_id;
  return s;
}

HullTile TileFromMsg(const hullpipe_msg_HullView& m) {
  const std::string who = "HullView from node " + std::to_string(m.node_id) + ": ";
  if (m.width == 0 || m.height == 0 || m.width > 8192 || m.height > 8192 || m.x > 8192 || m.y > 8192)
    throw MessageError(who + "tile rectangle out of range");
  const uint64_t n = uint64_t(m.width) * m.height;
  if (m.depth._length != n || m.colour._length != n * 3)
    throw MessageError(who + "depth/colour lengths " + std::to_string(m.depth._length) + "/" +
                       std::to_string(m.colour._length) + " do not match the " + std::to_string(m.width) +
                       "x" + std::to_string(m.height) + " tile");
  if (m.tile_count == 0 || m.tile_index >= m.tile_count) throw MessageError(who + "bad tile index");
  HullTile t;
  t.rect = cv::Rect(int(m.x), int(m.y), int(m.width), int(m.height));
  t.depth = cv::Mat(int(m.height), int(m.width), CV_32FC1, m.depth._buffer).clone();
  t.colour = cv::Mat(int(m.height), int(m.width), CV_8UC3, m.colour._buffer).clone();
  t.node_id = m.node_id;
  t.tile_index = m.tile_index;
  t.tile_count = m.tile_count;
  t.pose_seq = m.pose_seq;
  t.frame_seq = m.frame_seq;
  t.capture_time_ns = m.capture_time_ns;
  t.render_ms = m.render_ms;
  t.run_id = m.run_id;
  // 0 (no hull on the wire), and anything not a positive finite depth from a bad
  // sender, becomes kNoDepth (+inf) inside, where depth tests take the minimum.
  for (int r = 0; r < t.depth.rows; ++r) {
    float* row = t.depth.ptr<float>(r);
    for (int c = 0; c < t.depth.cols; ++c)
      if (!std::isfinite(row[c]) || !(row[c] > 0)) row[c] = std::numeric_limits<float>::infinity();
  }
  return t;
}

namespace {
constexpr size_t kMaxMeshVertices = 200000;

// A scene element's key (VirtualMesh.element): [a-z0-9_], 1 to 32 characters.
bool IsElementKey(const std::string& key) {
  if (key.empty() || key.size() > kMaxElementKeyChars) return false;
  for (const char c : key)
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  return true;
}
}  // namespace

OwnedSample<hullpipe_msg_VirtualMesh> MakeVirtualMeshMessage(const VirtualMeshSample& mesh) {
  const VirtualMeshDraw& d = mesh.draw;
  const size_t items = d.triangles.empty() ? d.vertices.size() : d.triangles.size();
  if (d.vertices.size() > kMaxMeshVertices) throw MessageError("VirtualMesh: more than 200000 vertices");
  if (!d.colliding.empty() && d.colliding.size() != items)
    throw MessageError("VirtualMesh: colliding must have one flag per triangle (or per point)");
  if (!IsElementKey(mesh.element))
    throw MessageError("VirtualMesh: element '" + mesh.element.substr(0, 40) + "' is not a scene element's key");
  OwnedSample<hullpipe_msg_VirtualMesh> s;
  s.strings.reserve(1);
  s.strings.push_back(mesh.element);
  s.floats.reserve(d.vertices.size() * 3);
  for (const auto& v : d.vertices)
    for (int k = 0; k < 3; ++k) s.floats.push_back(float(v[k]));
  s.words.reserve(d.triangles.size() * 3);
  for (const auto& t : d.triangles)
    for (int k = 0; k < 3; ++k) s.words.push_back(uint32_t(t[k]));
  s.bytes.assign(d.colliding.begin(), d.colliding.end());
  auto& m = s.msg;
  m.object_id = mesh.object_id;
  m.frame_seq = mesh.frame_seq;
  m.capture_time_ns = mesh.capture_time_ns;
  m.kind = mesh.kind;
  Borrow(&m.vertices, s.floats);
  Borrow(&m.triangles, s.words);
  Borrow(&m.colliding, s.bytes);
  m.point_radius = d.point_radius;
  for (int k = 0; k < 3; ++k) m.colour[k] = d.colour[k];
  m.clearance = mesh.clearance;
  m.element = const_cast<char*>(s.strings[0].c_str());
  return s;
}

VirtualMeshSample VirtualMeshFromMsg(const hullpipe_msg_VirtualMesh& m) {
  const std::string who = "VirtualMesh " + std::to_string(m.object_id) + ": ";
  if (m.kind != hullpipe_msg_MESH_KIND_CLOTH && m.kind != hullpipe_msg_MESH_KIND_PARTICLES &&
      m.kind != hullpipe_msg_MESH_KIND_PART)
    throw MessageError(who + "unknown kind " + std::to_string(m.kind));
  if (m.vertices._length % 3 != 0 || m.vertices._length / 3 > kMaxMeshVertices)
    throw MessageError(who + "vertex floats " + std::to_string(m.vertices._length) +
                       " not a multiple of 3 or too many");
  if (m.triangles._length % 3 != 0) throw MessageError(who + "triangle indices not a multiple of 3");
  const size_t nv = m.vertices._length / 3, nt = m.triangles._length / 3;
  const size_t items = nt ? nt : nv;
  if (m.colliding._length != 0 && m.colliding._length != items)
    throw MessageError(who + "colliding has " + std::to_string(m.colliding._length) + " flags for " +
                       std::to_string(items) + " items");
  if (!std::isfinite(m.point_radius) || m.point_radius < 0 || m.point_radius > 1)
    throw MessageError(who + "point_radius out of range");
  std::string element = m.element ? std::string(m.element, strnlen(m.element, kMaxElementKeyChars + 1)) : "";
  if (element.empty()) element = "unnamed";  // a recording from before meshes named their element
  if (!IsElementKey(element)) throw MessageError(who + "element is not a scene element's key ([a-z0-9_], 1 to 32)");
  VirtualMeshSample out;
  out.element = element;
  out.object_id = m.object_id;
  out.kind = m.kind;
  out.frame_seq = m.frame_seq;
  out.capture_time_ns = m.capture_time_ns;
  out.clearance = std::isfinite(m.clearance) ? m.clearance : -1;
  auto& d = out.draw;
  d.vertices.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    const float* v = m.vertices._buffer + 3 * i;
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      throw MessageError(who + "vertex " + std::to_string(i) + " not finite");
    d.vertices[i] = Eigen::Vector3d(v[0], v[1], v[2]);
  }
  d.triangles.resize(nt);
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* ix = m.triangles._buffer + 3 * t;
    if (ix[0] >= nv || ix[1] >= nv || ix[2] >= nv)
      throw MessageError(who + "triangle " + std::to_string(t) + " indexes past the vertices");
    d.triangles[t] = Eigen::Vector3i(int(ix[0]), int(ix[1]), int(ix[2]));
  }
  d.colliding.assign(m.colliding._buffer, m.colliding._buffer + m.colliding._length);
  d.point_radius = m.point_radius;
  d.colour = cv::Vec3b(m.colour[0], m.colour[1], m.colour[2]);
  return out;
}

namespace {
// A pose as the messages carry it: rotation row-major, translation.
void PoseToArrays(const Rigid3d& X, double rotation[9], double translation[3]) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rotation[3 * r + c] = X.rotation(r, c);
    translation[r] = X.translation[r];
  }
}
// The pose of those arrays, checked: finite, the rotation orthonormal with
// det +1 to 1e-6. Throws MessageError starting with `who`.
Rigid3d PoseFromArrays(const double rotation[9], const double translation[3], const std::string& who) {
  Rigid3d X;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) X.rotation(r, c) = rotation[3 * r + c];
    X.translation[r] = translation[r];
  }
  if (!X.rotation.allFinite() || !X.translation.allFinite()) throw MessageError(who + "not finite");
  if (!IsRotation(X.rotation)) throw MessageError(who + "rotation not orthonormal");
  return X;
}
}  // namespace

hullpipe_msg_HeadPose HeadPoseToMsg(const Rigid3d& X, uint32_t tracker_id, int64_t stamp_ns) {
  hullpipe_msg_HeadPose m{};
  m.tracker_id = tracker_id;
  m.stamp_ns = stamp_ns;
  PoseToArrays(X, m.world_from_eye_rotation, m.world_from_eye_translation);
  return m;
}

Rigid3d HeadPoseFromMsg(const hullpipe_msg_HeadPose& m) {
  return PoseFromArrays(m.world_from_eye_rotation, m.world_from_eye_translation,
                        "HeadPose from tracker " + std::to_string(m.tracker_id) + ": ");
}

hullpipe_msg_EyeViews EyeViewsToMsg(const EyeViewsSample& v) {
  hullpipe_msg_EyeViews m{};
  m.tracker_id = v.tracker_id;
  m.stamp_ns = v.stamp_ns;
  for (int k = 0; k < 2; ++k) {
    hullpipe_msg_EyeView& e = m.eyes[k];
    const Eigen::Vector4d q = XrOrientationOf(v.world_from_eye[size_t(k)]);
    for (int i = 0; i < 3; ++i) e.position[i] = v.world_from_eye[size_t(k)].translation[i];
    for (int i = 0; i < 4; ++i) e.orientation[i] = q[i];
    const EyeFov& f = v.fov[size_t(k)];
    e.fov[0] = f.left, e.fov[1] = f.right, e.fov[2] = f.up, e.fov[3] = f.down;
  }
  return m;
}

EyeViewsSample EyeViewsFromMsg(const hullpipe_msg_EyeViews& m) {
  EyeViewsSample v;
  v.tracker_id = m.tracker_id;
  v.stamp_ns = m.stamp_ns;
  for (int k = 0; k < 2; ++k) {
    const hullpipe_msg_EyeView& e = m.eyes[k];
    const std::string who =
        "EyeViews from tracker " + std::to_string(m.tracker_id) + ", " + (k == 0 ? "left" : "right") + " eye: ";
    try {
      v.world_from_eye[size_t(k)] =
          EyePoseFromXr(Eigen::Vector3d(e.position[0], e.position[1], e.position[2]),
                        Eigen::Vector4d(e.orientation[0], e.orientation[1], e.orientation[2], e.orientation[3]));
      v.fov[size_t(k)] = EyeFov{e.fov[0], e.fov[1], e.fov[2], e.fov[3]};
      v.fov[size_t(k)].Check();
    } catch (const std::invalid_argument& err) {
      throw MessageError(who + err.what());
    }
  }
  return v;
}

hullpipe_msg_CameraPose CameraPoseToMsg(const Rigid3d& X, uint32_t camera_id, int64_t stamp_ns) {
  hullpipe_msg_CameraPose m{};
  m.camera_id = camera_id;
  m.stamp_ns = stamp_ns;
  PoseToArrays(X, m.world_from_camera_rotation, m.world_from_camera_translation);
  return m;
}

Rigid3d CameraPoseFromMsg(const hullpipe_msg_CameraPose& m) {
  return PoseFromArrays(m.world_from_camera_rotation, m.world_from_camera_translation,
                        "CameraPose of camera " + std::to_string(m.camera_id) + ": ");
}

static_assert(kMeshCloth == hullpipe_msg_MESH_KIND_CLOTH && kMeshParticles == hullpipe_msg_MESH_KIND_PARTICLES &&
              kMeshPart == hullpipe_msg_MESH_KIND_PART);

hullpipe_msg_VirtualObjectState VirtualObjectToMsg(const VirtualObjectSample& v) {
  hullpipe_msg_VirtualObjectState s{};
  s.object_id = v.object_id;
  s.frame_seq = v.frame_seq;
  s.capture_time_ns = v.capture_time_ns;
  s.sim_time = v.sim_time;
  s.shape = uint8_t(v.shape);
  s.radius = v.radius;
  s.half_extents = ToMsg(v.half_extents);
  s.position = ToMsg(v.position);
  s.velocity = ToMsg(v.velocity);
  const Eigen::Quaterniond q = v.orientation.normalized();
  s.orientation[0] = q.w(), s.orientation[1] = q.x(), s.orientation[2] = q.y(), s.orientation[3] = q.z();
  s.colliding = v.colliding;
  return s;
}

VirtualObjectSample VirtualObjectFromMsg(const hullpipe_msg_VirtualObjectState& m) {
  VirtualObjectSample v;
  v.object_id = m.object_id;
  v.frame_seq = m.frame_seq;
  v.capture_time_ns = m.capture_time_ns;
  v.sim_time = m.sim_time;
  v.radius = m.radius;
  v.half_extents = FromMsg(m.half_extents);
  v.position = FromMsg(m.position);
  v.velocity = FromMsg(m.velocity);
  v.colliding = m.colliding;
  const std::string who = "VirtualObjectState " + std::to_string(m.object_id) + ": ";
  if (m.shape != hullpipe_msg_SHAPE_SPHERE && m.shape != hullpipe_msg_SHAPE_BOX)
    throw MessageError(who + "unknown shape " + std::to_string(m.shape));
  v.shape = VirtualObjectSample::Shape(m.shape);
  if (!v.position.allFinite() || !v.velocity.allFinite() || !std::isfinite(v.radius) || v.radius < 0)
    throw MessageError(who + "position, velocity and radius must be finite (radius >= 0)");
  // Drawn sizes: at most 100 m (kMaxStatedExtentM's order), a box's positive.
  if (v.radius > 100 || !v.half_extents.allFinite() || v.half_extents.maxCoeff() > 100 ||
      (v.shape == VirtualObjectSample::Shape::kBox && !(v.half_extents.minCoeff() > 0)))
    throw MessageError(who + "radius and half_extents must be at most 100 m (a box's half_extents > 0)");
  const Eigen::Quaterniond q(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]);
  if (!q.coeffs().allFinite() || !(std::abs(q.norm() - 1) < 1e-6))
    throw MessageError(who + "orientation must be a unit quaternion");
  v.orientation = q.normalized();
  return v;
}

OwnedSample<hullpipe_msg_CollisionReport> MakeCollisionReportMessage(const CollisionReportSample& r) {
  OwnedSample<hullpipe_msg_CollisionReport> o;
  o.words = r.triangle_ids;
  for (const auto& p : r.collision_points) o.vec3s.push_back(ToMsg(p));
  auto& m = o.msg;
  m.object_id = r.object_id;
  m.frame_seq = r.frame_seq;
  m.capture_time_ns = r.capture_time_ns;
  Borrow(&m.triangle_ids, o.words);
  Borrow(&m.collision_points, o.vec3s);
  m.has_response = r.has_response;
  if (r.has_response) {
    m.cp_obj = ToMsg(r.cp_obj);
    m.cp_hull = ToMsg(r.cp_hull);
    m.v_rec = ToMsg(r.v_rec);
    m.d_rec = r.d_rec;
    m.n_hull = ToMsg(r.n_hull);
    m.hull_velocity_status = r.hull_velocity_status;
    m.hull_normal_speed = r.hull_normal_speed;
    m.hull_velocity_interval = r.hull_velocity_interval;
  }
  return o;
}

CollisionReportSample CollisionReportFromMsg(const hullpipe_msg_CollisionReport& m) {
  const std::string who = "CollisionReport " + std::to_string(m.object_id) + ": ";
  if (m.triangle_ids._length > kMaxReportEntries || m.collision_points._length > kMaxReportEntries)
    throw MessageError(who + "more than " + std::to_string(kMaxReportEntries) + " triangle_ids or collision_points");
  CollisionReportSample r;
  r.object_id = m.object_id;
  r.frame_seq = m.frame_seq;
  r.capture_time_ns = m.capture_time_ns;
  r.triangle_ids.assign(m.triangle_ids._buffer, m.triangle_ids._buffer + m.triangle_ids._length);
  r.collision_points.reserve(m.collision_points._length);
  for (uint32_t i = 0; i < m.collision_points._length; ++i) {
    r.collision_points.push_back(FromMsg(m.collision_points._buffer[i]));
    if (!r.collision_points.back().allFinite()) throw MessageError(who + "collision_points must be finite");
  }
  r.has_response = m.has_response;
  if (!m.has_response) return r;
  r.cp_obj = FromMsg(m.cp_obj);
  r.cp_hull = FromMsg(m.cp_hull);
  r.v_rec = FromMsg(m.v_rec);
  r.n_hull = FromMsg(m.n_hull);
  r.d_rec = m.d_rec;
  if (!r.cp_obj.allFinite() || !r.cp_hull.allFinite() || !r.v_rec.allFinite() || !r.n_hull.allFinite() ||
      !std::isfinite(r.d_rec))
    throw MessageError(who + "cp_obj, cp_hull, v_rec, n_hull and d_rec must be finite");
  if (m.hull_velocity_status > hullpipe_msg_HULL_VELOCITY_APPEARED)
    throw MessageError(who + "hull_velocity_status must be a HULL_VELOCITY_* value");
  if (!std::isfinite(m.hull_normal_speed) || !std::isfinite(m.hull_velocity_interval))
    throw MessageError(who + "hull_normal_speed and hull_velocity_interval must be finite");
  r.hull_velocity_status = m.hull_velocity_status;
  r.hull_normal_speed = m.hull_normal_speed;
  r.hull_velocity_interval = m.hull_velocity_interval;
  return r;
}

}  // namespace hullpipe::dds

namespace hullpipe::dds {

namespace {
constexpr size_t kMaxPartVertices = 2000000;
constexpr size_t kMaxModelParts = 1000000;
}  // namespace

OwnedSample<hullpipe_msg_ModelPart> MakeModelPartMessage(const ModelPartSample& p) {
  if (p.vertices.size() > kMaxPartVertices) throw MessageError("ModelPart: more than 2000000 vertices");
  OwnedSample<hullpipe_msg_ModelPart> s;
  s.strings.reserve(2);
  s.strings.push_back(p.name);
  s.strings.push_back(p.file);
  s.floats.reserve(p.vertices.size() * 3);
  for (const auto& v : p.vertices)
    for (int k = 0; k < 3; ++k) s.floats.push_back(v[k]);
  s.words.reserve(p.triangles.size() * 3);
  for (const auto& t : p.triangles)
    for (int k = 0; k < 3; ++k) {
      if (t[k] < 0 || size_t(t[k]) >= p.vertices.size()) throw MessageError("ModelPart: index out of range");
      s.words.push_back(uint32_t(t[k]));
    }
  auto& m = s.msg;
  m.object_id = p.object_id;
  m.model_id = p.model_id;
  m.part_index = p.part_index;
  m.part_count = p.part_count;
  m.name = const_cast<char*>(s.strings[0].c_str());
  m.file = const_cast<char*>(s.strings[1].c_str());
  Borrow(&m.vertices, s.floats);
  Borrow(&m.triangles, s.words);
  for (int k = 0; k < 3; ++k) m.colour[k] = p.colour[k];
  return s;
}

ModelPartSample ModelPartFromMsg(const hullpipe_msg_ModelPart& m) {
  const std::string who = "ModelPart " + std::to_string(m.object_id) + ": ";
  if (m.part_count == 0 || m.part_index >= m.part_count) throw MessageError(who + "part_index past part_count");
  if (uint64_t(m.model_id) + m.part_index != m.object_id)
    throw MessageError(who + "object_id is not model_id + part_index");
  if (m.vertices._length % 3 != 0 || m.vertices._length / 3 > kMaxPartVertices)
    throw MessageError(who + "vertex floats not a multiple of 3 or too many");
  if (m.triangles._length % 3 != 0) throw MessageError(who + "triangle indices not a multiple of 3");
  ModelPartSample p;
  p.object_id = m.object_id;
  p.model_id = m.model_id;
  p.part_index = m.part_index;
  p.part_count = m.part_count;
  p.name = m.name ? m.name : "";
  p.file = m.file ? m.file : "";
  const size_t nv = m.vertices._length / 3, nt = m.triangles._length / 3;
  p.vertices.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    const float* v = m.vertices._buffer + 3 * i;
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2]))
      throw MessageError(who + "vertex " + std::to_string(i) + " not finite");
    p.vertices[i] = Eigen::Vector3f(v[0], v[1], v[2]);
  }
  p.triangles.resize(nt);
  for (size_t t = 0; t < nt; ++t) {
    const uint32_t* ix = m.triangles._buffer + 3 * t;
    if (ix[0] >= nv || ix[1] >= nv || ix[2] >= nv)
      throw MessageError(who + "triangle " + std::to_string(t) + " indexes past the vertices");
    p.triangles[t] = Eigen::Vector3i(int(ix[0]), int(ix[1]), int(ix[2]));
  }
  p.colour = cv::Vec3b(m.colour[0], m.colour[1], m.colour[2]);
  return p;
}

OwnedSample<hullpipe_msg_ModelState> MakeModelStateMessage(const ModelStateSample& st) {
  OwnedSample<hullpipe_msg_ModelState> s;
  s.part_states.reserve(st.parts.size());
  for (const auto& p : st.parts) {
    hullpipe_msg_PartState q{};
    q.position = ToMsg(p.position);
    for (int k = 0; k < 4; ++k) q.orientation[k] = p.orientation[k];
    q.contact = p.contact;
    q.clearance = p.clearance;
    s.part_states.push_back(q);
  }
  auto& m = s.msg;
  m.model_id = st.model_id;
  m.frame_seq = st.frame_seq;
  m.capture_time_ns = st.capture_time_ns;
  m.triangles = st.triangles;
  m.boxes_tested = st.boxes_tested;
  m.triangles_queried = st.triangles_queried;
  m.query_ms = st.query_ms;
  Borrow(&m.parts, s.part_states);
  return s;
}

ModelStateSample ModelStateFromMsg(const hullpipe_msg_ModelState& m) {
  const std::string who = "ModelState " + std::to_string(m.model_id) + ": ";
  if (m.parts._length > kMaxModelParts) throw MessageError(who + "too many parts");
  if (!std::isfinite(m.query_ms) || m.query_ms < 0) throw MessageError(who + "query_ms not a finite time");
  ModelStateSample st;
  st.model_id = m.model_id;
  st.frame_seq = m.frame_seq;
  st.capture_time_ns = m.capture_time_ns;
  st.triangles = m.triangles;
  st.boxes_tested = m.boxes_tested;
  st.triangles_queried = m.triangles_queried;
  st.query_ms = m.query_ms;
  st.parts.resize(m.parts._length);
  for (size_t k = 0; k < st.parts.size(); ++k) {
    const hullpipe_msg_PartState& q = m.parts._buffer[k];
    PartStateSample& p = st.parts[k];
    p.position = FromMsg(q.position);
    p.orientation = Eigen::Vector4d(q.orientation[0], q.orientation[1], q.orientation[2], q.orientation[3]);
    if (!p.position.allFinite() || !p.orientation.allFinite() || std::abs(p.orientation.norm() - 1) > 1e-6)
      throw MessageError(who + "part " + std::to_string(k) + " pose not finite or its quaternion not unit");
    if (q.contact > hullpipe_msg_PART_CONTACT_COLLIDING)
      throw MessageError(who + "part " + std::to_string(k) + " has unknown contact " + std::to_string(q.contact));
    p.contact = q.contact;
    p.clearance = std::isfinite(q.clearance) ? q.clearance : -1;
  }
  return st;
}

}  // namespace hullpipe::dds
