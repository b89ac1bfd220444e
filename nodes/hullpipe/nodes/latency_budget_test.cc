#include "hullpipe/nodes/latency_budget.h"

#include <algorithm>

#include <gtest/gtest.h>

namespace hullpipe::nodes {
namespace {

NodeStatsSample Report(const std::string& name, const std::string& host,
                       std::vector<std::pair<std::string, double>> p50s) {
  NodeStatsSample r;
  r.name = name;
  r.host = host;
  for (const auto& [stage, p50] : p50s) r.stages[stage] = {p50, p50, 2 * p50, 10};
  return r;
}

const BudgetRow* Find(const LatencyBudget& b, const std::string& node, const std::string& stage) {
  for (const auto& r : b.rows)
    if (r.node == node && r.stage == stage) return &r;
  return nullptr;
}

// Two recon lanes, the second slower: the path is capture, recon1, then
// render's stages after the last tile; every bar starts where the previous
// stage of its lane ends (p50s summed in pipeline order).
std::map<std::string, NodeStatsSample> FiveNodes() {
  std::map<std::string, NodeStatsSample> m;
  m["capture"] = Report("capture", "a", {{"publish", 0.5}, {"read", 3}, {"lag", 2}, {"segment", 4}, {"encode", 1}});
  m["recon0"] =
      Report("recon0", "b", {{"transport_map", 1}, {"wait", 5}, {"sweep", 10}, {"texture", 3}, {"publish", 0.25}});
  m["recon1"] = Report(
      "recon1", "a",
      {{"transport_map", 1}, {"wait", 5}, {"sweep", 12}, {"texture", 3}, {"publish", 0.25}, {"transport_image", 2}});
  m["sim"] = Report("sim", "a", {{"step", 4}, {"transport_map", 1}});
  m["render"] = Report("render", "a", {{"composite", 2}, {"write", 1}, {"transport_tile", 0.5}, {"issue", 1},
                                       {"tiles", 30}, {"transport_map", 1}, {"gamma", 0.1}, {"publish", 0.5}});
  m["render"].latency_ms_p50 = 40;
  m["render"].latency_ms_p95 = 60;
  return m;
}

TEST(LatencyBudget, StagesFollowThePipelineAndThePathTakesTheSlowerReconLane) {
  const LatencyBudget b = BuildLatencyBudget(FiveNodes());
  std::vector<std::string> capture;
  for (const auto& r : b.rows)
    if (r.node == "capture") capture.push_back(r.stage);
  EXPECT_EQ(capture, (std::vector<std::string>{"lag", "read", "segment", "encode", "publish"}));
  EXPECT_EQ(b.rows.front().node, "capture");
  EXPECT_EQ(b.rows.back().node, "render");
  EXPECT_EQ(b.critical_recon, "recon1");
  // capture ends at 2 + 3 + 4 + 1 + 0.5 = 10.5 ms.
  EXPECT_DOUBLE_EQ(Find(b, "capture", "segment")->start_ms, 5.0);
  EXPECT_DOUBLE_EQ(Find(b, "recon1", "transport_map")->start_ms, 10.5);
  // transport_image runs beside transport_map: off the path, starting with it.
  EXPECT_FALSE(Find(b, "recon1", "transport_image")->on_path);
  EXPECT_DOUBLE_EQ(Find(b, "recon1", "transport_image")->start_ms, 10.5);
  EXPECT_TRUE(Find(b, "recon1", "sweep")->on_path);
  EXPECT_FALSE(Find(b, "recon0", "sweep")->on_path);
  // recon1 ends at 10.5 + 1 + 5 + 12 + 3 + 0.25 (its images come beside its maps).
  const double recon_end = 10.5 + 1 + 5 + 12 + 3 + 0.25;
  EXPECT_DOUBLE_EQ(Find(b, "render", "transport_tile")->start_ms, recon_end);
  EXPECT_DOUBLE_EQ(Find(b, "render", "composite")->start_ms, recon_end + 0.5);
  EXPECT_TRUE(Find(b, "render", "write")->on_path);
  // The composite published for viewers comes after the write, on the path.
  EXPECT_TRUE(Find(b, "render", "publish")->on_path);
  EXPECT_DOUBLE_EQ(Find(b, "render", "publish")->start_ms, recon_end + 0.5 + 2 + 1);
  // render's own frameset, pose and the tiles' round trip run beside recon.
  EXPECT_FALSE(Find(b, "render", "tiles")->on_path);
  EXPECT_DOUBLE_EQ(Find(b, "render", "transport_map")->start_ms, 10.5);
  EXPECT_FALSE(Find(b, "sim", "step")->on_path);
  // A stage the budget does not know comes last in its node, off the path.
  EXPECT_FALSE(Find(b, "render", "gamma")->on_path);
  EXPECT_EQ(b.rows.back().stage, "gamma");
  EXPECT_DOUBLE_EQ(b.path_p50_sum_ms, recon_end + 0.5 + 2 + 1 + 0.5);
  EXPECT_DOUBLE_EQ(b.end_to_end_p50_ms, 40);
  EXPECT_DOUBLE_EQ(Find(b, "recon1", "sweep")->p95_ms, 24);
}

TEST(LatencyBudget, SaysWhichStampsCrossHosts) {
  const LatencyBudget b = BuildLatencyBudget(FiveNodes());
  // Maps from capture (host a) to recon0 (host b) cross; to recon1 (a) not.
  EXPECT_TRUE(Find(b, "recon0", "transport_map")->crosses_hosts);
  EXPECT_FALSE(Find(b, "recon1", "transport_map")->crosses_hosts);
  EXPECT_EQ(Find(b, "recon0", "transport_map")->stamps, "writer->reader");
  // Tiles come to render (a) from recon0 (b) too.
  EXPECT_TRUE(Find(b, "render", "transport_tile")->crosses_hosts);
  // A stage within one node never does.
  EXPECT_FALSE(Find(b, "recon0", "sweep")->crosses_hosts);
  EXPECT_EQ(Find(b, "recon0", "sweep")->stamps, "node");
  EXPECT_EQ(Find(b, "capture", "lag")->stamps, "timeline->node");
  EXPECT_FALSE(b.end_to_end_crosses_hosts);
  auto other = FiveNodes();
  other["render"].host = "c";
  EXPECT_TRUE(BuildLatencyBudget(other).end_to_end_crosses_hosts);
  // Unknown hosts claim nothing.
  for (auto& [name, r] : other) r.host.clear();
  for (const auto& r : BuildLatencyBudget(other).rows) EXPECT_FALSE(r.crosses_hosts) << r.node << " " << r.stage;
}

TEST(LatencyBudget, JsonTableAndWaterfallCarryEveryRow) {
  const LatencyBudget b = BuildLatencyBudget(FiveNodes());
  const nlohmann::json j = b.ToJson();
  ASSERT_EQ(j["rows"].size(), b.rows.size());
  EXPECT_EQ(j["rows"][0]["stage"], "lag");
  EXPECT_EQ(j["end_to_end_ms"]["p95"], 60.0);
  EXPECT_EQ(j["critical_recon"], "recon1");
  const std::string table = b.Table();
  EXPECT_NE(table.find("sweep *"), std::string::npos);
  EXPECT_NE(table.find("(crosses hosts)"), std::string::npos);
  const std::string tsv = b.WaterfallTsv();
  EXPECT_EQ(size_t(std::count(tsv.begin(), tsv.end(), '\n')), b.rows.size() + 2);
  EXPECT_EQ(tsv.rfind("# end to end p50 40.0 ms, p95 60.0 ms", 0), 0u) << tsv;
  EXPECT_NE(tsv.find("\"recon1 sweep\"\t16.500\t12.000\t24.000\t1"), std::string::npos) << tsv;
  // Nodes without stages (an old peer) are left out; no report, no rows.
  EXPECT_TRUE(BuildLatencyBudget({}).rows.empty());
}

}  // namespace
}  // namespace hullpipe::nodes
