#include "hullpipe/nodes/latency_budget.h"

#include <algorithm>
#include <cstdio>
#include <set>

namespace hullpipe::nodes {
namespace {

std::string Kind(const std::string& name) {
  for (const char* k : {"capture", "recon", "sim", "render"})
    if (name.rfind(k, 0) == 0) return k;
  return "";
}

// Each kind's stages in pipeline order (docs/latency.md), and whether each
// follows the one before it in its node's lane (true) or runs beside it: recon's
// images beside its maps; render's own frameset, pose and the tiles' round trip
// beside the recon lanes.
struct StageDef {
  const char* name;
  bool sequential;
};
const std::map<std::string, std::vector<StageDef>>& Stages() {
  static const std::map<std::string, std::vector<StageDef>> stages = {
      {"capture", {{"lag", true}, {"read", true}, {"segment", true}, {"encode", true}, {"publish", true}}},
      {"recon",
       {{"transport_map", true}, {"transport_image", false}, {"wait", true}, {"hull_box", true}, {"upload", true},
        {"visibility", true}, {"sweep", true}, {"refine", true}, {"texture", true}, {"publish", true}}},
      {"sim", {{"transport_map", true}, {"wait", true}, {"step", true}, {"publish", true}}},
      {"render",
       {{"transport_map", false}, {"issue", false}, {"light_hull", false}, {"tiles", false},
        {"transport_tile", true}, {"composite", true}, {"light", true}, {"write", true}, {"publish", true}}},
  };
  return stages;
}

bool Sequential(const std::string& kind, const std::string& stage) {
  const auto it = Stages().find(kind);
  if (it == Stages().end()) return false;
  for (const StageDef& d : it->second)
    if (stage == d.name) return d.sequential;
  return false;
}

// Kinds whose lanes can be on the capture-to-composite path (sim's objects are
// composited from its newest state; render does not wait for them).
bool PathKind(const std::string& kind) { return kind == "capture" || kind == "recon" || kind == "render"; }

std::string Stamps(const std::string& stage) {
  if (stage.rfind("transport_", 0) == 0) return "writer->reader";
  if (stage == "lag") return "timeline->node";
  return "node";
}

// Hosts of the writers of a transport stage's samples.
std::set<std::string> WriterHosts(const std::string& stage, const std::map<std::string, NodeStatsSample>& reports) {
  const std::string writer_kind = stage == "transport_tile"                                ? "recon"
                                  : stage == "transport_map" || stage == "transport_image" ? "capture"
                                                                                           : "";
  std::set<std::string> hosts;
  for (const auto& [name, r] : reports)
    if (!writer_kind.empty() && Kind(name) == writer_kind && !r.host.empty()) hosts.insert(r.host);
  return hosts;
}

}  // namespace

const std::vector<std::string>& StageOrder(const std::string& node_name) {
  static const std::map<std::string, std::vector<std::string>> order = [] {
    std::map<std::string, std::vector<std::string>> o;
    for (const auto& [kind, defs] : Stages())
      for (const StageDef& d : defs) o[kind].push_back(d.name);
    return o;
  }();
  static const std::vector<std::string> none;
  const auto it = order.find(Kind(node_name));
  return it == order.end() ? none : it->second;
}

LatencyBudget BuildLatencyBudget(const std::map<std::string, NodeStatsSample>& reports) {
  LatencyBudget b;
  // Rows per node in pipeline order.
  struct Lane {
    std::string name, kind;
    std::vector<BudgetRow> rows;
    double path_ms = 0;  // sum of the on-path stages' p50s
  };
  std::vector<Lane> lanes;
  for (const auto& [name, r] : reports) {
    if (r.stages.empty()) continue;
    Lane lane{name, Kind(name), {}, 0};
    std::vector<std::string> names = StageOrder(name);
    for (const auto& [stage, s] : r.stages)
      if (std::find(names.begin(), names.end(), stage) == names.end()) names.push_back(stage);
    for (const auto& stage : names) {
      const auto it = r.stages.find(stage);
      if (it == r.stages.end()) continue;
      BudgetRow row;
      row.node = name;
      row.stage = stage;
      row.p50_ms = it->second.ms_p50;
      row.p95_ms = it->second.ms_p95;
      row.mean_ms = it->second.ms_mean;
      row.count = it->second.count;
      row.on_path = PathKind(lane.kind) && Sequential(lane.kind, stage);
      row.stamps = Stamps(stage);
      if (row.stamps == "writer->reader" && !r.host.empty())
        for (const auto& h : WriterHosts(stage, reports)) row.crosses_hosts = row.crosses_hosts || h != r.host;
      if (row.stamps == "timeline->node" && !r.host.empty())
        for (const auto& [other, o] : reports)
          if (Kind(other) == "capture" && !o.host.empty() && o.host != r.host) row.crosses_hosts = true;
      if (Sequential(lane.kind, stage)) lane.path_ms += row.p50_ms;
      lane.rows.push_back(std::move(row));
    }
    lanes.push_back(std::move(lane));
  }
  // Lane starts: capture at 0; recon and sim where the slowest capture lane
  // ends; render's path stages where the slowest recon lane ends.
  auto lanes_of = [&](const std::string& kind) {
    std::vector<Lane*> out;
    for (auto& l : lanes)
      if (l.kind == kind) out.push_back(&l);
    return out;
  };
  // A lane's sequential stages start where the previous one ends; a stage
  // beside them starts with the stage before it.
  auto place = [](Lane& lane, double start, bool path_lane) {
    double t = start, prev_start = start;
    for (auto& row : lane.rows) {
      if (!path_lane) row.on_path = false;
      if (Sequential(lane.kind, row.stage)) {
        row.start_ms = prev_start = t;
        t += row.p50_ms;
      } else {
        row.start_ms = prev_start;  // beside the stage before it
      }
    }
  };
  Lane* capture_path = nullptr;
  for (Lane* l : lanes_of("capture"))
    if (!capture_path || l->path_ms > capture_path->path_ms) capture_path = l;
  for (Lane* l : lanes_of("capture")) place(*l, 0, l == capture_path);
  const double capture_end = capture_path ? capture_path->path_ms : 0;
  Lane* recon_path = nullptr;
  for (Lane* l : lanes_of("recon"))
    if (!recon_path || l->path_ms > recon_path->path_ms) recon_path = l;
  for (Lane* l : lanes_of("recon")) place(*l, capture_end, l == recon_path);
  for (Lane* l : lanes_of("sim")) place(*l, capture_end, false);
  const double recon_end = capture_end + (recon_path ? recon_path->path_ms : 0);
  for (Lane* l : lanes_of("render")) {
    // Off-path stages (render's own frameset, the pose, the tiles' round trip)
    // run beside recon; the path stages follow the last tile.
    double off = capture_end, on = recon_end;
    for (auto& row : l->rows) {
      double& t = Sequential("render", row.stage) ? on : off;
      row.start_ms = t;
      t += row.p50_ms;
    }
  }
  for (Lane* l : lanes_of("")) place(*l, 0, false);
  if (recon_path) b.critical_recon = recon_path->name;
  // Rows: capture, recon, sim, render, others (each in name order).
  for (const char* kind : {"capture", "recon", "sim", "render", ""})
    for (Lane* l : lanes_of(kind))
      for (auto& row : l->rows) {
        if (row.on_path) b.path_p50_sum_ms += row.p50_ms;
        b.rows.push_back(row);
      }
  if (const auto it = reports.find("render"); it != reports.end()) {
    b.end_to_end_p50_ms = it->second.latency_ms_p50;
    b.end_to_end_p95_ms = it->second.latency_ms_p95;
    for (const auto& [name, r] : reports)
      if (Kind(name) == "capture" && !r.host.empty() && !it->second.host.empty() && r.host != it->second.host)
        b.end_to_end_crosses_hosts = true;
  }
  return b;
}

nlohmann::json LatencyBudget::ToJson() const {
  nlohmann::json rows_j = nlohmann::json::array();
  for (const auto& r : rows)
    rows_j.push_back({{"node", r.node},       {"stage", r.stage},     {"p50_ms", r.p50_ms},
                      {"p95_ms", r.p95_ms},   {"mean_ms", r.mean_ms}, {"count", r.count},
                      {"on_path", r.on_path}, {"start_ms", r.start_ms}, {"stamps", r.stamps},
                      {"crosses_hosts", r.crosses_hosts}});
  return {{"rows", rows_j},
          {"end_to_end_ms",
           {{"p50", end_to_end_p50_ms}, {"p95", end_to_end_p95_ms}, {"crosses_hosts", end_to_end_crosses_hosts}}},
          {"path_p50_sum_ms", path_p50_sum_ms},
          {"critical_recon", critical_recon},
          {"clocks",
           "node: both stamps on the node's monotonic clock; writer->reader: the DDS source timestamp "
           "(writer's host) to the take (reader's host); timeline->node: the frame's due time on the "
           "capture timeline to the node's read (docs/latency.md)"}};
}

std::string LatencyBudget::Table() const {
  std::string out;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%-10s %-16s %8s %8s %8s %8s  %s\n", "node", "stage (* path)", "p50 ms", "p95 ms",
                "start", "count", "stamps");
  out += buf;
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%-10s %-16s %8.2f %8.2f %8.1f %8llu  %s%s\n", r.node.c_str(),
                  (r.stage + (r.on_path ? " *" : "")).c_str(), r.p50_ms, r.p95_ms, r.start_ms,
                  (unsigned long long)r.count, r.stamps.c_str(), r.crosses_hosts ? " (crosses hosts)" : "");
    out += buf;
  }
  std::snprintf(buf, sizeof buf, "path: sum of p50s %.1f ms (recon lane %s); end to end p50 %.1f ms, p95 %.1f ms%s\n",
                path_p50_sum_ms, critical_recon.empty() ? "none" : critical_recon.c_str(), end_to_end_p50_ms,
                end_to_end_p95_ms, end_to_end_crosses_hosts ? " (capture and render clocks on different hosts)" : "");
  out += buf;
  return out;
}

std::string LatencyBudget::WaterfallTsv() const {
  char buf[256];
  std::snprintf(buf, sizeof buf, "# end to end p50 %.1f ms, p95 %.1f ms; path sum of p50s %.1f ms\n",
                end_to_end_p50_ms, end_to_end_p95_ms, path_p50_sum_ms);
  std::string out = buf;
  out += "# index\tlabel\tstart_ms\tp50_ms\tp95_ms\ton_path\n";
  int i = 0;
  for (const auto& r : rows) {
    std::snprintf(buf, sizeof buf, "%d\t\"%s %s\"\t%.3f\t%.3f\t%.3f\t%d\n", i++, r.node.c_str(), r.stage.c_str(),
                  r.start_ms, r.p50_ms, r.p95_ms, r.on_path ? 1 : 0);
    out += buf;
  }
  return out;
}

}  // namespace hullpipe::nodes
