// The importers against rigs the test writes itself in each format (not with the
// importer's code): every camera must come back within 1e-9 (printed with 17
// significant digits, so only the conversions can lose more), and each trap of
// docs/rigs.md (axes, directions, units, pixel centres, near-rotations, skew,
// unsupported models) is a case of its own.
#include "hullpipe/geometry/rig_import.h"

#include <chrono>
#include <cstdio>
#include <functional>
#include <fstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

namespace fs = std::filesystem;

// A z-up rig (as COLMAP and NeRF worlds usually are): 5 cameras on a ring 1.5 m
// above the floor looking at a point 1 m up, each with its own intrinsics and
// distortion, so no field can be swapped with another unnoticed.
std::vector<Camera> ZUpRig(bool distortion = true) {
  std::vector<Camera> cams;
  for (int i = 0; i < 5; ++i) {
    const double a = 2 * 3.14159265358979 * i / 5 + 0.3;
    const Eigen::Vector3d eye(2.5 * std::cos(a) + 0.4, 2.5 * std::sin(a) - 0.2, 1.5 + 0.1 * i);
    const Distortion d = distortion ? Distortion{-0.1 - 0.01 * i, 0.02, 0.001 * i, -0.0005, 0.0}
                                    : Distortion{};
    Camera c = LookingCamera(i + 1, eye, Eigen::Vector3d(0.4, -0.2, 1.0), Eigen::Vector3d(0, 0, 1), 640, 480,
                             1.0 + 0.05 * i, d);
    c.fy = c.fx * (1.0 + 0.01 * i);
    c.cx = 320.5 + 3.25 * i;
    c.cy = 240.5 - 2.75 * i;
    cams.push_back(c);
  }
  return cams;
}

void ExpectSameCamera(const Camera& a, const Camera& b, double tol = 1e-9) {
  SCOPED_TRACE("camera " + std::to_string(a.id));
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_NEAR(a.fx, b.fx, tol * a.fx);
  EXPECT_NEAR(a.fy, b.fy, tol * a.fy);
  EXPECT_NEAR(a.cx, b.cx, tol * a.width);
  EXPECT_NEAR(a.cy, b.cy, tol * a.width);
  EXPECT_NEAR(a.skew, b.skew, tol * a.fx);
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(a.distortion[size_t(k)], b.distortion[size_t(k)], tol);
  EXPECT_LT((a.cam_from_world.rotation - b.cam_from_world.rotation).cwiseAbs().maxCoeff(), tol);
  EXPECT_LT((a.cam_from_world.translation - b.cam_from_world.translation).cwiseAbs().maxCoeff(), tol);
}

void ExpectSameRig(const std::vector<Camera>& truth, const Rig& rig, double tol = 1e-9) {
  ASSERT_EQ(rig.cameras.size(), truth.size());
  for (size_t i = 0; i < truth.size(); ++i) {
    EXPECT_EQ(rig.cameras[i].camera.id, truth[i].id);
    ExpectSameCamera(truth[i], rig.cameras[i].camera, tol);
  }
}

std::string G(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", v);
  return b;
}

// COLMAP text: OPENCV model, principal point in COLMAP's convention (pixel
// centres at +0.5, hullpipe's own), qvec/tvec = cam_from_world, lengths in
// model units (`units_per_metre`).
void WriteColmapText(const fs::path& dir, const std::vector<Camera>& cams, double units_per_metre = 1.0) {
  fs::create_directories(dir);
  std::ofstream c(dir / "cameras.txt"), im(dir / "images.txt");
  c << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  im << "# Image list with two lines of data per image:\n";
  for (const auto& cam : cams) {
    c << cam.id << " OPENCV " << cam.width << " " << cam.height << " " << G(cam.fx) << " " << G(cam.fy) << " "
      << G(cam.cx) << " " << G(cam.cy);
    for (int k = 0; k < 4; ++k) c << " " << G(cam.distortion[size_t(k)]);
    c << "\n";
    const Eigen::Quaterniond q(cam.cam_from_world.rotation);
    const Eigen::Vector3d t = cam.cam_from_world.translation * units_per_metre;
    im << cam.id << " " << G(q.w()) << " " << G(q.x()) << " " << G(q.y()) << " " << G(q.z()) << " " << G(t.x())
       << " " << G(t.y()) << " " << G(t.z()) << " " << cam.id << " cam" << cam.id << ".png\n";
    im << (cam.id % 2 ? "12.5 20.25 -1 30.5 40.75 7\n" : "\n");  // some images without 2-D points
  }
}

template <typename T>
void Put(std::ofstream& f, T v) {
  f.write(reinterpret_cast<const char*>(&v), sizeof v);
}

void WriteColmapBinary(const fs::path& dir, const std::vector<Camera>& cams) {
  fs::create_directories(dir);
  std::ofstream c(dir / "cameras.bin", std::ios::binary), im(dir / "images.bin", std::ios::binary);
  Put<uint64_t>(c, cams.size());
  Put<uint64_t>(im, cams.size());
  for (const auto& cam : cams) {
    Put<uint32_t>(c, uint32_t(cam.id));
    Put<int32_t>(c, 4);  // OPENCV
    Put<uint64_t>(c, uint64_t(cam.width));
    Put<uint64_t>(c, uint64_t(cam.height));
    for (double v : {cam.fx, cam.fy, cam.cx, cam.cy, cam.distortion[0], cam.distortion[1], cam.distortion[2],
                     cam.distortion[3]})
      Put<double>(c, v);
    const Eigen::Quaterniond q(cam.cam_from_world.rotation);
    Put<uint32_t>(im, uint32_t(cam.id));
    for (double v : {q.w(), q.x(), q.y(), q.z()}) Put<double>(im, v);
    for (int k = 0; k < 3; ++k) Put<double>(im, cam.cam_from_world.translation[k]);
    Put<uint32_t>(im, uint32_t(cam.id));
    const std::string name = "cam" + std::to_string(cam.id) + ".png";
    im.write(name.c_str(), std::streamsize(name.size() + 1));
    Put<uint64_t>(im, 2);
    for (int p = 0; p < 2; ++p) {
      Put<double>(im, 1.5 * p);
      Put<double>(im, 2.5 * p);
      Put<uint64_t>(im, uint64_t(p));
    }
  }
}

// NeRF: world_from_camera with OpenGL camera axes (x right, y up, z backwards);
// cx, cy in continuous pixel coordinates (centres at +0.5), per-frame intrinsics.
void WriteNerf(const fs::path& file, const std::vector<Camera>& cams) {
  std::ofstream f(file);
  f << "{\n  \"camera_model\": \"OPENCV\",\n  \"frames\": [\n";
  for (size_t i = 0; i < cams.size(); ++i) {
    const Camera& c = cams[i];
    const Rigid3d w = c.cam_from_world.Inverse();
    const Eigen::Matrix3d r_gl = w.rotation * Eigen::Vector3d(1, -1, -1).asDiagonal();
    f << "    {\"file_path\": \"./images/c" << c.id << "\", \"w\": " << c.width << ", \"h\": " << c.height
      << ", \"fl_x\": " << G(c.fx) << ", \"fl_y\": " << G(c.fy) << ", \"cx\": " << G(c.cx) << ", \"cy\": " << G(c.cy)
      << ", \"k1\": " << G(c.distortion[0]) << ", \"k2\": " << G(c.distortion[1]) << ", \"p1\": "
      << G(c.distortion[2]) << ", \"p2\": " << G(c.distortion[3]) << ",\n     \"transform_matrix\": [";
    for (int r = 0; r < 4; ++r) {
      f << (r ? ", " : "") << "[";
      for (int k = 0; k < 4; ++k)
        f << (k ? ", " : "") << G(r == 3 ? (k == 3 ? 1.0 : 0.0) : k < 3 ? r_gl(r, k) : w.translation[r]);
      f << "]";
    }
    f << "]}" << (i + 1 < cams.size() ? "," : "") << "\n";
  }
  f << "  ]\n}\n";
}

// Middlebury *_par.txt: K with pixel centres at integers, R and t cam_from_world;
// the images beside it give the size.
void WriteMiddlebury(const fs::path& dir, const std::vector<Camera>& cams) {
  fs::create_directories(dir);
  std::ofstream f(dir / "rig_par.txt");
  f << cams.size() << "\n";
  for (const auto& c : cams) {
    const std::string name = "rig" + std::to_string(c.id) + ".png";
    cv::imwrite((dir / name).string(), cv::Mat(c.height, c.width, CV_8UC3, cv::Scalar(20, 40, 60)));
    f << name;
    for (double v : {c.fx, 0.0, c.cx - kOpenCvToHullpipePixelOffset, 0.0, c.fy, c.cy - kOpenCvToHullpipePixelOffset,
                     0.0, 0.0, 1.0})
      f << " " << G(v);
    for (int k = 0; k < 9; ++k) f << " " << G(c.cam_from_world.rotation(k / 3, k % 3));
    for (int k = 0; k < 3; ++k) f << " " << G(c.cam_from_world.translation[k]);
    f << "\n";
  }
}

// opencv_contrib ccalib's multi-camera file, written with cv::FileStorage (in
// millimetres, as a pattern measured in millimetres gives).
void WriteMulticalib(const fs::path& file, const std::vector<Camera>& cams, bool world_from_camera = false) {
  cv::FileStorage f(file.string(), cv::FileStorage::WRITE);
  f << "nCameras" << int(cams.size());
  f << "image_width" << cams[0].width << "image_height" << cams[0].height;
  for (size_t i = 0; i < cams.size(); ++i) {
    const Camera& c = cams[i];
    const cv::Mat k = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx - 0.5, 0, c.fy, c.cy - 0.5, 0, 0, 1);
    const cv::Mat d = (cv::Mat_<double>(1, 5) << c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3],
                       c.distortion[4]);
    const Rigid3d p = world_from_camera ? c.cam_from_world.Inverse() : c.cam_from_world;
    cv::Mat pose = cv::Mat::eye(4, 4, CV_64F);
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) pose.at<double>(r, col) = p.rotation(r, col);
      pose.at<double>(r, 3) = p.translation[r] * 1000.0;
    }
    f << "camera_matrix_" + std::to_string(i) << k << "camera_distortion_" + std::to_string(i) << d
      << "camera_pose_" + std::to_string(i) << pose;
  }
}

TEST(RigImport, ColmapTextAndBinaryReadBackTheSameCameras) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("colmap");
  WriteColmapText(dir / "text", cams);
  ExpectSameRig(cams, ImportColmap((dir / "text").string()));
  WriteColmapBinary(dir / "bin" / "sparse" / "0", cams);
  ExpectSameRig(cams, ImportColmap((dir / "bin").string()));  // finds sparse/0 itself
}

TEST(RigImport, NerfReadsBackTheSameCamerasThroughTheOpenGlAxes) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("nerf");
  WriteNerf(dir / "transforms.json", cams);
  const Rig rig = ImportNerf((dir / "transforms.json").string());
  ExpectSameRig(cams, rig);
  // The trap itself: OpenGL axes taken as OpenCV's would put the point every
  // camera looks at behind them.
  for (const auto& rc : rig.cameras) {
    const auto uv = rc.camera.Project(Eigen::Vector3d(0.4, -0.2, 1.0));
    ASSERT_TRUE(uv.has_value());
    EXPECT_TRUE(rc.camera.InImage(*uv));
  }
}

TEST(RigImport, NerfCameraAngleGivesTheFocalLength) {
  const auto dir = test::TempDir("nerf_angle");
  // The original NeRF layout: one camera_angle_x, images give the size.
  fs::create_directories(dir / "train");
  cv::imwrite((dir / "train" / "r_0.png").string(), cv::Mat(200, 400, CV_8UC4, cv::Scalar(0, 0, 0, 0)));
  std::ofstream(dir / "transforms.json")
      << R"({"camera_angle_x": 0.6911112070083618, "frames": [{"file_path": "./train/r_0", "transform_matrix": )"
      << R"([[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]})";
  const Rig rig = ImportNerf((dir / "transforms.json").string());
  ASSERT_EQ(rig.cameras.size(), 1u);
  const Camera& c = rig.cameras[0].camera;
  EXPECT_EQ(c.width, 400);
  EXPECT_EQ(c.height, 200);
  EXPECT_NEAR(c.fx, 200.0 / std::tan(0.5 * 0.6911112070083618), 1e-9);
  EXPECT_NEAR(c.cx, 200.0, 1e-12);  // the image centre, continuous coordinates
  // Camera at (0,0,4) looking down -z (OpenGL): the origin projects to the centre.
  const auto uv = c.Project(Eigen::Vector3d::Zero());
  ASSERT_TRUE(uv.has_value());
  EXPECT_NEAR((*uv - Eigen::Vector2d(200, 100)).norm(), 0, 1e-9);
}

TEST(RigImport, MiddleburyReadsBackTheSameCamerasWithIntegerPixelCentres) {
  const auto cams = ZUpRig(false);  // Middlebury has no distortion
  const auto dir = test::TempDir("middlebury");
  WriteMiddlebury(dir, cams);
  ExpectSameRig(cams, ImportMiddlebury((dir / "rig_par.txt").string()));
}

TEST(RigImport, OpenCvMulticalibReadsBackInMillimetresAndEitherPoseDirection) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("opencv");
  WriteMulticalib(dir / "multi.yml", cams);
  ImportOptions o;
  o.scale = 0.001;
  ExpectSameRig(cams, ImportOpenCvYaml((dir / "multi.yml").string(), o));
  WriteMulticalib(dir / "multi_inv.yml", cams, /*world_from_camera=*/true);
  o.poses_world_from_camera = true;
  ExpectSameRig(cams, ImportOpenCvYaml((dir / "multi_inv.yml").string(), o));
  // The trap: the inverse poses read as cam_from_world put cameras looking away.
  o.poses_world_from_camera = false;
  const Rig wrong = ImportOpenCvYaml((dir / "multi_inv.yml").string(), o);
  const RigReport report = CheckRig(wrong.Cameras(), wrong.workspace, wrong.world);
  bool hinted = false;
  for (const auto& w : report.warnings) hinted |= w.find("world_from_camera") != std::string::npos;
  EXPECT_TRUE(hinted) << "no warning names the pose-direction trap; " << report.warnings.size()
                      << " warnings: " << (report.warnings.empty() ? "" : report.warnings[0]);
  const RigReport right = CheckRig(cams, DefaultWorkspace(cams), wrong.world);
  EXPECT_TRUE(right.warnings.empty()) << right.warnings.front();  // control: the right rig warns of nothing
}

TEST(RigImport, OpenCvStereoCalibrationReadsBothCameras) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("stereo");
  // As OpenCV's stereo_calib sample writes them: intrinsics.yml and extrinsics.yml.
  {
    cv::FileStorage in((dir / "intrinsics.yml").string(), cv::FileStorage::WRITE);
    for (int i = 0; i < 2; ++i) {
      const Camera& c = cams[size_t(i)];
      in << "M" + std::to_string(i + 1)
         << (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx - 0.5, 0, c.fy, c.cy - 0.5, 0, 0, 1);
      in << "D" + std::to_string(i + 1)
         << (cv::Mat_<double>(1, 5) << c.distortion[0], c.distortion[1], c.distortion[2], c.distortion[3], 0);
    }
    cv::FileStorage ex((dir / "extrinsics.yml").string(), cv::FileStorage::WRITE);
    const Rigid3d c2_from_c1 = cams[1].cam_from_world * cams[0].cam_from_world.Inverse();
    cv::Mat r(3, 3, CV_64F), t(3, 1, CV_64F);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) r.at<double>(a, b) = c2_from_c1.rotation(a, b);
      t.at<double>(a) = c2_from_c1.translation[a];
    }
    ex << "R" << r << "T" << t;
  }
  ImportOptions o;
  o.width = 640;
  o.height = 480;
  const Rig rig = ImportOpenCvYaml(dir.string(), o);
  ASSERT_EQ(rig.cameras.size(), 2u);
  // The world is camera 1's frame.
  Camera c1 = cams[0], c2 = cams[1];
  c2.cam_from_world = cams[1].cam_from_world * cams[0].cam_from_world.Inverse();
  c1.cam_from_world = Rigid3d{};
  ExpectSameCamera(c1, rig.cameras[0].camera);
  ExpectSameCamera(c2, rig.cameras[1].camera);
}

TEST(RigImport, MillimetresAreScaledOrWarnedAbout) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("colmap_mm");
  WriteColmapText(dir, cams, 1000.0);
  ImportOptions o;
  o.scale = 0.001;
  ExpectSameRig(cams, ImportColmap(dir.string(), o));
  const Rig raw = ImportColmap(dir.string());
  bool warned = false;
  for (const auto& w : CheckRig(raw.Cameras(), raw.workspace, raw.world).warnings)
    warned |= w.find("millimetres") != std::string::npos;
  EXPECT_TRUE(warned);
  for (const auto& w : CheckRig(cams, DefaultWorkspace(cams), raw.world).warnings)
    EXPECT_EQ(w.find("millimetres"), std::string::npos) << w;  // control: metres are not warned about
  // Far beyond int's range the distance is still printed right (it printed
  // "-2147483648 m apart").
  auto far = cams;
  far[1].cam_from_world.translation += far[1].cam_from_world.rotation * Eigen::Vector3d(3e9, 0, 0);
  bool said = false;
  for (const auto& w : CheckRig(far, DefaultWorkspace(cams), raw.world).warnings)
    said |= w.find("the cameras are 3e+09 m apart") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(RigImport, NearRotationsAreRepairedOnceAndNonRotationsRefused) {
  auto cams = ZUpRig(false);
  const auto dir = test::TempDir("nearrot");
  WriteMiddlebury(dir, cams);
  // Six printed decimals, as published calibrations have them.
  {
    std::ifstream in(dir / "rig_par.txt");
    std::string line, out;
    std::getline(in, line);
    out = line + "\n";
    while (std::getline(in, line)) {
      std::istringstream ls(line);
      std::string name;
      ls >> name;
      out += name;
      double v;
      int k = 0;
      while (ls >> v) {
        char b[40];
        std::snprintf(b, sizeof b, k >= 9 && k < 18 ? " %.6f" : " %.17g", v);
        out += b;
        ++k;
      }
      out += "\n";
    }
    std::ofstream(dir / "rig_par.txt") << out;
  }
  // Camera::Check would refuse these (orthonormal to 1e-6 only).
  const Rig rig = ImportMiddlebury((dir / "rig_par.txt").string());
  ASSERT_EQ(rig.notes.size(), 1u);
  EXPECT_NE(rig.notes[0].find("nearest rotation"), std::string::npos) << rig.notes[0];
  for (size_t i = 0; i < cams.size(); ++i) {
    const Eigen::Matrix3d& r = rig.cameras[i].camera.cam_from_world.rotation;
    EXPECT_LT((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_LT((r - cams[i].cam_from_world.rotation).cwiseAbs().maxCoeff(), 2e-6);  // the printed precision
  }
  // Clearly not rotations: scaled by 1.01, a reflection.
  Eigen::Matrix3d scaled = 1.01 * cams[0].cam_from_world.rotation;
  EXPECT_THROW(NearestRotation(scaled, "x"), CalibrationError);
  Eigen::Matrix3d reflected = cams[0].cam_from_world.rotation;
  reflected.row(0) *= -1;
  try {
    NearestRotation(reflected, "rig.yaml: camera 3: key 'R'");
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 3: key 'R': not a rotation"), std::string::npos) << e.what();
  }
  EXPECT_EQ(NearestRotation(cams[0].cam_from_world.rotation, "x"), cams[0].cam_from_world.rotation);
}

TEST(RigImport, SkewIsKeptAndUnsupportedModelsAreRefusedWithTheirReason) {
  const auto cams = ZUpRig(false);
  const auto dir = test::TempDir("refuse");
  WriteMiddlebury(dir, cams);
  std::string text;
  {
    std::ifstream in(dir / "rig_par.txt");
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  // Skew 17 px in camera 1's K (k12).
  const size_t at = text.find(' ', text.find("rig1.png") + 9);
  text.replace(at, text.find(' ', at + 1) - at, " 17");
  std::ofstream(dir / "skew_par.txt") << text;
  {
    const Rig skewed = ImportMiddlebury((dir / "skew_par.txt").string());
    const Camera& c = skewed.cameras.at(0).camera;
    EXPECT_EQ(c.skew, 17.0);
    // The point at camera 1's principal ray one metre in front, moved 0.1 m
    // along the camera's y: v moves by fy 0.1, u by the skew's 17 x 0.1.
    const Eigen::Vector3d X = c.Center() + c.cam_from_world.rotation.transpose() * Eigen::Vector3d(0, 0.1, 1.0);
    const Eigen::Vector2d uv = *c.Project(X);
    EXPECT_NEAR(uv.x(), c.cx + 1.7, 1e-9);
    EXPECT_NEAR(uv.y(), c.cy + 0.1 * c.fy, 1e-9);
  }
  const auto cdir = test::TempDir("fisheye");
  WriteColmapText(cdir, cams);
  std::ifstream in(cdir / "cameras.txt");
  std::string all((std::istreambuf_iterator<char>(in)), {});
  all.replace(all.find(" OPENCV "), 8, " OPENCV_FISHEYE ");
  std::ofstream(cdir / "cameras.txt") << all;
  try {
    ImportColmap(cdir.string());
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("OPENCV_FISHEYE is not supported"), std::string::npos) << e.what();
  }
}

// PMVS camera files: "CONTOUR" and P = s K [R t] at any scale and sign, as
// data sets that publish 3x4 projection matrices give them. Decomposed back to
// the cameras (skew included, 0.01 fx here) to 1e-9 relative; P's scale, its
// sign and the file order do not matter; a singular P is refused naming the
// file.
TEST(RigImport, PmvsProjectionMatricesAreDecomposedWithTheirSkew) {
  auto cams = ZUpRig(false);
  for (auto& c : cams) c.skew = 0.01 * c.fx * (c.id % 2 ? 1 : -1);
  const auto dir = test::TempDir("pmvs");
  fs::create_directories(dir / "txt");
  fs::create_directories(dir / "visualize");
  for (size_t i = 0; i < cams.size(); ++i) {
    const Camera& c = cams[i];
    Eigen::Matrix3d K = c.K();
    K(0, 2) -= kOpenCvToHullpipePixelOffset, K(1, 2) -= kOpenCvToHullpipePixelOffset;  // PMVS: integer centres
    Eigen::Matrix<double, 3, 4> Rt;
    Rt << c.cam_from_world.rotation, c.cam_from_world.translation;
    const Eigen::Matrix<double, 3, 4> P = (i % 2 ? -2.5 : 0.01) * K * Rt;
    char name[32];
    std::snprintf(name, sizeof name, "%08zu", i);
    std::ofstream f(dir / "txt" / (std::string(name) + ".txt"));
    f << "CONTOUR\n";
    for (int r = 0; r < 3; ++r) f << G(P(r, 0)) << " " << G(P(r, 1)) << " " << G(P(r, 2)) << " " << G(P(r, 3)) << "\n";
    cv::imwrite((dir / "visualize" / (std::string(name) + ".jpg")).string(),
                cv::Mat(c.height, c.width, CV_8UC3, cv::Scalar(20, 40, 60)));
  }
  const Rig rig = ImportRig("pmvs", dir.string());
  ExpectSameRig(cams, rig);
  EXPECT_NE(rig.cameras[0].frames.find("visualize/00000000.jpg"), std::string::npos);
  std::ofstream(dir / "txt" / "00000000.txt") << "CONTOUR\n1 0 0 0\n0 1 0 0\n1 0 0 0\n";
  try {
    ImportPmvs(dir.string());
    FAIL();
  } catch (const CalibrationError& e) {
    EXPECT_NE(std::string(e.what()).find("00000000.txt: P is singular"), std::string::npos) << e.what();
  }
}

// Files that crashed the OpenCV importer (docs/reliability.md): each ends in
// one CalibrationError naming the file and what is wrong.
TEST(RigImport, HostileOpenCvFilesAreRefusedInOneLine) {
  const auto dir = test::TempDir("hostile_opencv");
  auto expect_refused = [&](const std::string& name, const std::string& text, const std::string& says) {
    const fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << text;
    try {
      ImportOptions sized;
      sized.width = 640;
      sized.height = 480;
      ImportOpenCvYaml(p.string(), sized);
      ADD_FAILURE() << name << " was accepted";
    } catch (const CalibrationError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(p.string() + ": ", 0), 0u) << what;
      EXPECT_NE(what.find(says), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  };
  // An XML attribute cut off at the end: OpenCV 4.6 dereferenced NULL.
  expect_refused("cut.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>\n<op vo=", "not well-formed XML");
  // 40,000 nested sequences: OpenCV's YAML parser overflowed the stack.
  expect_refused("deep.yml", "%YAML:1.0\nnCameras: " + std::string(40000, '['), "nested deeper than 64");
  // A '-' line where a second document would start: OpenCV 4.6's YAML parser
  // looped forever (fuzz_rig_files); parsed in a bounded child, it is refused
  // within kMaxStorageParseSeconds.
  const auto t0 = std::chrono::steady_clock::now();
  expect_refused("loops.yml", "%YAML:1.\n s:3\na-\n-", "did not finish reading it within 5 s");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
            kMaxStorageParseSeconds + 2.0);
  // Many flat sequences, none deep: bounded by their number.
  std::string flat = "%YAML:1.0\nx: [";
  for (int i = 0; i < 5000; ++i) flat += "[1],";
  expect_refused("flat.yml", flat + "]\n", "more than 4096 sequences and maps");
  // A stereo calibration whose R is 1x9: nine values, read as 3x3 past its buffer.
  const std::string m =
      "!!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n";
  const std::string d = "!!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n";
  expect_refused(
      "stereo.yml",
      "%YAML:1.0\nM1: " + m + "D1: " + d + "M2: " + m + "D2: " + d +
          "R: !!opencv-matrix\n   rows: 1\n   cols: 9\n   dt: d\n   data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n"
          "T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ -0.1, 0., 0. ]\n",
      "R is 1x9");
  // Control: the same stereo file with a 3x3 R imports.
  const fs::path good = dir / "good.yml";
  std::ofstream(good) << "%YAML:1.0\nM1: " + m + "D1: " + d + "M2: " + m + "D2: " + d +
                             "R: " + m.substr(0, m.find("data")) + "data: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]\n"
                             "T: !!opencv-matrix\n   rows: 3\n   cols: 1\n   dt: d\n   data: [ -0.1, 0., 0. ]\n";
  ImportOptions o;
  o.width = 640;
  o.height = 480;
  EXPECT_EQ(ImportOpenCvYaml(good.string(), o).cameras.size(), 2u);
}

// Lies and unclear messages: a COLMAP model whose IMAGE_IDs repeat (two
// cameras of one id: the assembler saw one, nothing composited) or pass int's
// range, a cameras.txt line short of parameters, a NeRF size of 1e300 or a
// file_path that is a number: each one line naming the file and the thing.
std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(RigImport, DuplicateOrOutOfRangeIdsAndBadNumbersAreNamed) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("lies");
  auto error_of = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const CalibrationError& e) {
      return e.what();
    }
    return "";
  };
  auto edit = [](const fs::path& file, const std::string& from, const std::string& to) {
    std::string text = Slurp(file);
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    std::ofstream(file) << text;
  };
  WriteColmapText(dir / "dup", cams);
  edit(dir / "dup" / "images.txt", "\n2 ", "\n1 ");  // image 2 now claims id 1
  EXPECT_NE(error_of([&] { ImportColmap((dir / "dup").string()); }).find("two cameras have id 1"), std::string::npos);
  WriteColmapText(dir / "big", cams);
  edit(dir / "big" / "images.txt", "\n2 ", "\n4294967295 ");
  EXPECT_NE(error_of([&] { ImportColmap((dir / "big").string()); }).find("IMAGE_ID 4294967295 is beyond 2147483647"),
            std::string::npos);
  WriteColmapText(dir / "short", cams);
  std::string text = Slurp(dir / "short" / "cameras.txt");
  text = text.substr(0, text.find_last_of(' ', text.find('\n', text.find("OPENCV")))) + "\n";  // a parameter less
  std::ofstream(dir / "short" / "cameras.txt") << text;
  EXPECT_NE(error_of([&] { ImportColmap((dir / "short").string()); }).find("OPENCV has 8 parameters, the line has 7"),
            std::string::npos);
  WriteColmapText(dir / "good", cams);
  EXPECT_EQ(error_of([&] { ImportColmap((dir / "good").string()); }), "") << "the control";

  WriteNerf(dir / "huge.json", cams);
  edit(dir / "huge.json", "\"w\": 640", "\"w\": 1e300");
  EXPECT_NE(error_of([&] {
              ImportNerf((dir / "huge.json").string());
            }).find("key 'w' must be whole pixels in [1, 16384], not 1e+300"),
            std::string::npos);
  WriteNerf(dir / "typed.json", cams);
  edit(dir / "typed.json", "\"file_path\": \"", "\"file_path\": 5, \"x\": \"");
  const std::string typed = error_of([&] { ImportNerf((dir / "typed.json").string()); });
  EXPECT_NE(typed.find("typed.json: frame 1: key 'file_path' must be text"), std::string::npos) << typed;
}

TEST(RigImport, ImportedRigsRoundTripThroughTheRigFile) {
  const auto cams = ZUpRig();
  const auto dir = test::TempDir("roundtrip");
  WriteColmapText(dir / "model", cams);
  const Rig rig = ImportColmap((dir / "model").string());
  WriteRigYaml(rig, (dir / "rig.yaml").string());
  const Rig back = LoadRig((dir / "rig.yaml").string());
  ExpectSameRig(cams, back, 1e-12);
  EXPECT_EQ(back.world.up, rig.world.up);
  EXPECT_EQ(back.world.up, Eigen::Vector3d(0, 0, 1));  // derived: the cameras' image-up, z-up
  EXPECT_NEAR(back.world.orbit_radius, rig.world.orbit_radius, 1e-12);
  EXPECT_TRUE(back.world.up_stated);  // written out, then stated
  EXPECT_EQ((back.workspace.min - rig.workspace.min).norm(), 0);
}

}  // namespace
}  // namespace hullpipe
