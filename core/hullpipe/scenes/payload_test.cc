// The payload spacing task (paper §5.2): the spacing sweep's known answer on a
// synthetic motion, a part's clearance from an exact sphere hull, and the
// spacing changed while running.
#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <fstream>

#include "hullpipe/scenes/scene_config.h"
#include "hullpipe/scenes/ball.h"
#include "hullpipe/scenes/cloth.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/scenes/particles.h"
#include "hullpipe/models/model_import.h"
#include "hullpipe/scenes/payload.h"
#include "hullpipe/geometry/rigid3.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/scenes/virtual_scene.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {



TEST(PayloadTask, SpacingSweepFindsTheKnownAnswerOfASyntheticMotion) {
  // The paper's pipe (a 14 x 4 cm capsule) swings across the gap, reaching 1 + 4
  // + 6 = 11 cm from the PMT's face: the true pipe needs 11 cm.
  PayloadConfig cfg;
  double needed = 0;
  auto motion = ExamplePipeMotion(cfg, 0.06, 15, &needed);
  ASSERT_NEAR(needed, 0.11, 1e-12);
  // The motion goes through its CSV file format unchanged (9 significant digits).
  const std::string csv = (test::TempDir("motion") / "pipe.csv").string();
  SavePipeMotion(csv, motion);
  const auto loaded = LoadPipeMotion(csv);
  ASSERT_EQ(loaded.size(), motion.size());
  for (size_t k = 0; k < motion.size(); ++k) EXPECT_TRUE(loaded[k].q.isApprox(motion[k].q, 1e-8)) << k;
  motion = loaded;
  Eigen::Vector3d target = cfg.pmt_centre;
  target.y() += cfg.pmt_half.y() + 0.1;
  const auto cams = DomeCameras(8, 2.5, target, 320, 240, 0.9);
  std::vector<VolumeQuery> hulls;
  for (const auto& pose : motion) {
    SyntheticScene s;
    s.shapes.push_back(Shape::Capsule(pose.p, pose.q, pose.radius));
    hulls.push_back(test::HullOf(s, cams));
  }
  const SpacingSweepResult r = SweepSpacing(cfg, hulls, 0.08, 0.16, 0.02, 0.001);
  EXPECT_EQ(r.pmt_frames_colliding, 0);  // the motion keeps 1 cm off the PMT
  ASSERT_FALSE(std::isnan(r.smallest_free));
  // Exact maps mark a pixel whose centre ray hits the pipe, so the hull's side
  // differs from the pipe's by under one camera pixel's footprint at 2.5 m
  // (7.5 mm at 320 px over 0.9 rad), either way; plus the 1 mm bisection.
  EXPECT_NEAR(r.smallest_free, needed, 0.0085);
  // The table: colliding below the answer, free above it.
  for (const auto& row : r.rows) EXPECT_EQ(row.frames_colliding > 0, row.spacing < r.smallest_free) << row.spacing;
}

TEST(PayloadTask, ClearanceOfABoxFromASphereHull) {
  // A sphere (r 0.2) seen by 8 dome cameras; a box part 10 cm from it along +x.
  // The hull's side differs from the sphere's by under a pixel footprint (7.5 mm
  // at 2.5 m; exact maps sample pixel centres), either way.
  const Eigen::Vector3d c(0, 0, -1.0);
  SyntheticScene s;
  s.shapes.push_back(Shape::Sphere(c, 0.2));
  const VolumeQuery q = test::HullOf(s, DomeCameras(8, 2.5, c, 320, 240, 0.9));
  PayloadPart box;
  box.centre = c + Eigen::Vector3d(0.2 + 0.1 + 0.05, 0, 0);
  box.half_extents = Eigen::Vector3d(0.05, 0.1, 0.1);
  const ClearanceResult r = HullClearance(q, box, 0.15);
  EXPECT_TRUE(r.hull_near);
  EXPECT_FALSE(r.colliding);
  EXPECT_NEAR(r.distance, 0.1, 0.0075 + 0.0002);  // + half the finest grid's diagonal
  // Moved into the sphere: colliding, clearance 0.
  box.centre.x() -= 0.12;
  const ClearanceResult in = HullClearance(q, box, 0.15);
  EXPECT_TRUE(in.colliding);
  EXPECT_EQ(in.distance, 0.0);
}

TEST(PayloadTask, SpacingChangesWhileRunningAndBadValuesAreRefused) {
  SceneConfig cfg;
  cfg.Set(PayloadConfig{});
  VirtualScene scene(cfg);
  scene.SetSpacing(0.2);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);
  EXPECT_DOUBLE_EQ(scene.config().Find<PayloadConfig>()->spacing, 0.2);  // one copy of the settings
  EXPECT_THROW(scene.SetSpacing(-1), std::invalid_argument);
  EXPECT_THROW(scene.SetSpacing(std::nan("")), std::invalid_argument);
  EXPECT_DOUBLE_EQ(scene.payload()->spacing, 0.2);  // unchanged
  const auto parts = scene.payload()->Parts();
  EXPECT_NEAR(parts[1].Bounds().min.y() - parts[0].Bounds().max.y(), 0.2, 1e-12);
  SceneConfig none;
  VirtualScene no_payload(none);
  EXPECT_THROW(no_payload.SetSpacing(0.2), std::invalid_argument);
}

// The paper's task used the payload's CAD models. Payload A as a model file of
// exactly its box (a cube OBJ in millimetres, one vertex copy per face, as
// files carry them) is placed where the box part is and measures what it
// measures: the same collisions and clearances, to rounding, against one hull,
// at two spacings. A model's box stands for the box keys, which are refused
// beside it.
TEST(PayloadTask, APayloadModelOfTheBoxMeasuresAsTheBox) {
  const auto dir = test::TempDir("payload_model");
  PayloadConfig box_cfg;
  const Eigen::Vector3d h = box_cfg.a_half * 1000;  // mm
  {
    std::ofstream obj(dir / "a.obj");
    obj << "o payload_a\n";
    const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    int n = 0;
    for (const auto& f : faces) {
      for (int k = 0; k < 4; ++k) {
        const int c = f[k];
        obj << "v " << ((c & 4) ? h.x() : -h.x()) << " " << ((c & 2) ? h.y() : -h.y()) << " "
            << ((c & 1) ? h.z() : -h.z()) << "\n";
      }
      obj << "f " << n + 1 << " " << n + 2 << " " << n + 3 << "\nf " << n + 1 << " " << n + 3 << " " << n + 4
          << "\n";
      n += 4;
    }
  }
  // Offset from the box's centre in the file: placement goes by the model's box.
  std::ofstream(dir / "scene.yaml") << "balls: []\npayload: {a_model: {file: a.obj, units: mm}}\n";
  const SceneConfig scene = LoadSceneConfig((dir / "scene.yaml").string());
  const PayloadConfig* model_cfg = scene.Find<PayloadConfig>();
  ASSERT_NE(model_cfg, nullptr);
  ASSERT_TRUE(model_cfg->a_model && model_cfg->a_model->shape);
  EXPECT_TRUE(model_cfg->a_model->shape->closed());
  EXPECT_EQ(model_cfg->PartCount(), 2);
  EXPECT_EQ(model_cfg->ObjectIds()[0].last, model_cfg->first_id + 1);

  // A sphere hull reaching into payload A's side at the default spacing.
  const auto box_parts = box_cfg.Parts();
  const Eigen::Vector3d c = box_parts[1].centre + Eigen::Vector3d(0.15 + 0.15, 0, 0);
  SyntheticScene s;
  s.shapes.push_back(Shape::Sphere(c, 0.2));
  const VolumeQuery q = test::HullOf(s, DomeCameras(8, 2.5, c, 320, 240, 0.9));
  for (double spacing : {0.14, 0.50}) {
    PayloadConfig a = box_cfg, b = *model_cfg;
    a.spacing = b.spacing = spacing;
    const PayloadFrame fa = EvaluatePayload(a, &q), fb = EvaluatePayload(b, &q);
    ASSERT_EQ(fb.parts.size(), 2u);
    for (size_t k = 0; k < 2; ++k) {
      EXPECT_TRUE(fb.parts[k].centre.isApprox(fa.parts[k].centre, 1e-12)) << k;
      EXPECT_TRUE(fb.parts[k].half_extents.isApprox(fa.parts[k].half_extents, 1e-12)) << k;
      EXPECT_EQ(fb.clearance[k].colliding, fa.clearance[k].colliding) << spacing << " " << k;
      EXPECT_NEAR(fb.clearance[k].distance, fa.clearance[k].distance, 1e-9) << spacing << " " << k;
    }
    EXPECT_EQ(fb.collisions[1].colliding(), fb.clearance[1].colliding) << spacing;
  }
  // The hull reaches into A at 14 cm and clears it at 50 cm (a control that
  // the comparison saw both).
  PayloadConfig near = *model_cfg, far = *model_cfg;
  far.spacing = 0.50;
  EXPECT_TRUE(EvaluatePayload(near, &q).clearance[1].colliding);
  EXPECT_FALSE(EvaluatePayload(far, &q).clearance[1].colliding);

  std::ofstream(dir / "both.yaml") << "balls: []\npayload: {a_model: {file: a.obj, units: mm}, a_half: [1, 1, 1]}\n";
  try {
    LoadSceneConfig((dir / "both.yaml").string());
    ADD_FAILURE() << "a_half beside a_model was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'payload.a_half' with 'payload.a_model'"), std::string::npos) << e.what();
  }
}

// A part of the lab's engine (assimp-testmodels' two-cylinder engine, glTF in
// metres... by its specification) as the PMT: the part named is taken, placed
// by its box at pmt_centre, and payload A moves with the spacing; a part the
// file does not have, and a file with no units, are refused naming the key.
TEST(PayloadTask, APartOfTheEngineIsThePMT) {
  const std::string engine = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";
  const auto dir = test::TempDir("payload_engine");
  auto load = [&](const std::string& text) {
    std::ofstream(dir / "scene.yaml") << "balls: []\npayload: " << text << "\n";
    return LoadSceneConfig((dir / "scene.yaml").string());
  };
  // Find a part's name from the file itself.
  const ImportedModel model = ImportModelInProcess(engine);
  ASSERT_FALSE(model.parts.empty());
  const std::string part = model.parts[0].name;
  const SceneConfig scene = load("{pmt_model: {file: " + engine + ", part: \"" + part + "\", units: mm}}");
  const PayloadConfig* cfg = scene.Find<PayloadConfig>();
  ASSERT_NE(cfg, nullptr);
  const auto parts = cfg->Parts();
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].type, PayloadPart::Type::kMesh);
  EXPECT_EQ(parts[0].Mesh().triangles.size(), model.parts[0].triangles.size());
  EXPECT_TRUE(parts[0].Bounds().Center().isApprox(cfg->pmt_centre, 1e-9));
  // Payload A's near face is `spacing` from the part's box along the axis.
  EXPECT_NEAR(parts[1].Bounds().min[cfg->axis] - parts[0].Bounds().max[cfg->axis], cfg->spacing, 1e-9);
  // The signed distance is the mesh's: the part's own vertices are on it.
  for (size_t v = 0; v < parts[0].Mesh().vertices.size(); v += 97)
    EXPECT_NEAR(parts[0].SignedDistance(parts[0].Mesh().vertices[v]), 0.0, 1e-12);
  VirtualScene running(scene);
  running.SetSpacing(0.2);
  EXPECT_NE(running.Describe().find("PMT: " + engine + " part '" + part + "'"), std::string::npos)
      << running.Describe();

  for (const auto& [text, words] : std::vector<std::pair<std::string, std::string>>{
           {"{pmt_model: {file: " + engine + ", part: nothing_of_this_name}}", "has no part 'nothing_of_this_name'"},
           {"{pmt_model: {file: a.obj}}", "'payload.pmt_model': a.obj carries no units"},
           {"{pmt_model: {file: " + engine + "}}", "at most 100000 (take one of its parts: 'part')"},
           {"{pmt_model: {file: " + engine + ", unit: mm}}", "unknown key 'payload.pmt_model.unit'"},
           {"{pmt_model: {file: " + engine + ", rotation_deg: [0, 90]}}", "'rotation_deg' must have 3 numbers"}}) {
    try {
      load(text);
      ADD_FAILURE() << text << ": loaded";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << text << " -> " << e.what();
    }
  }
}

}  // namespace
}  // namespace hullpipe
