#include "hullpipe/geometry/calibration.h"

#include <fstream>
#include <iterator>

#include <gtest/gtest.h>

#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

const char* kConfig = R"(<?xml version="1.0"?>
<opencv_storage>
<CameraMatrix type_id="opencv-matrix"><rows>3</rows><cols>3</cols><dt>f</dt>
<data>500. 0. 320. 0. 510. 240. 0. 0. 1.</data></CameraMatrix>
<DistortionCoeffs type_id="opencv-matrix"><rows>1</rows><cols>5</cols><dt>f</dt>
<data>-0.1 0.01 0. 0. 0.</data></DistortionCoeffs>
<Rotation type_id="opencv-matrix"><rows>3</rows><cols>1</cols><dt>d</dt>
<data>0. 0. 0.</data></Rotation>
<Translation type_id="opencv-matrix"><rows>3</rows><cols>1</cols><dt>d</dt>
<data>100. -2000. 5000.</data></Translation>
</opencv_storage>
)";

TEST(Calibration, ReadsOpenCvConfigConvertingUnits) {
  const auto dir = test::TempDir("calib");
  std::ofstream(dir / "config.xml") << kConfig;
  const Camera c = ReadOpenCvCameraConfig((dir / "config.xml").string(), 3, 640, 480);
  EXPECT_EQ(c.id, 3);
  EXPECT_DOUBLE_EQ(c.fx, 500);
  EXPECT_DOUBLE_EQ(c.fy, 510);
  EXPECT_DOUBLE_EQ(c.cx, 320.5);  // OpenCV centres at integers -> hullpipe +0.5
  EXPECT_DOUBLE_EQ(c.cy, 240.5);
  EXPECT_DOUBLE_EQ(c.distortion[0], -0.1f);  // stored as float in the file
  // Translation in mm -> m.
  EXPECT_NEAR((c.cam_from_world.translation - Eigen::Vector3d(0.1, -2.0, 5.0)).norm(), 0, 1e-12);
}

TEST(Calibration, MissingKeyIsNamed) {
  const auto dir = test::TempDir("calib_missing");
  std::string text = kConfig;
  const auto a = text.find("<Rotation"), b = text.find("</Rotation>") + 11;
  text.erase(a, b - a);
  std::ofstream(dir / "config.xml") << text;
  try {
    ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480);
    FAIL() << "expected CalibrationError";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("Rotation"), std::string::npos) << e.what();
  }
}

TEST(Calibration, WrongShapeAndMissingFileAreErrors) {
  const auto dir = test::TempDir("calib_shape");
  std::string text = kConfig;
  text.replace(text.find("100. -2000. 5000."), 17, "100. -2000.");
  std::ofstream(dir / "config.xml") << text;
  EXPECT_THROW(ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480), CalibrationError);
  EXPECT_THROW(ReadOpenCvCameraConfig((dir / "nope.xml").string(), 1, 640, 480), CalibrationError);
  std::ofstream(dir / "garbage.xml") << "this is not xml <<<";
  EXPECT_THROW(ReadOpenCvCameraConfig((dir / "garbage.xml").string(), 1, 640, 480), CalibrationError);
}

TEST(Calibration, YamlRigRoundTrip) {
  const auto dir = test::TempDir("rig_yaml");
  Rig rig;
  for (const auto& c : RingCameras(3, 3.0, 2.0, Eigen::Vector3d(0, 0, -1), 320, 240, 1.0,
                                   Distortion{-0.2, 0.05, 0.001, -0.001, 0}))
    rig.cameras.push_back({c, "bg.png", "frames_%03d.png", "", 0.0, ""});
  // A live camera: its URL is kept as written (not made a path), its latency and
  // a tracked camera's pose log round-trip.
  rig.cameras[1].frames = "udp://127.0.0.1:5002?overrun_nonfatal=1";
  rig.cameras[1].latency_s = 0.045;
  rig.cameras[2].frames = "v4l2:0";
  rig.cameras[2].tracked = "poses.csv";
  rig.workspace.min = Eigen::Vector3d(-1, -1, -2);
  rig.workspace.max = Eigen::Vector3d(1, 1, 0);
  rig.cameras[0].camera.skew = -1.47;  // as a MATLAB-calibrated dome's
  WriteRigYaml(rig, (dir / "rig.yaml").string());
  const Rig back = LoadRig((dir / "rig.yaml").string());
  ASSERT_EQ(back.cameras.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const Camera& a = rig.cameras[i].camera;
    const Camera& b = back.cameras[i].camera;
    EXPECT_EQ(a.id, b.id);
    EXPECT_NEAR(a.cx, b.cx, 1e-9);
    EXPECT_EQ(a.skew, b.skew);
    EXPECT_NEAR((a.cam_from_world.rotation - b.cam_from_world.rotation).norm(), 0, 1e-9);
    EXPECT_NEAR((a.cam_from_world.translation - b.cam_from_world.translation).norm(), 0, 1e-9);
    EXPECT_NEAR(a.distortion[2], b.distortion[2], 1e-12);
    EXPECT_EQ(back.cameras[i].background, (dir / "bg.png").string());  // relative to the file
  }
  EXPECT_NEAR((back.workspace.max - rig.workspace.max).norm(), 0, 1e-12);
  EXPECT_EQ(back.cameras[1].frames, "udp://127.0.0.1:5002?overrun_nonfatal=1");
  EXPECT_TRUE(back.cameras[1].live());
  EXPECT_FALSE(back.cameras[0].live());
  EXPECT_DOUBLE_EQ(back.cameras[1].latency_s, 0.045);
  EXPECT_EQ(back.cameras[2].frames, "v4l2:0");
  EXPECT_EQ(back.cameras[2].tracked, (dir / "poses.csv").string());
  // A latency out of [0, 10] s is refused, naming the key.
  std::ifstream in((dir / "rig.yaml").string());
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t at = text.find("latency: ");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, text.find('\n', at) - at, "latency: -1");
  std::ofstream((dir / "bad.yaml").string()) << text;
  try {
    LoadRig((dir / "bad.yaml").string());
    ADD_FAILURE() << "a negative latency was accepted";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("'latency'"), std::string::npos) << e.what();
  }
}

TEST(Calibration, YamlMissingKeyIsNamed) {
  const auto dir = test::TempDir("rig_yaml_bad");
  std::ofstream(dir / "rig.yaml")
      << "cameras:\n  - id: 1\n    width: 10\n    height: 10\n    K: [1,0,5,0,1,5,0,0,1]\n    t: [0,0,0]\n";
  try {
    LoadRig((dir / "rig.yaml").string());
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("'R'"), std::string::npos) << e.what();
  }
}

// Only fx, fy, cx, cy were read: a skewed K lost its skew and a singular one
// was taken. Each bad K is refused with the file and key named; the good K of
// kConfig is the positive control, and a skewed K is read with its skew.
TEST(Calibration, SingularOrMalformedIntrinsicsAreRefusedAndSkewIsRead) {
  const auto dir = test::TempDir("calib_k");
  const std::string good = "500. 0. 320. 0. 510. 240. 0. 0. 1.";
  struct Case {
    const char* k;
    const char* says;
  };
  for (const Case& c : std::vector<Case>{{"500. 503.5 320. 0. 510. 240. 0. 0. 1.", "larger than fx"},
                                         {"0. 0. 320. 0. 510. 240. 0. 0. 1.", "has fx 0"},
                                         {"1e-30 0. 320. 0. 1e-30 240. 0. 0. 1.", "singular"},
                                         {"500. 0. 320. 0. 510. 240. 0. 0. 0.", "last two rows"},
                                         {"500. 0. 320. 0. 510. 240. 0.1 0. 1.", "last two rows"},
                                         {"500. 0. 320. 7. 510. 240. 0. 0. 1.", "last two rows"},
                                         {"500. 0. 5000. 0. 510. 240. 0. 0. 1.", "principal point"},
                                         {"500. 0. .nan 0. 510. 240. 0. 0. 1.", "finite"}}) {
    std::string text = kConfig;
    text.replace(text.find(good), good.size(), c.k);
    std::ofstream(dir / "config.xml") << text;
    try {
      ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480);
      ADD_FAILURE() << c.k << " was accepted";
    } catch (const CalibrationError& e) {
      EXPECT_NE(std::string(e.what()).find("config.xml: camera 1: key 'CameraMatrix' "), std::string::npos)
          << e.what();
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
    }
  }
  std::ofstream(dir / "config.xml") << kConfig;
  EXPECT_NO_THROW(ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480));
  {  // A skew is read as it is: the pixel-centre offset moves cx, not the skew.
    std::string text = kConfig;
    text.replace(text.find(good), good.size(), "500. -1.47 320. 0. 510. 240. 0. 0. 1.");
    std::ofstream(dir / "config.xml") << text;
    const Camera c = ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480);
    EXPECT_NEAR(c.skew, -1.47, 1e-6);  // the file stores K as float (dt f)
    EXPECT_EQ(c.cx, 320.5);
    std::ofstream(dir / "config.xml") << kConfig;
  }
  // NUL bytes in an attribute crashed OpenCV's parser (fuzz_rig_files): refused first.
  std::string nul = kConfig;
  nul.replace(nul.find("type_id=") + 8, 4, std::string(4, '\0'));
  std::ofstream(dir / "config.xml", std::ios::binary) << nul;
  try {
    ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480);
    ADD_FAILURE() << "a NUL byte was accepted";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("NUL byte at offset"), std::string::npos) << e.what();
  }
  // An attribute cut off at the end of the file crashed OpenCV's parser too
  // (fuzz_rig_files, a 10-minute run): the XML must be well-formed first. YAML
  // or JSON text, which OpenCV would read with other parsers, is not XML.
  for (const auto& [text, says] : std::vector<std::pair<std::string, std::string>>{
           {"<?xml vo=\"20\"?>\n<op vo=", "not well-formed XML (line 2"},
           {std::string(kConfig).substr(0, std::string(kConfig).size() / 2), "not well-formed XML"},
           {"%YAML:1.0\nCameraMatrix: !!opencv-matrix\n", "not XML"},
           {"{\"CameraMatrix\": 1}", "not XML"}}) {
    std::ofstream(dir / "config.xml", std::ios::binary | std::ios::trunc) << text;
    try {
      ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 640, 480);
      ADD_FAILURE() << text << " was accepted";
    } catch (const CalibrationError& e) {
      EXPECT_NE(std::string(e.what()).find("config.xml: " + says), std::string::npos) << e.what();
    }
  }
  // An image side beyond Camera::kMaxSide (what a node would allocate per map).
  EXPECT_THROW(ReadOpenCvCameraConfig((dir / "config.xml").string(), 1, 100000, 480), CalibrationError);
}

// YAML rigs: a misspelt key became a default; too many cameras, a huge image
// and a skewed K are refused, each naming the key.
TEST(Calibration, YamlRigKeysAndBoundsAreChecked) {
  const auto dir = test::TempDir("rig_yaml_keys");
  const std::string cam = "  - id: 1\n    width: 640\n    height: 480\n    K: [500,0,320,0,510,240,0,0,1]\n"
                          "    R: [1,0,0,0,1,0,0,0,1]\n    t: [0,0,5]\n";
  auto load = [&](const std::string& text) -> std::string {
    std::ofstream(dir / "rig.yaml") << text;
    try {
      LoadRig((dir / "rig.yaml").string());
      return "";
    } catch (const CalibrationError& e) {
      return e.what();
    }
  };
  EXPECT_EQ(load("cameras:\n" + cam), "") << "the positive control";
  EXPECT_NE(load("cameras:\n" + cam + "    distortio: [0.1,0,0,0,0]\n").find("camera 1: unknown key 'distortio'"),
            std::string::npos);
  EXPECT_NE(load("camera:\n" + cam).find("unknown key 'camera'"), std::string::npos);
  EXPECT_NE(load("cameras:\n" + cam + "workspace: {min: [0,0,0], max: [1,1,1], mx: 2}\n")
                .find("workspace: unknown key 'mx'"),
            std::string::npos);
  std::string many = "cameras:\n";
  for (int i = 0; i < 65; ++i) many += cam;
  EXPECT_NE(load(many).find("65 cameras; at most 64"), std::string::npos);
  std::string huge = cam;
  huge.replace(huge.find("width: 640"), 10, "width: 100000");
  EXPECT_NE(load("cameras:\n" + huge).find("'width', 'height' must be in [1, 16384]"), std::string::npos);
  std::string skewed = cam;
  skewed.replace(skewed.find("[500,0,"), 7, "[500,900,");
  EXPECT_NE(load("cameras:\n" + skewed).find("key 'K' has skew 900"), std::string::npos);
  EXPECT_NE(load("- just a list\n").find("not a YAML map"), std::string::npos);
  // A NaN workspace (NaN compares false: the box was "not empty") and a 1e308
  // orbit passed `check`.
  EXPECT_NE(load("cameras:\n" + cam + "workspace: {min: [.nan, 0, 0], max: [1, 1, 1]}\n")
                .find("workspace: 'min' and 'max' must be finite metres within 10 km"),
            std::string::npos);
  EXPECT_NE(load("cameras:\n" + cam + "world: {orbit_radius: 1e308}\n").find("'orbit_radius' must be in (0, 10000] m"),
            std::string::npos);
  EXPECT_NE(
      load("cameras:\n" + cam + "world: {floor: -1e30}\n").find("key 'floor' must be metres along up (within 10 km)"),
      std::string::npos);
  EXPECT_EQ(load("cameras:\n" + cam + "world: {orbit_radius: 3, floor: -0.5}\n"), "") << "the control";
  // A Utrecht-style directory whose cam<N> overflows int: "stoi" was the whole message.
  const auto utrecht = test::TempDir("rig_cam_overflow");
  std::filesystem::create_directories(utrecht / "cam99999999999");
  try {
    LoadRig(utrecht.string());
    ADD_FAILURE() << "loaded";
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("no cam<N>/ directories"), std::string::npos) << e.what();
  }
  // Two cameras of one id are one camera on the wire.
  std::string two = cam;
  EXPECT_NE(load("cameras:\n" + cam + two).find("two cameras have id 1"), std::string::npos);
}

TEST(Calibration, LoadsTheUtrechtRig) {
  if (!test::HaveRig()) GTEST_SKIP() << "no rig at " << test::RigDir();
  const Rig rig = LoadRig(test::RigDir());
  ASSERT_EQ(rig.cameras.size(), 4u);
  for (const auto& rc : rig.cameras) {
    EXPECT_EQ(rc.camera.width, 644);
    EXPECT_EQ(rc.camera.height, 486);
    // Cameras hang 1.6-2.2 m above the floor (z points down) and 3-6 m from the origin.
    const Eigen::Vector3d c = rc.camera.Center();
    EXPECT_LT(c.z(), -1.5);
    EXPECT_GT(c.z(), -2.3);
    EXPECT_GT(c.head<2>().norm(), 3.0);
    EXPECT_LT(c.head<2>().norm(), 6.5);
  }
  EXPECT_LE(rig.workspace.max.z(), 0.02 + 1e-12);  // bounded by the floor
}

}  // namespace
}  // namespace hullpipe
