// The latency budget: where the time from a frame's capture to its composited
// output goes, stage by stage, from the nodes' own reports (NodeStats stages).
// docs/latency.md names every stage, says what its two stamps are and on whose
// clock each is taken. DDS-free; render_node writes it into stats.json, the
// end-of-run table and latency.tsv (scripts/latency_plot.sh draws the waterfall).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hullpipe/pipeline/node_counters.h"

namespace hullpipe::nodes {

/// One stage of one node in the budget.
struct BudgetRow {
  std::string node;   ///< NodeStats name: "capture", "recon0", "sim", "render"...
  std::string stage;  ///< Stage name (docs/latency.md).
  double p50_ms = 0, p95_ms = 0, mean_ms = 0;
  uint64_t count = 0;
  /// On the capture-to-composite critical path: the capture lane, then the
  /// recon lane that ends last, then render's stages after the last tile.
  bool on_path = false;
  /// Where the stage's bar starts in the waterfall, ms after capture: its lane's
  /// start plus the p50s of the lane's earlier stages.
  double start_ms = 0;
  /// Whose clocks the stage's two stamps are read on: "node" (both on the
  /// node's own monotonic clock), "writer->reader" (the DDS source timestamp on
  /// the writer's host, the take on the reader's), "timeline->node" (the frame's
  /// due time on the capture timeline, which another host may have announced).
  std::string stamps = "node";
  /// The two stamps were taken on different hosts (as NodeStats::host says);
  /// false where a host is unknown.
  bool crosses_hosts = false;
};

struct LatencyBudget {
  std::vector<BudgetRow> rows;  ///< capture lanes, recon lanes, sim, render; stages in pipeline order.
  /// render's capture-to-composite latency (its own FrameOut), ms.
  double end_to_end_p50_ms = 0, end_to_end_p95_ms = 0;
  /// Capture time (capture host) against render's clock: crosses hosts?
  bool end_to_end_crosses_hosts = false;
  /// Sum of the critical path's p50s, ms (a sum of medians is no median of
  /// sums: compare it with end_to_end_p50_ms, the gap is the path's spread and
  /// anything unmeasured).
  double path_p50_sum_ms = 0;
  std::string critical_recon;  ///< The recon lane on the path ("" when none reported).

  /// {"rows": [...], "end_to_end_ms": {...}, "path_p50_sum_ms", "critical_recon", "clocks"}.
  nlohmann::json ToJson() const;
  /// The end-of-run table (a header line and one line per row).
  std::string Table() const;
  /// Tab-separated rows for gnuplot: index, "node stage", start_ms, p50_ms,
  /// p95_ms, on_path (0/1), after two '#' lines: the end-to-end percentiles and
  /// the path's sum, then the column names.
  std::string WaterfallTsv() const;
};

/// The stages of a node kind ("capture", "recon", "sim", "render") in pipeline
/// order (docs/latency.md). A node's name selects its kind by prefix.
const std::vector<std::string>& StageOrder(const std::string& node_name);

/// Builds the budget from every node's newest report (render's own included,
/// under "render"). Stages a node reports that StageOrder does not list come
/// after its listed ones, off the path. Nodes without stages are left out.
LatencyBudget BuildLatencyBudget(const std::map<std::string, NodeStatsSample>& reports);

}  // namespace hullpipe::nodes
