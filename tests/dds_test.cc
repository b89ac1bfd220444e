// Message conversion and validation, and Cyclone DDS behaviour hullpipe relies on.
#include <limits>
#include <set>
#include <thread>

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>

#include <Eigen/Geometry>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hullpipe/geometry/conventions.h"
#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/dds.h"
#include "hullpipe/dds/frameset_input.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/evaluation/synthetic.h"
#include "test_util.h"

namespace hullpipe::dds {
namespace {

Camera TestCamera() {
  return RingCameras(1, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{-0.2, 0.05, 0.001, 0.002, -0.01})[0];
}

TEST(Convert, CameraInfoRoundTrip) {
  Camera c = TestCamera();
  c.skew = -1.47;  // K[1] on the wire
  Aabb ws;
  ws.min = Eigen::Vector3d(-1, -2, -3);
  ws.max = Eigen::Vector3d(1, 2, 0);
  Aabb back_ws;
  const Camera back = CameraFromMsg(CameraToMsg(c, ws), &back_ws);
  EXPECT_EQ(back.id, c.id);
  EXPECT_EQ(back.K(), c.K());
  EXPECT_EQ(back.skew, -1.47);
  EXPECT_EQ(back.distortion, c.distortion);
  EXPECT_EQ(back.cam_from_world.rotation, c.cam_from_world.rotation);
  EXPECT_EQ(back_ws.max, ws.max);
}

TEST(Convert, BadCameraInfoIsRejected) {
  auto m = CameraToMsg(TestCamera(), {});
  m.K[0] = std::nan("");
  EXPECT_THROW(CameraFromMsg(m), MessageError);
  m = CameraToMsg(TestCamera(), {});
  m.width = 0;
  EXPECT_THROW(CameraFromMsg(m), MessageError);
  m = CameraToMsg(TestCamera(), {});
  m.cam_from_world_rotation[0] = 3;  // not a rotation
  EXPECT_THROW(CameraFromMsg(m), MessageError);
  m = CameraToMsg(TestCamera(), {});
  m.K[1] = 2 * m.K[0];  // a skew larger than fx
  EXPECT_THROW(CameraFromMsg(m), MessageError);
}

TEST(Convert, MapRoundTripAndWrongSize) {
  cv::Mat map(48, 64, CV_8UC1, cv::Scalar(0));
  cv::circle(map, {20, 20}, 9, 255, cv::FILLED);
  auto s = MakeMapMessage({3, 42, 1234, 0.5}, 4, map);
  EXPECT_EQ(s.msg.frame_seq, 42u);
  EXPECT_DOUBLE_EQ(s.msg.source_time, 0.5);
  EXPECT_EQ(cv::countNonZero(MapFromMsg(s.msg) != map), 0);
  s.msg.width = 65;  // runs no longer sum to the size
  EXPECT_THROW(MapFromMsg(s.msg), MessageError);
  s.msg.width = 64;
  s.msg.encoding = 9;
  EXPECT_THROW(MapFromMsg(s.msg), MessageError);
  s.msg.encoding = hullpipe_msg_MAP_ENCODING_RLE;
  s.msg.width = 0xFFFFFFFFu;  // absurd size
  EXPECT_THROW(MapFromMsg(s.msg), MessageError);
}

TEST(Convert, ImagesRawAndJpeg) {
  cv::Mat img(30, 40, CV_8UC3, cv::Scalar(10, 120, 240));
  auto raw = MakeImageMessage(1, 1, 1, img, 0);
  EXPECT_EQ(cv::norm(ImageFromMsg(raw.msg), img, cv::NORM_INF), 0);
  auto jpg = MakeImageMessage(1, 1, 1, img, 90);
  EXPECT_LT(jpg.msg.data._length, raw.msg.data._length);
  EXPECT_LE(cv::norm(ImageFromMsg(jpg.msg), img, cv::NORM_INF), 8);  // JPEG loss on a flat colour
  raw.msg.data._length -= 1;
  EXPECT_THROW(ImageFromMsg(raw.msg), MessageError);
  jpg.msg.data._length = 10;  // truncated JPEG
  EXPECT_THROW(ImageFromMsg(jpg.msg), MessageError);
  // Data marked JPEG that is a PNG, or DICOM (which OpenCV hands to GDCM,
  // whose parser aborts on a bad element: fuzz_wire_samples found it), is
  // refused before any decoder sees it; so is a JPEG of another size.
  for (const std::string ext : {".png", ".jpg"}) {
    std::vector<uint8_t> bytes;
    cv::imencode(ext, ext == ".png" ? img : cv::Mat(img, cv::Rect(0, 0, 20, 30)), bytes);
    auto s = MakeImageMessage(1, 1, 1, img, 90);
    s.bytes = bytes;
    s.msg.data._buffer = s.bytes.data();
    s.msg.data._length = uint32_t(s.bytes.size());
    try {
      ImageFromMsg(s.msg);
      ADD_FAILURE() << ext;
    } catch (const MessageError& e) {
      EXPECT_NE(std::string(e.what()).find("not a JPEG of the stated size 40x30"), std::string::npos) << e.what();
    }
  }
  std::vector<uint8_t> dicom(128, 0);
  for (char c : std::string("DICM\x02\x00\x00\x00UL\x04\x00\xff\xff\xff\x7f", 16)) dicom.push_back(uint8_t(c));
  dicom.resize(300, 0xd9);
  jpg.msg.data._buffer = dicom.data();
  jpg.msg.data._length = uint32_t(dicom.size());
  EXPECT_THROW(ImageFromMsg(jpg.msg), MessageError);
}

// capture_node --image-region: an image sent only around its object pixels
// arrives as its whole image, the region's pixels at their place and black
// elsewhere; an empty region sends nothing; a region of the whole image goes
// as the whole image. A region that lies about its place is refused.
TEST(Convert, AnImageRegionArrivesInItsWholeImage) {
  // A gradient, so that a region put one pixel off would differ.
  cv::Mat img(30, 40, CV_8UC3);
  for (int r = 0; r < img.rows; ++r)
    for (int c = 0; c < img.cols; ++c) img.at<cv::Vec3b>(r, c) = cv::Vec3b(uint8_t(6 * c), uint8_t(8 * r), 77);
  const cv::Rect part(7, 5, 13, 11);
  cv::Mat expected(img.size(), CV_8UC3, cv::Scalar::all(0));
  img(part).copyTo(expected(part));
  for (const int quality : {0, 95}) {
    SCOPED_TRACE(quality);
    auto s = MakeImageMessage(3, 1, 1, img, quality, part);
    EXPECT_TRUE(ImageHasRegion(s.msg));
    EXPECT_EQ(s.msg.x, 7u);
    EXPECT_EQ(s.msg.y, 5u);
    EXPECT_EQ(s.msg.width, 13u);
    EXPECT_EQ(s.msg.height, 11u);
    EXPECT_EQ(s.msg.full_width, 40u);
    EXPECT_EQ(s.msg.full_height, 30u);
    const cv::Mat back = ImageFromMsg(s.msg);
    ASSERT_EQ(back.size(), img.size());
    cv::Mat outside = back.clone();
    outside(part).setTo(cv::Scalar::all(0));
    EXPECT_EQ(cv::countNonZero(outside.reshape(1)), 0) << "black outside the region";
    // Raw: exact; JPEG: its loss on a gradient of 6-8 levels a pixel.
    EXPECT_LE(cv::norm(back(part), img(part), cv::NORM_INF), quality ? 24 : 0);
    if (!quality) {
      EXPECT_EQ(cv::norm(back, expected, cv::NORM_INF), 0);
    }
  }
  // A region past the image is clipped to it; one of the whole image is none.
  const auto clipped = MakeImageMessage(3, 1, 1, img, 0, cv::Rect(30, 20, 50, 50));
  EXPECT_EQ(clipped.msg.width, 10u);
  EXPECT_EQ(clipped.msg.height, 10u);
  const auto whole = MakeImageMessage(3, 1, 1, img, 0, cv::Rect(-5, -5, 100, 100));
  EXPECT_FALSE(ImageHasRegion(whole.msg));
  EXPECT_EQ(cv::norm(ImageFromMsg(whole.msg), img, cv::NORM_INF), 0);
  // No object pixels: no data, a black image of the whole size.
  for (const int quality : {0, 90}) {
    const auto none = MakeImageMessage(3, 1, 1, img, quality, cv::Rect());
    EXPECT_TRUE(ImageHasRegion(none.msg));
    EXPECT_EQ(none.msg.data._length, 0u);
    const cv::Mat black = ImageFromMsg(none.msg);
    ASSERT_EQ(black.size(), img.size());
    EXPECT_EQ(cv::countNonZero(black.reshape(1)), 0);
  }
  // Lies: a region past its whole image, a whole image of one side or of an
  // absurd size, an empty region with data.
  const auto refused = [&](auto&& change, const std::string& says) {
    auto s = MakeImageMessage(3, 1, 1, img, 0, part);
    change(s.msg);
    try {
      ImageFromMsg(s.msg);
      ADD_FAILURE() << says;
    } catch (const MessageError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  refused([](auto& m) { m.x = 30; }, "region 13x11 at (30, 5) is not within the whole image 40x30");
  refused([](auto& m) { m.y = 0xFFFFFFF0u; }, "is not within the whole image");
  refused([](auto& m) { m.full_height = 0; }, "whole image size 40x0 out of range");
  refused([](auto& m) { m.full_width = m.full_height = 1u << 20; }, "out of range");
  refused([](auto& m) { m.width = m.height = 0; }, "an empty region (0x0) with");
  refused([](auto& m) { m.height = 0; }, "an empty region (13x0) with");
}

// render_node's composited frame for viewers: scaled down to the publishing
// bound with its aspect kept, a JPEG of the stated size, and refused when it
// lies (another format, another size, larger than its view).
TEST(Convert, CompositedViewIsAJpegScaledToTheBound) {
  // A left/right split so that a mirrored or transposed image would fail.
  cv::Mat frame(240, 320, CV_8UC3, cv::Scalar(200, 30, 30));
  frame(cv::Rect(160, 0, 160, 240)).setTo(cv::Scalar(30, 200, 30));
  const auto same = MakeCompositedViewMessage(frame, 7, 42, 1'000'000'000, 99, {1280, 90});
  EXPECT_EQ(same.msg.pose_seq, 7u);
  EXPECT_EQ(same.msg.frame_seq, 42u);
  EXPECT_EQ(same.msg.run_id, 99u);
  EXPECT_EQ(same.msg.width, 320u);
  EXPECT_EQ(same.msg.view_width, 320u);
  const cv::Mat back = CompositedViewFromMsg(same.msg);
  ASSERT_EQ(back.size(), frame.size());
  // JPEG loss away from the colour edge (8x8 blocks, 4:2:0 chroma): a few levels.
  EXPECT_LE(cv::norm(back(cv::Rect(0, 0, 140, 240)), frame(cv::Rect(0, 0, 140, 240)), cv::NORM_INF), 12);
  EXPECT_LE(cv::norm(back(cv::Rect(180, 0, 140, 240)), frame(cv::Rect(180, 0, 140, 240)), cv::NORM_INF), 12);

  // 320x240 at a bound of 100: 100x75, the view's size kept beside it.
  const auto small = MakeCompositedViewMessage(frame, 7, 42, 1, 99, {100, 90});
  EXPECT_EQ(small.msg.width, 100u);
  EXPECT_EQ(small.msg.height, 75u);
  EXPECT_EQ(small.msg.view_width, 320u);
  EXPECT_EQ(small.msg.view_height, 240u);
  const cv::Mat shrunk = CompositedViewFromMsg(small.msg);
  ASSERT_EQ(shrunk.size(), cv::Size(100, 75));
  EXPECT_LE(cv::norm(shrunk.at<cv::Vec3b>(37, 10), cv::Vec3b(200, 30, 30), cv::NORM_INF), 12);
  EXPECT_LE(cv::norm(shrunk.at<cv::Vec3b>(37, 90), cv::Vec3b(30, 200, 30), cv::NORM_INF), 12);

  EXPECT_THROW(MakeCompositedViewMessage(cv::Mat(), 1, 1, 1, 1, {1280, 90}), MessageError);
  EXPECT_THROW(MakeCompositedViewMessage(frame, 1, 1, 1, 1, {8, 90}), MessageError);
  EXPECT_THROW(MakeCompositedViewMessage(frame, 1, 1, 1, 1, {1280, 0}), MessageError);

  auto lie = MakeCompositedViewMessage(frame, 1, 1, 1, 1, {1280, 90});
  lie.msg.width = 321;  // the JPEG says 320
  EXPECT_THROW(CheckCompositedViewMsg(lie.msg), MessageError);
  lie.msg.width = 320, lie.msg.view_width = 160;  // an image larger than its view
  EXPECT_THROW(CheckCompositedViewMsg(lie.msg), MessageError);
  lie.msg.view_width = 320;
  std::vector<uint8_t> png;
  cv::imencode(".png", frame, png);
  lie.msg.data._buffer = png.data();
  lie.msg.data._length = uint32_t(png.size());
  try {
    CheckCompositedViewMsg(lie.msg);
    ADD_FAILURE() << "a PNG marked JPEG was accepted";
  } catch (const MessageError& e) {
    EXPECT_NE(std::string(e.what()).find("not a JPEG of the stated size 320x240"), std::string::npos) << e.what();
  }
  lie.msg.data._length = 0;
  EXPECT_THROW(CompositedViewFromMsg(lie.msg), MessageError);

  // Each eye of a headset's pair says which it is; an eye that is none is refused.
  EXPECT_EQ(same.msg.eye, hullpipe_msg_VIEW_EYE_MONO);
  auto right = MakeCompositedViewMessage(frame, 8, 42, 1, 99, {1280, 90}, ViewEye::kRight);
  EXPECT_EQ(right.msg.eye, hullpipe_msg_VIEW_EYE_RIGHT);
  EXPECT_NO_THROW(CheckCompositedViewMsg(right.msg));
  right.msg.eye = 255;
  try {
    CheckCompositedViewMsg(right.msg);
    ADD_FAILURE() << "eye 255 accepted";
  } catch (const MessageError& e) {
    EXPECT_NE(std::string(e.what()).find("eye 255 is none of"), std::string::npos) << e.what();
  }
}

TEST(Convert, ViewAndTile) {
  const NovelView v = NovelView::FromFov(32, 24, 1.0, LookAt({1, 2, 3}, {0, 0, 0}, {0, 0, -1}));
  const NovelView back = ViewFromMsg(ViewToMsg(v, 5, 6, 7));
  EXPECT_EQ(back.width, 32);
  EXPECT_EQ(back.world_from_eye.rotation, v.world_from_eye.rotation);
  auto bad = ViewToMsg(v, 5, 6, 7);
  bad.world_from_eye_rotation[4] = 5;
  EXPECT_THROW(ViewFromMsg(bad), MessageError);
  // The eye: the one view unless given, and only VIEW_EYE_*.
  EXPECT_EQ(ViewToMsg(v, 5, 6, 7).eye, hullpipe_msg_VIEW_EYE_MONO);
  EXPECT_EQ(ViewToMsg(v, 5, 6, 7, 0, ViewEye::kRight).eye, hullpipe_msg_VIEW_EYE_RIGHT);
  auto bad_eye = ViewToMsg(v, 5, 6, 7, 0, ViewEye::kLeft);
  EXPECT_NO_THROW(ViewFromMsg(bad_eye));
  bad_eye.eye = 3;
  try {
    ViewFromMsg(bad_eye);
    ADD_FAILURE() << "eye 3 accepted";
  } catch (const MessageError& e) {
    EXPECT_NE(std::string(e.what()).find("ViewPose 5: eye 3 is none of"), std::string::npos) << e.what();
  }

  HullTile t;
  t.rect = {0, 12, 32, 12};
  t.depth = cv::Mat(12, 32, CV_32FC1, cv::Scalar(kNoDepth));
  t.depth.at<float>(3, 4) = 2.5f;
  t.depth.at<float>(5, 5) = std::nanf("");
  t.colour = cv::Mat(12, 32, CV_8UC3, cv::Scalar(1, 2, 3));
  t.tile_index = 1;
  t.tile_count = 2;
  auto s = MakeHullViewMessage(t, 100);
  // On the wire: no NaN or infinity, 0 for no hull.
  for (uint32_t i = 0; i < s.msg.depth._length; ++i) ASSERT_TRUE(std::isfinite(s.msg.depth._buffer[i]));
  EXPECT_EQ(s.msg.depth._buffer[0], 0.0f);
  const HullTile tb = TileFromMsg(s.msg);
  EXPECT_TRUE(std::isinf(tb.depth.at<float>(0, 0))) << "no hull is kNoDepth inside";
  EXPECT_EQ(tb.rect, t.rect);
  EXPECT_EQ(tb.depth.at<float>(3, 4), 2.5f);
  EXPECT_TRUE(std::isinf(tb.depth.at<float>(5, 5)));  // NaN never reaches the compositor
  s.msg.colour._length -= 3;
  EXPECT_THROW(TileFromMsg(s.msg), MessageError);
}

// A state carries a sphere or a box (SHAPE_BOX: half extents and orientation);
// an unknown shape, a box with no size, a quaternion that is not unit, or an
// absurd size from outside is refused.
TEST(Convert, VirtualObjectStateCarriesSpheresAndBoxes) {
  VirtualObjectSample box;
  box.object_id = 5;
  box.shape = VirtualObjectSample::Shape::kBox;
  box.half_extents = Eigen::Vector3d(0.1, 0.2, 0.3);
  box.position = Eigen::Vector3d(1, 2, 3);
  box.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  box.colliding = true;
  hullpipe_msg_VirtualObjectState m = VirtualObjectToMsg(box);
  const VirtualObjectSample back = VirtualObjectFromMsg(m);
  EXPECT_EQ(back.shape, VirtualObjectSample::Shape::kBox);
  EXPECT_EQ(back.half_extents, box.half_extents);
  EXPECT_TRUE(back.orientation.isApprox(box.orientation, 1e-12));
  EXPECT_EQ(back.position, box.position);
  EXPECT_TRUE(back.colliding);
  VirtualObjectSample ball;
  ball.radius = 0.12;
  EXPECT_EQ(VirtualObjectFromMsg(VirtualObjectToMsg(ball)).shape, VirtualObjectSample::Shape::kSphere);
  EXPECT_EQ(VirtualObjectFromMsg(VirtualObjectToMsg(ball)).radius, 0.12);

  auto refused = [](hullpipe_msg_VirtualObjectState bad) {
    EXPECT_THROW(VirtualObjectFromMsg(bad), MessageError);
  };
  hullpipe_msg_VirtualObjectState bad = m;
  bad.shape = 9;
  refused(bad);
  bad = m;
  bad.half_extents.y = 0;
  refused(bad);
  bad = m;
  bad.half_extents.x = 1e6;
  refused(bad);
  bad = m;
  bad.orientation[0] = 2;
  refused(bad);
  bad = m;
  bad.orientation[1] = std::nan("");
  refused(bad);
  EXPECT_NO_THROW(VirtualObjectFromMsg(m));  // control
}

TEST(Convert, VirtualMeshRoundTripAndMalformed) {
  VirtualMeshSample m;
  m.object_id = 100;
  m.kind = hullpipe_msg_MESH_KIND_CLOTH;
  m.frame_seq = 9;
  m.draw.vertices = {{0, 0, -1}, {0.1, 0, -1}, {0, 0.1, -1}, {0.1, 0.1, -1}};
  m.draw.triangles = {{0, 1, 2}, {1, 3, 2}};
  m.draw.colliding = {0, 1};
  m.clearance = 0.05;
  m.element = "cloth";
  auto s = MakeVirtualMeshMessage(m);
  const VirtualMeshSample back = VirtualMeshFromMsg(s.msg);
  EXPECT_EQ(back.object_id, 100u);
  EXPECT_EQ(back.frame_seq, 9u);
  ASSERT_EQ(back.draw.vertices.size(), 4u);
  EXPECT_TRUE(back.draw.vertices[3].isApprox(m.draw.vertices[3], 1e-6));  // floats on the wire
  ASSERT_EQ(back.draw.triangles.size(), 2u);
  EXPECT_EQ(back.draw.triangles[1], Eigen::Vector3i(1, 3, 2));
  EXPECT_EQ(back.draw.colliding, m.draw.colliding);
  EXPECT_DOUBLE_EQ(back.clearance, 0.05);
  EXPECT_EQ(back.element, "cloth");
  // Malformed samples from outside are refused, never drawn.
  for (const char* bad : {"Cloth", "a b", "x123456789012345678901234567890123"}) {
    std::string text = bad;
    s.msg.element = text.data();
    EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError) << bad;
  }
  std::string empty;
  s.msg.element = empty.data();  // a recording from before elements were named
  EXPECT_EQ(VirtualMeshFromMsg(s.msg).element, "unnamed");
  m.element = "no good";
  EXPECT_THROW(MakeVirtualMeshMessage(m), MessageError);
  s.msg.element = const_cast<char*>(s.strings[0].c_str());
  ASSERT_NO_THROW(VirtualMeshFromMsg(s.msg));  // control
  s.words[5] = 7;  // index past the vertices
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
  s.words[5] = 2;
  s.msg.colliding._length = 1;  // wrong flag count
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
  s.msg.colliding._length = 2;
  s.msg.vertices._length = 11;  // not a multiple of 3
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
  s.msg.vertices._length = 12;
  s.floats[4] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
  s.floats[4] = 0;
  s.msg.kind = 77;
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
  s.msg.kind = hullpipe_msg_MESH_KIND_PARTICLES;
  s.msg.triangles._length = 0;  // points: one flag per vertex
  EXPECT_THROW(VirtualMeshFromMsg(s.msg), MessageError);
}

TEST(Convert, ModelPartAndStateRoundTripAndMalformed) {
  ModelPartSample p;
  p.object_id = 1003;
  p.model_id = 1000;
  p.part_index = 3;
  p.part_count = 5;
  p.name = "crankshaft";
  p.file = "engine.glb";
  p.vertices = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}};
  p.triangles = {{0, 1, 2}};
  p.colour = {1, 2, 3};
  auto s = MakeModelPartMessage(p);
  const ModelPartSample back = ModelPartFromMsg(s.msg);
  EXPECT_EQ(back.name, "crankshaft");
  EXPECT_EQ(back.file, "engine.glb");
  EXPECT_EQ(back.vertices, p.vertices);
  EXPECT_EQ(back.triangles, p.triangles);
  EXPECT_EQ(back.colour, p.colour);
  s.words[2] = 3;  // index past the vertices
  EXPECT_THROW(ModelPartFromMsg(s.msg), MessageError);
  s.words[2] = 2;
  s.msg.object_id = 7;  // not model_id + part_index
  EXPECT_THROW(ModelPartFromMsg(s.msg), MessageError);
  s.msg.object_id = 1003;
  s.msg.part_index = 5;  // past part_count
  EXPECT_THROW(ModelPartFromMsg(s.msg), MessageError);
  s.msg.part_index = 3;
  s.floats[1] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(ModelPartFromMsg(s.msg), MessageError);

  ModelStateSample st;
  st.model_id = 1000;
  st.frame_seq = 4;
  st.triangles = 110336;
  st.boxes_tested = 900;
  st.triangles_queried = 1200;
  st.query_ms = 5.5;
  st.parts.push_back({{0.3, 0.6, -0.4}, {1, 0, 0, 0}, kPartNear, 0.031});
  auto m = MakeModelStateMessage(st);
  const ModelStateSample sb = ModelStateFromMsg(m.msg);
  EXPECT_EQ(sb.triangles, 110336u);
  ASSERT_EQ(sb.parts.size(), 1u);
  EXPECT_EQ(sb.parts[0].contact, kPartNear);
  EXPECT_DOUBLE_EQ(sb.parts[0].clearance, 0.031);
  EXPECT_EQ(sb.parts[0].position, st.parts[0].position);
  m.part_states[0].contact = 9;
  EXPECT_THROW(ModelStateFromMsg(m.msg), MessageError);
  m.part_states[0].contact = 0;
  m.part_states[0].orientation[0] = 2;  // not a unit quaternion
  EXPECT_THROW(ModelStateFromMsg(m.msg), MessageError);
  m.part_states[0].orientation[0] = 1;
  m.msg.query_ms = -1;
  EXPECT_THROW(ModelStateFromMsg(m.msg), MessageError);
}

TEST(Convert, HeadPoseRoundTripAndBadRotation) {
  Rigid3d X;
  X.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  X.translation = Eigen::Vector3d(0.5, -1, -1.6);
  hullpipe_msg_HeadPose m = HeadPoseToMsg(X, 3, 42);
  const Rigid3d back = HeadPoseFromMsg(m);
  EXPECT_TRUE(back.rotation.isApprox(X.rotation, 1e-15));
  EXPECT_TRUE(back.translation.isApprox(X.translation, 1e-15));
  m.world_from_eye_rotation[0] = 2;  // not a rotation
  EXPECT_THROW(HeadPoseFromMsg(m), MessageError);
  m = HeadPoseToMsg(X, 3, 42);
  m.world_from_eye_translation[1] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(HeadPoseFromMsg(m), MessageError);
}

// An HMD runtime's two views travel as XrPosefs (OpenXR's view axes) and come
// back in OpenCV's eye axes, each eye's pose and fov as sent; a runtime's
// unnormalised quaternion is normalised; a zero quaternion, a value not finite
// or a bad fov is refused naming the eye.
TEST(Convert, EyeViewsRoundTripInOpenXrsAxesAndBadViews) {
  EyeViewsSample v;
  v.tracker_id = 7, v.stamp_ns = 123;
  Rigid3d head;
  head.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  head.translation = Eigen::Vector3d(1, 2, -1.6);
  const StereoViews s = MakeStereoViews(head, StereoOptions{});
  v.world_from_eye = {s.eye[0].world_from_eye, s.eye[1].world_from_eye};
  v.fov = {EyeFov{-0.8, 0.6, 0.7, -0.9}, EyeFov{-0.6, 0.8, 0.7, -0.9}};
  hullpipe_msg_EyeViews m = EyeViewsToMsg(v);
  // The left eye's orientation as OpenXR has it: its view axis (-z) is the
  // OpenCV eye's +z.
  const Eigen::Quaterniond q_xr(m.eyes[0].orientation[3], m.eyes[0].orientation[0], m.eyes[0].orientation[1],
                                m.eyes[0].orientation[2]);
  EXPECT_LT((q_xr.toRotationMatrix() * Eigen::Vector3d(0, 0, -1) - v.world_from_eye[0].rotation.col(2)).norm(), 1e-12);
  EXPECT_LT((q_xr.toRotationMatrix() * Eigen::Vector3d(0, 1, 0) + v.world_from_eye[0].rotation.col(1)).norm(), 1e-12)
      << "OpenXR's up is OpenCV's -y";
  const EyeViewsSample back = EyeViewsFromMsg(m);
  EXPECT_EQ(back.tracker_id, 7u);
  EXPECT_EQ(back.stamp_ns, 123);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_LT((back.world_from_eye[k].rotation - v.world_from_eye[k].rotation).norm(), 1e-12);
    EXPECT_LT((back.world_from_eye[k].translation - v.world_from_eye[k].translation).norm(), 1e-12);
    EXPECT_EQ(back.fov[k].left, v.fov[k].left);
    EXPECT_EQ(back.fov[k].down, v.fov[k].down);
  }
  for (double& c : m.eyes[1].orientation) c *= 3;  // not unit
  EXPECT_LT((EyeViewsFromMsg(m).world_from_eye[1].rotation - v.world_from_eye[1].rotation).norm(), 1e-12);
  auto refused = [](const hullpipe_msg_EyeViews& bad, const std::string& eye) {
    try {
      (void)EyeViewsFromMsg(bad);
      return false;
    } catch (const MessageError& e) {
      return std::string(e.what()).find(eye) != std::string::npos;
    }
  };
  hullpipe_msg_EyeViews bad = EyeViewsToMsg(v);
  for (double& c : bad.eyes[1].orientation) c = 0;
  EXPECT_TRUE(refused(bad, "right eye"));
  bad = EyeViewsToMsg(v);
  bad.eyes[0].position[2] = std::nan("");
  EXPECT_TRUE(refused(bad, "left eye"));
  bad = EyeViewsToMsg(v);
  bad.eyes[0].fov[0] = 0.9;  // left of right
  EXPECT_TRUE(refused(bad, "left eye"));
}

// One NodeStats sample with an invalid UTF-8 byte in its name once made render's
// stats.json empty (nlohmann-json threw at the end of the run): rejected at the
// wire now, one line, counted.
TEST(Convert, NodeStatsWithBadTextIsRejected) {
  NodeStatsSample s;
  s.name = "recon0";
  s.stages["sweep"] = {1.0, 2.0};
  s.backend = "cpu";
  const auto good = MakeNodeStatsMessage(s, 1);
  EXPECT_EQ(NodeStatsFromMsg(good.msg).name, "recon0");  // control
  for (const std::string& bad : {std::string("rec\xff"), std::string("\xc3"), std::string("\xc0\x80"),
                                std::string("\xed\xa0\x80"), std::string(65, 'a'), std::string()}) {
    s.name = bad;
    const auto m = MakeNodeStatsMessage(s, 1);
    EXPECT_THROW(NodeStatsFromMsg(m.msg), MessageError) << bad.size();
  }
  s.name = "sim";
  s.stages.clear();
  s.stages["caf\xc3\xa9"] = {1, 1};  // valid UTF-8 passes
  EXPECT_NO_THROW(NodeStatsFromMsg(MakeNodeStatsMessage(s, 1).msg));
  s.stages.clear();
  s.stages["st\xfe"] = {1, 1};
  EXPECT_THROW(NodeStatsFromMsg(MakeNodeStatsMessage(s, 1).msg), MessageError);
}

// The latency budget needs each stage's median, p95 and count, and the host
// (which stamps cross hosts): all of them cross the wire.
TEST(Convert, NodeStatsCarriesEachStagesPercentilesAndTheHost) {
  NodeStatsSample s;
  s.name = "recon1";
  s.host = "lab-pc-2";
  s.stages["sweep"] = {12.5, 11.0, 20.0, 321};
  s.stages["transport_map"] = {1.5, 1.0, 3.0, 1284};
  const NodeStatsSample back = NodeStatsFromMsg(MakeNodeStatsMessage(s, 1).msg);
  EXPECT_EQ(back.host, "lab-pc-2");
  ASSERT_EQ(back.stages.size(), 2u);
  const auto& st = back.stages.at("sweep");
  EXPECT_EQ(st.ms_mean, 12.5);
  EXPECT_EQ(st.ms_p50, 11.0);
  EXPECT_EQ(st.ms_p95, 20.0);
  EXPECT_EQ(st.count, 321u);
  EXPECT_EQ(back.stages.at("transport_map").count, 1284u);
  s.host = std::string(256, 'h');  // longer than any host name
  EXPECT_THROW(NodeStatsFromMsg(MakeNodeStatsMessage(s, 1).msg), MessageError);
}

TEST(Dds, ErrorsNameTheCall) {
  try {
    Check(DDS_RETCODE_BAD_PARAMETER, "dds_create_writer");
    FAIL();
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("dds_create_writer"), std::string::npos);
    EXPECT_EQ(e.code(), DDS_RETCODE_BAD_PARAMETER);
  }
}

// Recorded bytes reach Cyclone only as XCDR1, what hullpipe's writers send:
// Cyclone 0.10.2 reads past its buffer deserializing an XCDR2-encapsulated
// CameraInfo the wire fuzzer made (fuzz/corpus/fuzz_wire_samples). Encode and
// Decode round-trip (the positive control); the same bytes marked XCDR2 are refused.
TEST(Dds, RecordedSamplesMustBeXcdr1) {
  const auto dir = test::TempDir("dds_xcdr");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  const KnownType& kt = *FindKnownType("hullpipe::msg::CameraInfo");
  CdrWriter w(p, kt, kt.qos);
  const hullpipe_msg_CameraInfo info = CameraToMsg(TestCamera(), {});
  std::vector<uint8_t> cdr = w.Encode(&info);
  ASSERT_GE(cdr.size(), 4u);
  EXPECT_EQ(cdr[1], 1) << "CDR_LE";
  hullpipe_msg_CameraInfo back{};
  ASSERT_TRUE(w.Decode(cdr, &back));
  EXPECT_EQ(CameraFromMsg(back).fx, TestCamera().fx);
  dds_sample_free(&back, kt.descriptor, DDS_FREE_CONTENTS);
  cdr[1] = 7;  // CDR2_LE
  hullpipe_msg_CameraInfo none{};
  EXPECT_FALSE(w.Decode(cdr, &none));
  EXPECT_THROW(w.Write(cdr), std::invalid_argument);
}

// The XCDR2-marked CameraInfo that makes Cyclone 0.10.2 read past its buffer
// when deserializing recorded bytes, written on the wire by another process
// (raw serialized data, as a foreign writer could): Cyclone delivers it, and a
// typed take read it as garbage (camera 99 with fx 2e300 and translations of
// 1e-315: the over-read). The node's reader now refuses it by its encapsulation
// before deserializing and counts it. Each is sent between valid samples of
// camera 1 (the control: they arrive), and the writer ends with a valid sample
// of camera 2, which the reader waits for.
TEST(Dds, ASampleNotInXcdr1FromTheWireIsRefusedBeforeDeserializing) {
  const auto dir = test::TempDir("dds_live_xcdr");
  const std::string config = test::WriteLoopbackConfig(dir);
  setenv("CYCLONEDDS_URI", ("file://" + config).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  Participant node(domain);
  Reader<hullpipe_msg_CameraInfo> reader(node);
  // The foreign writer: this test binary again, running the helper below.
  test::Process writer(
      {"/proc/self/exe", "--gtest_filter=Dds.ForeignXcdr2WriterHelper"}, (dir / "writer.log").string(),
      {{"CYCLONEDDS_URI", "file://" + config}, {"HULLPIPE_TEST_XCDR2_DOMAIN", std::to_string(domain)}});
  int valid = 0, other = 0;
  bool last = false;
  const double end = MonotonicSeconds() + 30;
  while (!last && MonotonicSeconds() < end) {
    reader.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) {
      if (m.camera_id == 2) last = true;
      else if (m.camera_id == uint32_t(TestCamera().id) && m.K[0] == TestCamera().fx) ++valid;
      else ++other;
    });
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(writer.Wait(30), 0) << test::ReadFile((dir / "writer.log").string());
  EXPECT_TRUE(last) << "the writer's last sample did not come";
  EXPECT_GE(valid, 1) << "the valid samples around the XCDR2 ones (the control; keep-last 1 per camera)";
  EXPECT_EQ(other, 0) << "an XCDR2-marked sample was deserialized";
  EXPECT_GE(reader.refused(), 1u) << "the XCDR2-marked samples were delivered and refused";
}

// The writer process of the test above (skipped unless it started it): valid,
// XCDR2-marked (camera 99), valid, 20 times, then camera 2's valid sample.
TEST(Dds, ForeignXcdr2WriterHelper) {
  const char* domain_text = std::getenv("HULLPIPE_TEST_XCDR2_DOMAIN");
  if (!domain_text) GTEST_SKIP() << "the writer process of ASampleNotInXcdr1FromTheWireIsRefusedBeforeDeserializing";
  Participant stranger(uint32_t(std::atoi(domain_text)));
  Writer<hullpipe_msg_CameraInfo> writer(stranger);
  const KnownType& kt = *FindKnownType("hullpipe::msg::CameraInfo");
  CdrWriter encoder(stranger, kt, kt.qos);
  const hullpipe_msg_CameraInfo valid = CameraToMsg(TestCamera(), {});
  hullpipe_msg_CameraInfo marked = valid;
  marked.camera_id = 99;  // whatever of it arrived would show as camera 99 (or garbage)
  std::vector<uint8_t> cdr = encoder.Encode(&marked);
  cdr[1] = 7;  // CDR2_LE
  // Cyclone's sertype of the topic, from a serialized sample of a probe reader.
  Entity probe(Check(dds_create_reader(stranger.handle(), dds_get_topic(writer.handle()), nullptr, nullptr),
                     "dds_create_reader"));
  struct ddsi_serdata* sample = nullptr;
  dds_sample_info_t si;
  const double end = MonotonicSeconds() + 20;
  while (writer.MatchedReaders() < 2 && MonotonicSeconds() < end)  // the probe and the node's reader
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GE(writer.MatchedReaders(), 2u);
  while (Check(dds_takecdr(probe.handle(), &sample, 1, &si, DDS_ANY_STATE), "dds_takecdr") == 0 &&
         MonotonicSeconds() < end) {
    sample = nullptr;
    writer.Write(valid);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_NE(sample, nullptr);
  ddsrt_iovec_t iov;
  iov.iov_base = cdr.data();
  iov.iov_len = static_cast<ddsrt_iov_len_t>(cdr.size());
  for (int k = 0; k < 20; ++k) {
    writer.Write(valid);
    struct ddsi_serdata* xcdr2 = ddsi_serdata_from_ser_iov(sample->type, SDK_DATA, 1, &iov, cdr.size());
    ASSERT_NE(xcdr2, nullptr);
    Check(dds_writecdr(writer.handle(), xcdr2), "dds_writecdr");  // takes the reference
    writer.Write(valid);
  }
  hullpipe_msg_CameraInfo last = valid;
  last.camera_id = 2;
  writer.Write(last);
  dds_wait_for_acks(writer.handle(), DDS_SECS(5));
  ddsi_serdata_unref(sample);
}

// A recording of an earlier build holds ViewPose samples without the run_id
// field (8 bytes shorter: the field follows doubles, so no padding differs).
// Such a sample is refused, never read with a made-up run id.
TEST(Dds, ASampleOfTheOlderShorterLayoutIsRefused) {
  const auto dir = test::TempDir("dds_old_layout");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  const KnownType& kt = *FindKnownType("hullpipe::msg::ViewPose");
  CdrWriter w(p, kt, kt.qos);
  const hullpipe_msg_ViewPose pose =
      ViewToMsg(NovelView::FromFov(64, 48, 1.0, Rigid3d{}), 7, 3, 1000, /*run_id=*/0xabc);
  std::vector<uint8_t> cdr = w.Encode(&pose);
  hullpipe_msg_ViewPose back{};
  ASSERT_TRUE(w.Decode(cdr, &back));  // control: the whole sample
  EXPECT_EQ(back.run_id, 0xabcu);
  // The layout before the eye (Dds.AViewOfTheEarlierLayoutReadsAsTheOneView),
  // then without its run id.
  cdr.resize(cdr.size() - 4 - 8);
  cdr[3] = 0;
  hullpipe_msg_ViewPose old{};
  EXPECT_FALSE(w.Decode(cdr, &old));
  EXPECT_THROW(w.Write(cdr), std::invalid_argument);
}

// A recording made before ViewPose and CompositedView said which eye they are
// for holds samples 4 bytes shorter (the eye, a uint8, and the padding to a
// multiple of 4 after it). They read as what they are: every other field
// exactly, and the one view (VIEW_EYE_MONO) for the eye; replayed, they are
// published completed. A sample cut anywhere else is still refused.
TEST(Dds, AViewOfTheEarlierLayoutReadsAsTheOneView) {
  const auto dir = test::TempDir("dds_old_eye");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  // The earlier layout of a current sample: its body less the eye and padding,
  // with a header that declares no padding (as the earlier build wrote it).
  const auto earlier = [](const std::vector<uint8_t>& cdr) {
    EXPECT_EQ(cdr[3] & 3u, 3u) << "the current layout ends in the eye and 3 bytes of padding";
    std::vector<uint8_t> old(cdr.begin(), cdr.end() - 4);
    old[3] = 0;
    return old;
  };
  {
    const KnownType& kt = *FindKnownType("hullpipe::msg::ViewPose");
    EXPECT_EQ(kt.appended_bytes, 1u);
    CdrWriter w(p, kt, kt.qos);
    const hullpipe_msg_ViewPose pose = ViewToMsg(
        NovelView::FromFov(64, 48, 1.0, LookAt({1, 2, 3}, {0, 0, 0}, {0, 0, -1})), 7, 3, 1000, 0xabc, ViewEye::kLeft);
    const std::vector<uint8_t> cdr = w.Encode(&pose);
    hullpipe_msg_ViewPose whole{};
    ASSERT_TRUE(w.Decode(cdr, &whole));  // control: the current layout keeps its eye
    EXPECT_EQ(whole.eye, hullpipe_msg_VIEW_EYE_LEFT);
    const std::vector<uint8_t> old = earlier(cdr);
    hullpipe_msg_ViewPose back{};
    ASSERT_TRUE(w.Decode(old, &back));
    EXPECT_EQ(back.eye, hullpipe_msg_VIEW_EYE_MONO);
    EXPECT_EQ(back.run_id, 0xabcu);
    EXPECT_EQ(back.pose_seq, 7u);
    for (int i = 0; i < 9; ++i) EXPECT_EQ(back.world_from_eye_rotation[i], pose.world_from_eye_rotation[i]);
    EXPECT_EQ(back.world_from_eye_translation[2], pose.world_from_eye_translation[2]);
    EXPECT_NO_THROW(ViewFromMsg(back));
    EXPECT_NO_THROW(w.Write(old));
    for (const size_t cut : {size_t(1), size_t(2), size_t(8)}) {
      std::vector<uint8_t> bad(old.begin(), old.end() - std::ptrdiff_t(cut));
      hullpipe_msg_ViewPose none{};
      EXPECT_FALSE(w.Decode(bad, &none)) << cut;
    }
  }
  {
    const KnownType& kt = *FindKnownType("hullpipe::msg::CompositedView");
    EXPECT_EQ(kt.appended_bytes, 1u);
    CdrWriter w(p, kt, kt.qos);
    const auto view = MakeCompositedViewMessage(cv::Mat(24, 32, CV_8UC3, cv::Scalar(1, 2, 3)), 8, 3, 1000, 0xabc,
                                                {1280, 90}, ViewEye::kRight);
    const std::vector<uint8_t> cdr = w.Encode(&view.msg);
    const std::vector<uint8_t> old = earlier(cdr);
    EXPECT_TRUE(w.DecodeWith<hullpipe_msg_CompositedView>(cdr, [&](const hullpipe_msg_CompositedView& m) {
      EXPECT_EQ(m.eye, hullpipe_msg_VIEW_EYE_RIGHT);
    }));
    EXPECT_TRUE(w.DecodeWith<hullpipe_msg_CompositedView>(old, [&](const hullpipe_msg_CompositedView& m) {
      EXPECT_EQ(m.eye, hullpipe_msg_VIEW_EYE_MONO);
      EXPECT_EQ(m.run_id, 0xabcu);
      EXPECT_EQ(m.data._length, view.bytes.size());
      EXPECT_EQ(CompositedViewFromMsg(m).size(), cv::Size(32, 24));
    }));
    EXPECT_NO_THROW(w.Write(old));
    for (const size_t cut : {size_t(1), size_t(8)}) {
      std::vector<uint8_t> bad(old.begin(), old.end() - std::ptrdiff_t(cut));
      hullpipe_msg_CompositedView none{};
      EXPECT_FALSE(w.Decode(bad, &none)) << cut;
    }
  }
}

// A recording made before CameraImage could hold a region of its image holds
// samples that end with the image's bytes (then the padding to a multiple of
// 4 its header declares). They read as what they were, the whole image, with
// no region; replayed, they are published completed. A sample cut anywhere
// else is still refused.
TEST(Dds, ACameraImageOfTheEarlierLayoutReadsAsTheWholeImage) {
  const auto dir = test::TempDir("dds_old_image");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  const KnownType& kt = *FindKnownType("hullpipe::msg::CameraImage");
  EXPECT_EQ(kt.appended_bytes, 16u);
  EXPECT_EQ(kt.appended_alignment, 4u);
  CdrWriter w(p, kt, kt.qos);
  // Widths 4, 5, 6 and 7 of one row: 12, 15, 18 and 21 bytes, each padding.
  for (const int width : {4, 5, 6, 7}) {
    SCOPED_TRACE(width);
    cv::Mat img(1, width, CV_8UC3);
    for (int c = 0; c < width; ++c) img.at<cv::Vec3b>(0, c) = cv::Vec3b(uint8_t(c + 1), 9, 200);
    const auto msg = MakeImageMessage(2, 5, 1000, img, 0);
    const std::vector<uint8_t> cdr = w.Encode(&msg.msg);
    // The earlier layout: the body less the region's 16 bytes; the data's
    // alignment before them becomes the padding its header declares.
    const size_t pad = (4 - (size_t(width) * 3) % 4) % 4;
    EXPECT_EQ(cdr[3] & 3u, 0u);
    std::vector<uint8_t> old(cdr.begin(), cdr.end() - 16);
    old[3] = uint8_t(pad);
    ASSERT_TRUE(w.DecodeWith<hullpipe_msg_CameraImage>(old, [&](const hullpipe_msg_CameraImage& m) {
      EXPECT_FALSE(ImageHasRegion(m));
      EXPECT_EQ(m.x, 0u);
      EXPECT_EQ(m.frame_seq, 5u);
      EXPECT_EQ(m.data._length, size_t(width) * 3);
      EXPECT_EQ(cv::norm(ImageFromMsg(m), img, cv::NORM_INF), 0);
    }));
    EXPECT_NO_THROW(w.Write(old));
    for (const size_t cut : {size_t(4), size_t(8), size_t(12)}) {
      std::vector<uint8_t> bad(cdr.begin(), cdr.end() - std::ptrdiff_t(cut));
      hullpipe_msg_CameraImage none{};
      EXPECT_FALSE(w.Decode(bad, &none)) << cut;
    }
  }
  // Control: the current layout keeps its region.
  const auto region =
      MakeImageMessage(2, 6, 1000, cv::Mat(8, 8, CV_8UC3, cv::Scalar(1, 2, 3)), 0, cv::Rect(2, 3, 4, 5));
  EXPECT_TRUE(w.DecodeWith<hullpipe_msg_CameraImage>(w.Encode(&region.msg), [&](const hullpipe_msg_CameraImage& m) {
    EXPECT_EQ(m.x, 2u);
    EXPECT_EQ(m.y, 3u);
    EXPECT_EQ(m.full_width, 8u);
  }));
}

// A recording made before CollisionReport had its hull velocity holds samples
// 24 bytes shorter (a uint8, 7 bytes of alignment, two doubles, appended last).
// They read as what they are: the rest of the report exactly, and "not
// estimated" (HULL_VELOCITY_NONE, zeros) for the velocity; replayed, they are
// published completed. A sample cut anywhere else is still refused.
TEST(Dds, ACollisionReportOfTheEarlierLayoutReadsWithNoHullVelocity) {
  const auto dir = test::TempDir("dds_old_report");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  const KnownType& kt = *FindKnownType("hullpipe::msg::CollisionReport");
  EXPECT_EQ(kt.appended_bytes, 24u);
  CdrWriter w(p, kt, kt.qos);
  CollisionReportSample r;
  r.object_id = 7, r.frame_seq = 42, r.capture_time_ns = 123456789;
  r.triangle_ids = {3, 5};
  r.collision_points = {{0.1, 0.2, -1.0}};
  r.has_response = true;
  r.cp_obj = {0.1, 0.2, -1.0}, r.cp_hull = {0.11, 0.2, -1.0}, r.v_rec = {1, 0, 0}, r.n_hull = {0, 0.6, -0.8};
  r.d_rec = 0.01;
  r.hull_velocity_status = hullpipe_msg_HULL_VELOCITY_MEASURED;
  r.hull_normal_speed = 1.25;
  r.hull_velocity_interval = 0.04;
  const auto msg = MakeCollisionReportMessage(r);
  std::vector<uint8_t> cdr = w.Encode(&msg.msg);
  hullpipe_msg_CollisionReport whole{};
  ASSERT_TRUE(w.Decode(cdr, &whole));  // control: the current layout
  EXPECT_EQ(whole.hull_velocity_status, hullpipe_msg_HULL_VELOCITY_MEASURED);
  EXPECT_EQ(whole.hull_normal_speed, 1.25);
  dds_sample_free(&whole, kt.descriptor, DDS_FREE_CONTENTS);
  std::vector<uint8_t> old(cdr.begin(), cdr.end() - 24);
  hullpipe_msg_CollisionReport back{};
  ASSERT_TRUE(w.Decode(old, &back));
  EXPECT_EQ(back.object_id, 7u);
  EXPECT_EQ(back.frame_seq, 42u);
  ASSERT_EQ(back.triangle_ids._length, 2u);
  EXPECT_EQ(back.triangle_ids._buffer[1], 5u);
  EXPECT_TRUE(back.has_response);
  EXPECT_EQ(back.n_hull.z, -0.8);
  EXPECT_EQ(back.d_rec, 0.01);
  EXPECT_EQ(back.hull_velocity_status, hullpipe_msg_HULL_VELOCITY_NONE);
  EXPECT_EQ(back.hull_normal_speed, 0.0);
  EXPECT_EQ(back.hull_velocity_interval, 0.0);
  dds_sample_free(&back, kt.descriptor, DDS_FREE_CONTENTS);
  EXPECT_NO_THROW(w.Write(old));
  for (const size_t cut : {size_t(1), size_t(8), size_t(30)}) {
    std::vector<uint8_t> bad(cdr.begin(), cdr.end() - std::ptrdiff_t(cut));
    hullpipe_msg_CollisionReport none{};
    EXPECT_FALSE(w.Decode(bad, &none)) << cut;
  }
}

// Recordings made before VirtualObjectState carried boxes, and before
// VirtualMesh named its element, hold samples without those fields last: they
// read as what they are, a sphere and an unnamed element, the rest exactly.
TEST(Dds, ObjectStatesAndMeshesOfTheEarlierLayoutsRead) {
  const auto dir = test::TempDir("dds_old_layouts");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  Participant p(test::UniqueDomain());
  {
    const KnownType& kt = *FindKnownType("hullpipe::msg::VirtualObjectState");
    CdrWriter w(p, kt, kt.qos, CdrWriter::Scope::kDecodeOnly);
    VirtualObjectSample ball;
    ball.object_id = 3, ball.radius = 0.12, ball.position = {1, 2, 3}, ball.colliding = true;
    const hullpipe_msg_VirtualObjectState msg = VirtualObjectToMsg(ball);
    const std::vector<uint8_t> cdr = w.Encode(&msg);
    // The earlier layout: the body through `colliding` (129 bytes after the header), padded to 4.
    std::vector<uint8_t> old(cdr.begin(), cdr.begin() + 4 + 129);
    old.resize(old.size() + 3, 0);
    old[3] = 3;
    hullpipe_msg_VirtualObjectState back{};
    ASSERT_TRUE(w.Decode(old, &back));
    const VirtualObjectSample s = VirtualObjectFromMsg(back);
    EXPECT_EQ(s.shape, VirtualObjectSample::Shape::kSphere);
    EXPECT_EQ(s.radius, 0.12);
    EXPECT_EQ(s.position, Eigen::Vector3d(1, 2, 3));
    EXPECT_TRUE(s.colliding);
    std::vector<uint8_t> cut(cdr.begin(), cdr.end() - 8);  // cut elsewhere: refused
    hullpipe_msg_VirtualObjectState none{};
    EXPECT_FALSE(w.Decode(cut, &none));
  }
  {
    const KnownType& kt = *FindKnownType("hullpipe::msg::VirtualMesh");
    CdrWriter w(p, kt, kt.qos, CdrWriter::Scope::kDecodeOnly);
    VirtualMeshSample m;
    m.object_id = 100;
    m.kind = hullpipe_msg_MESH_KIND_CLOTH;
    m.draw.vertices = {{0, 0, -1}, {0.1, 0, -1}, {0, 0.1, -1}};
    m.draw.triangles = {{0, 1, 2}};
    m.clearance = 0.05;
    m.element = "cloth";
    const auto msg = MakeVirtualMeshMessage(m);
    const std::vector<uint8_t> cdr = w.Encode(&msg.msg);
    // The earlier layout ends with `clearance`, a double: the body less the
    // string (4 bytes of length, "cloth" and its NUL) and its padding.
    const size_t padding = cdr[3] & 3u;
    std::vector<uint8_t> old(cdr.begin(), cdr.end() - std::ptrdiff_t(padding + 4 + 6));
    old[2] = old[3] = 0;
    ASSERT_EQ((old.size() - 4) % 8, 0u);
    hullpipe_msg_VirtualMesh back{};
    ASSERT_TRUE(w.Decode(old, &back));
    const VirtualMeshSample s = VirtualMeshFromMsg(back);
    EXPECT_EQ(s.element, "unnamed");
    EXPECT_EQ(s.object_id, 100u);
    EXPECT_EQ(s.draw.triangles.size(), 1u);
    EXPECT_EQ(s.clearance, 0.05);
    dds_sample_free(&back, kt.descriptor, DDS_FREE_CONTENTS);
    hullpipe_msg_VirtualMesh whole{};
    ASSERT_TRUE(w.Decode(cdr, &whole));  // control: the current layout keeps its name
    EXPECT_EQ(VirtualMeshFromMsg(whole).element, "cloth");
    dds_sample_free(&whole, kt.descriptor, DDS_FREE_CONTENTS);
  }
}

// CameraInfo is transient-local: a reader that joins after it was written still
// gets it (late joiners must not miss the calibration).
TEST(Dds, LateJoinerGetsCameraInfo) {
  const auto dir = test::TempDir("dds_late");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  Participant pub(domain);
  Writer<hullpipe_msg_CameraInfo> writer(pub);
  writer.Write(CameraToMsg(TestCamera(), {}));
  Participant sub(domain);
  Reader<hullpipe_msg_CameraInfo> reader(sub);
  WaitSet ws(sub);
  ws.Attach(reader);
  int got = 0;
  const double end = MonotonicSeconds() + 10;
  while (got == 0 && MonotonicSeconds() < end) {
    ws.Wait(0.2);
    reader.TakeEach([&](const hullpipe_msg_CameraInfo& m, const dds_sample_info_t&) {
      EXPECT_EQ(int(m.camera_id), TestCamera().id);
      ++got;
    });
  }
  EXPECT_EQ(got, 1);
}

// A peer publishing under ever new keys (here EyeViews from 4000 tracker ids)
// fills a node's reader only to its topic's instance bound (QosSpec::
// max_instances, topics.h): the reader's cache cannot grow without end. The
// positive control, a reader of the same topic with no bound, sees hundreds
// of the keys.
TEST(Dds, ANewKeyFloodFillsAReaderOnlyToItsTopicsInstanceBound) {
  const auto dir = test::TempDir("dds_key_flood");
  setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(dir)).c_str(), 1);
  const uint32_t domain = test::UniqueDomain();
  Participant pub(domain), sub(domain);
  Reader<hullpipe_msg_EyeViews> bounded(sub);
  QosSpec unbounded_qos = TopicTraits<hullpipe_msg_EyeViews>::kQos;
  unbounded_qos.max_instances = 0;
  Reader<hullpipe_msg_EyeViews> unbounded(sub, TopicTraits<hullpipe_msg_EyeViews>::kName, unbounded_qos);
  Writer<hullpipe_msg_EyeViews> writer(pub);
  const double matched_by = MonotonicSeconds() + 10;
  while (writer.MatchedReaders() < 2 && MonotonicSeconds() < matched_by)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(writer.MatchedReaders(), 2u);
  constexpr int32_t kBound = kTrackerInstances;
  std::set<uint32_t> seen_bounded, seen_unbounded;
  hullpipe_msg_EyeViews m{};
  for (auto& e : m.eyes) e.orientation[3] = 1, e.fov[0] = -0.8, e.fov[1] = 0.8, e.fov[2] = 0.8, e.fov[3] = -0.8;
  const double end = MonotonicSeconds() + 30;
  // Rounds over the keys (best-effort: a sample may be lost), until the
  // control has seen ten times the bound.
  while (seen_unbounded.size() < size_t(10 * kBound) && MonotonicSeconds() < end) {
    for (uint32_t id = 0; id < 4000; ++id) {
      m.tracker_id = id;
      writer.Write(m);
      if (id % 100 == 99) {
        bounded.TakeEach(
            [&](const hullpipe_msg_EyeViews& s, const dds_sample_info_t&) { seen_bounded.insert(s.tracker_id); });
        unbounded.TakeEach(
            [&](const hullpipe_msg_EyeViews& s, const dds_sample_info_t&) { seen_unbounded.insert(s.tracker_id); });
      }
    }
  }
  EXPECT_GE(seen_unbounded.size(), size_t(10 * kBound)) << "the control: the flood reached the reader";
  EXPECT_GT(seen_bounded.size(), 0u) << "the bounded reader still takes samples";
  EXPECT_LE(seen_bounded.size(), size_t(kBound)) << "more keys than the bound kept";
}

// The input of recon, sim and render: JPEG images are decoded together after
// the take (several threads), raw ones as they come; a bad JPEG is rejected,
// counted and costs its frameset nothing else. The same on the caller's thread
// and on the input's own (StartInputThread).
class FramesetInputOnItsThreadOrNot : public ::testing::TestWithParam<bool> {};

// A FramesetInput's test set-up: three 64x48 cameras, a publishing and a
// subscribing participant on loopback in a domain of the test's own, and the
// subscriber's waitset.
struct InputLink {
  explicit InputLink(const char* name) : domain(LoopbackDomain(name)), pub(domain), sub(domain), ws(sub) {}
  static uint32_t LoopbackDomain(const char* name) {
    setenv("CYCLONEDDS_URI", ("file://" + test::WriteLoopbackConfig(test::TempDir(name))).c_str(), 1);
    return test::UniqueDomain();
  }
  const std::vector<Camera> cams = RingCameras(3, 3, 2, Eigen::Vector3d::Zero(), 64, 48, 1.0, Distortion{});
  uint32_t domain;
  Participant pub, sub;
  WaitSet ws;
};

TEST_P(FramesetInputOnItsThreadOrNot, DecodesJpegImagesAndRejectsABadOne) {
  InputLink link("dds_frameset_input");
  const std::vector<Camera>& cams = link.cams;
  Participant& pub = link.pub;
  WaitSet& ws = link.ws;
  FramesetInput input(link.sub, ws, 4, /*with_images=*/true);
  input.SetDecodeThreads(3);
  if (GetParam()) input.StartInputThread();
  EXPECT_EQ(input.input_thread(), GetParam());
  Writer<hullpipe_msg_CameraInfo> info(pub);
  Writer<hullpipe_msg_ObjectPixelMap> maps(pub);
  Writer<hullpipe_msg_CameraImage> images(pub);
  const double match_end = MonotonicSeconds() + 10;
  while ((info.MatchedReaders() == 0 || maps.MatchedReaders() == 0 || images.MatchedReaders() == 0) &&
         MonotonicSeconds() < match_end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GT(images.MatchedReaders(), 0u);
  for (const Camera& c : cams) info.Write(CameraToMsg(c, {}));
  // Camera k's image: a flat colour of its own (JPEG-safe), half size.
  const cv::Rect kRegion(8, 3, 16, 16);  // camera 1's region: its object pixels at half size, grown
  auto colour = [](const Camera& c) { return cv::Scalar(40.0 * c.id, 200 - 30.0 * c.id, 90); };
  const int64_t t0 = NowNs();
  for (uint64_t seq : {1, 2}) {
    const int64_t t = t0 + int64_t(seq) * 40'000'000;
    for (const Camera& c : cams) {
      cv::Mat map(c.height, c.width, CV_8UC1, cv::Scalar(0));
      map(cv::Rect(20, 10, 20, 20)) = 255;
      maps.Write(MakeMapMessage(FrameStamp{uint32_t(c.id), seq, t, double(seq) / 25}, 3, map, nullptr).msg);
      const cv::Mat bgr(c.height / 2, c.width / 2, CV_8UC3, colour(c));
      const int quality = c.id == cams.back().id ? 0 : 95;  // the last camera's images raw
      // The first camera's only around its object pixels (capture_node --image-region).
      auto img = MakeImageMessage(uint32_t(c.id), seq, t, bgr, quality,
                                  c.id == cams[0].id ? std::optional<cv::Rect>(kRegion) : std::nullopt);
      std::vector<uint8_t> png;
      if (seq == 2 && c.id == cams[1].id) {  // marked JPEG, holding a PNG
        cv::imencode(".png", bgr, png);
        img.msg.data._buffer = png.data();
        img.msg.data._length = img.msg.data._maximum = uint32_t(png.size());
      }
      images.Write(img.msg);
    }
  }
  // A region whose whole image is larger than its camera's calibration (a
  // hostile peer's way to make each reader allocate 805 MB): refused before
  // anything is allocated.
  auto huge = MakeImageMessage(uint32_t(cams[2].id), 3, t0 + 120'000'000, cv::Mat(4, 4, CV_8UC3), 0,
                               cv::Rect(0, 0, 2, 2));
  huge.msg.full_width = huge.msg.full_height = 16384;
  images.Write(huge.msg);
  const double end = MonotonicSeconds() + 10;
  while ((!input.assembler().IsComplete(1) || input.malformed() < 2) && MonotonicSeconds() < end) {
    ws.Wait(0.1);
    input.Poll();
  }
  EXPECT_EQ(input.malformed(), 2u);
  std::optional<Frameset> fs = input.assembler().Take(1);
  ASSERT_TRUE(fs);
  ASSERT_EQ(fs->images.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    ASSERT_EQ(fs->images[i].image.size(), cv::Size(32, 24)) << i;
    cv::Mat expected(24, 32, CV_8UC3, colour(cams[i]));
    if (i == 0) {  // its region in the whole image, black around
      cv::Mat black(24, 32, CV_8UC3, cv::Scalar::all(0));
      expected(kRegion).copyTo(black(kRegion));
      expected = black;
    }
    EXPECT_EQ(fs->images[i].camera.id, cams[i].id);
    EXPECT_LE(cv::norm(fs->images[i].image, expected, cv::NORM_INF), i == 2 ? 0 : 4) << i;  // JPEG loss, flat colour
  }
  // Frameset 2 lacks camera 2's image: it never completes.
  EXPECT_FALSE(input.assembler().IsComplete(2));
}

INSTANTIATE_TEST_SUITE_P(Dds, FramesetInputOnItsThreadOrNot, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) { return i.param ? "thread" : "caller"; });

// The input thread takes ahead of Poll only as far as the assembler keeps
// (here 64 maps, the least it holds, passed by at most one take): past that
// the samples wait in the
// readers' history (4 per camera). Control: once Poll drains it, the thread
// takes again and the newest frameset completes. Stopping it takes under a
// second (its waits are 50 ms).
TEST(Dds, TheInputThreadTakesAheadOnlyAsFarAsTheAssemblerKeeps) {
  InputLink link("dds_input_thread");
  const std::vector<Camera>& cams = link.cams;
  Participant& pub = link.pub;
  WaitSet& ws = link.ws;
  auto input = std::make_unique<FramesetInput>(link.sub, ws, 2, /*with_images=*/false);
  input->StartInputThread();
  Writer<hullpipe_msg_CameraInfo> info(pub);
  Writer<hullpipe_msg_ObjectPixelMap> maps(pub);
  const double match_end = MonotonicSeconds() + 10;
  while ((info.MatchedReaders() == 0 || maps.MatchedReaders() == 0) && MonotonicSeconds() < match_end)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_GT(maps.MatchedReaders(), 0u);
  for (const Camera& c : cams) info.Write(CameraToMsg(c, {}));
  const int64_t t0 = NowNs();
  auto write_frame = [&](uint64_t seq) {
    for (const Camera& c : cams) {
      cv::Mat map(c.height, c.width, CV_8UC1, cv::Scalar(0));
      map(cv::Rect(20, 10, 20, 20)) = 255;
      const int64_t t = t0 + int64_t(seq) * 40'000'000;
      maps.Write(MakeMapMessage(FrameStamp{uint32_t(c.id), seq, t, double(seq) / 25}, 3, map, nullptr).msg);
    }
  };
  // One frame at a time, each taken before the next (the readers keep 4 maps
  // a camera), until the thread pauses: 22 frames' 66 maps pass 64.
  uint64_t seq = 0;
  while (input->paused() == 0 && seq < 40) {
    write_frame(++seq);
    const double end = MonotonicSeconds() + 10;
    while (input->queued() < 3 + 3 * seq && input->paused() == 0 && MonotonicSeconds() < end)
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_GT(input->paused(), 0u);
  EXPECT_EQ(seq, 22u);
  // Frame 21 leaves 63 maps: frame 22's first take passes 64, with one, two or
  // all three of its maps (as they reach the reader by then).
  const size_t held = input->queued();
  EXPECT_GE(held, 3u + 64u);
  EXPECT_LE(held, 3u + 66u);
  // Five frames more while it is full: after the thread has found it full
  // three times more (a 50-ms wait each), it still holds the same.
  for (int k = 0; k < 5; ++k) write_frame(++seq);
  const uint64_t paused = input->paused();
  const double end = MonotonicSeconds() + 10;
  while (input->paused() < paused + 3 && MonotonicSeconds() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_GE(input->paused(), paused + 3);
  EXPECT_EQ(input->queued(), held);
  EXPECT_FALSE(input->assembler().HasCamera(cams[0].id));  // nothing reaches the assembler without Poll
  // Control: Poll drains it and the thread takes the rest, the newest frame's included.
  const double poll_end = MonotonicSeconds() + 10;
  while (!input->assembler().IsComplete(seq) && MonotonicSeconds() < poll_end) {
    ws.Wait(0.1);
    input->Poll();
  }
  EXPECT_TRUE(input->assembler().IsComplete(seq));
  EXPECT_EQ(input->malformed(), 0u);
  const double t_stop = MonotonicSeconds();
  input.reset();
  EXPECT_LT(MonotonicSeconds() - t_stop, 1.0);
}

}  // namespace
}  // namespace hullpipe::dds
