// render_node's end-of-run report, fed directly: what stats.json says of
// collision responses, payload parts and model parts is what it was told.
#include "hullpipe/nodes/run_report.h"

#include <cmath>

#include <gtest/gtest.h>

#include "hullpipe/collision/hull_motion.h"

namespace hullpipe::nodes {
namespace {

TEST(RunReport, HullVelocityCountsEveryStatusAndAveragesOnlyMeasuredSpeeds) {
  RunReport r;
  using S = HullVelocityStatus;
  r.OnCollisionReport(true, uint8_t(S::kMeasured), -0.3);  // towards: the speed's size counts
  r.OnCollisionReport(true, uint8_t(S::kClamped), 10.0);
  r.OnCollisionReport(true, uint8_t(S::kMeasured), std::nan(""));  // counted, its speed not
  r.OnCollisionReport(false, uint8_t(S::kTooFarApart), 5.0);      // no speed
  r.OnCollisionReport(false, uint8_t(S::kNone), 0.0);            // no response: not counted
  r.OnCollisionReport(false, 200, 7.0);                          // unknown status: ignored
  const nlohmann::json j = r.StatsJson({});
  const auto& hv = j["hull_velocity"];
  EXPECT_EQ(hv["measured"], 2);
  EXPECT_EQ(hv["clamped"], 1);
  EXPECT_EQ(hv["too_far_apart"], 1);
  EXPECT_EQ(hv["no_previous"], 0);
  EXPECT_EQ(hv["max_normal_speed_mps"], 10.0);
  // (0.3 + 10) over the 3 measured or clamped responses (the NaN's is 0).
  EXPECT_NEAR(hv["mean_normal_speed_mps"].get<double>(), 10.3 / 3, 1e-12);
  EXPECT_EQ(j["collision_reports_with_points"], 3);
}

TEST(RunReport, PartsKeepTheirLeastClearanceAndTheirFramesInCollision) {
  RunReport r;
  r.OnMeshDrawn("payload", 7, 0.010, false);
  r.OnMeshDrawn("payload", 7, 0.002, true);
  r.OnMeshDrawn("payload", 7, 0.005, true);
  r.OnMeshDrawn("blocks", 7, 0.001, false);  // another element's object 7: its own entry
  r.OnMeshDrawn("cloth", 100, -1, true);      // no clearance measured
  ModelPartSample part;
  part.object_id = 101;
  part.model_id = 100;
  part.name = "piston";
  part.file = "engine.glb";
  part.triangles.resize(12);
  r.OnModelPart(part);
  ModelStateSample state;
  state.model_id = 100;
  state.triangles = 12;
  state.boxes_tested = 4;
  state.triangles_queried = 6;
  state.query_ms = 1.5;
  r.OnModelFrameset(state);
  r.OnModelPartDrawn(101, kPartNear, 0.004);
  r.OnModelPartDrawn(101, kPartColliding, -1);  // not measured: no clearance
  r.OnFrameDrawn(1, 3, true, 0.25);
  r.OnFrameDrawn(0, 2, false, 0.75);
  RunFacts facts;
  facts.frames_composited = 2;
  const nlohmann::json j = r.StatsJson(facts);
  const auto& e = j["elements"];
  EXPECT_NEAR(e["payload"]["7"]["min_clearance_mm"].get<double>(), 2.0, 1e-9);
  EXPECT_EQ(e["payload"]["7"]["frames_colliding"], 2);
  EXPECT_EQ(e["payload"]["7"]["frames_drawn"], 3);
  EXPECT_NEAR(e["blocks"]["7"]["min_clearance_mm"].get<double>(), 1.0, 1e-9);
  EXPECT_TRUE(e["cloth"]["100"]["min_clearance_mm"].is_null());
  EXPECT_EQ(e["cloth"]["100"]["frames_colliding"], 1);
  EXPECT_FALSE(j.contains("payload"));
  EXPECT_FALSE(j.contains("meshes_over_limit"));
  // Objects past the bound are counted, not kept (a peer publishing endless ids).
  RunReport flood;
  for (uint32_t id = 0; id <= RunReport::kMaxMeshObjects; ++id) flood.OnMeshDrawn("cloth", id, -1, false);
  const nlohmann::json f = flood.StatsJson(facts);
  EXPECT_EQ(f["elements"]["cloth"].size(), RunReport::kMaxMeshObjects);
  EXPECT_EQ(f["meshes_over_limit"], 1);
  ASSERT_EQ(j["models"].size(), 1u);
  const auto& m = j["models"][0];
  EXPECT_EQ(m["file"], "engine.glb");
  EXPECT_EQ(m["framesets"], 1);
  EXPECT_EQ(m["boxes_tested_mean"], 4.0);
  ASSERT_EQ(m["parts"].size(), 1u);
  EXPECT_EQ(m["parts"][0]["name"], "piston");
  EXPECT_EQ(m["parts"][0]["triangles"], 12);
  EXPECT_EQ(m["parts"][0]["frames_in_collision"], 1);
  EXPECT_EQ(m["parts"][0]["frames_near"], 1);
  EXPECT_NEAR(m["parts"][0]["clearance_mm_min"].get<double>(), 4.0, 1e-3);  // float storage
  EXPECT_EQ(j["collision_frames_drawn"], 1);
  EXPECT_EQ(j["meshes_drawn"], 5);
  EXPECT_EQ(j["lit_frames"], 1);
  EXPECT_EQ(j["hull_pixel_fraction_mean"], 0.5);
  EXPECT_NE(r.Table(facts).find("model engine.glb: 12 triangles"), std::string::npos) << r.Table(facts);
}

}  // namespace
}  // namespace hullpipe::nodes
