#include "hullpipe/dds/node_stats_convert.h"

namespace hullpipe::dds {

OwnedSample<hullpipe_msg_NodeStats> MakeNodeStatsMessage(const NodeStatsSample& s, int64_t stamp_ns) {
  OwnedSample<hullpipe_msg_NodeStats> o;
  // (Reserved first: the message borrows the strings' buffers.)
  o.strings.reserve(s.stages.size() + 3);
  o.strings.push_back(s.name);
  o.strings.push_back(s.backend);
  o.strings.push_back(s.host);
  for (const auto& [n, st] : s.stages) {
    o.strings.push_back(n);
    o.stages.push_back({const_cast<char*>(o.strings.back().c_str()), st.ms_mean, st.ms_p50, st.ms_p95, st.count});
  }
  auto& m = o.msg;
  m.node_name = const_cast<char*>(o.strings.front().c_str());
  m.stamp_ns = stamp_ns;
  m.frames_in = s.frames_in;
  m.frames_out = s.frames_out;
  m.dropped = s.dropped;
  m.rejected = s.rejected;
  m.fps = s.fps;
  m.latency_ms_p50 = s.latency_ms_p50;
  m.latency_ms_p95 = s.latency_ms_p95;
  Borrow(&m.stages, o.stages);
  m.final_report = s.final_report;
  m.dropped_for_skew = s.dropped_for_skew;
  for (const auto& c : s.cameras)
    o.cameras.push_back({uint32_t(c.camera_id), c.skew_ms_p50, c.skew_ms_p95, c.skew_ms_max, c.period_ms, c.frames,
                         c.unpartnered, c.pauses, c.restarts, c.clock_offsets});
  Borrow(&m.cameras, o.cameras);
  m.backend = const_cast<char*>(o.strings[1].c_str());
  m.host = const_cast<char*>(o.strings[2].c_str());
  m.run_id = s.run_id;
  return o;
}

namespace {
// A string from the wire that ends up in logs and stats.json: at most max_len
// bytes of valid UTF-8 (one bad byte from anyone on the domain must not spoil
// the run's record).
std::string WireText(const char* p, size_t max_len, const std::string& what) {
  const std::string t = p ? p : "";
  if (t.size() > max_len)
    throw MessageError("NodeStats: " + what + " longer than " + std::to_string(max_len) + " bytes");
  for (size_t i = 0; i < t.size();) {
    const auto c = uint8_t(t[i]);
    const size_t n = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xE ? 3 : (c >> 3) == 0x1E ? 4 : 0;
    if (n == 0 || i + n > t.size()) throw MessageError("NodeStats: " + what + " is not valid UTF-8");
    uint32_t cp = n == 1 ? c : n == 2 ? (c & 0x1F) : n == 3 ? (c & 0x0F) : (c & 0x07);
    for (size_t k = 1; k < n; ++k) {
      const auto cc = uint8_t(t[i + k]);
      if ((cc >> 6) != 0x2) throw MessageError("NodeStats: " + what + " is not valid UTF-8");
      cp = (cp << 6) | (cc & 0x3F);
    }
    const uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < least[n] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF) || cp == 0)
      throw MessageError("NodeStats: " + what + " is not valid UTF-8");
    i += n;
  }
  return t;
}
}  // namespace

NodeStatsSample NodeStatsFromMsg(const hullpipe_msg_NodeStats& m) {
  NodeStatsSample s;
  s.name = WireText(m.node_name, 64, "node_name");
  if (s.name.empty()) throw MessageError("NodeStats: empty node_name");
  s.fps = m.fps;
  s.latency_ms_p50 = m.latency_ms_p50;
  s.latency_ms_p95 = m.latency_ms_p95;
  s.frames_in = m.frames_in;
  s.frames_out = m.frames_out;
  s.dropped = m.dropped;
  s.rejected = m.rejected;
  s.final_report = m.final_report;
  s.run_id = m.run_id;
  for (uint32_t i = 0; i < m.stages._length; ++i) {
    const auto& st = m.stages._buffer[i];
    if (i >= 64) throw MessageError("NodeStats: more than 64 stages");
    s.stages[WireText(st.name ? st.name : "?", 64, "stage name")] = {st.ms_mean, st.ms_p50, st.ms_p95, st.count};
  }
  s.dropped_for_skew = m.dropped_for_skew;
  s.backend = WireText(m.backend, 512, "backend");
  s.host = WireText(m.host, 255, "host");
  for (uint32_t i = 0; i < m.cameras._length && i < 64; ++i) {
    const auto& c = m.cameras._buffer[i];
    CameraSkewReport r;
    r.camera_id = int(c.camera_id);
    r.skew_ms_p50 = c.skew_ms_p50;
    r.skew_ms_p95 = c.skew_ms_p95;
    r.skew_ms_max = c.skew_ms_max;
    r.period_ms = c.period_ms;
    r.frames = c.frames;
    r.unpartnered = c.unpartnered;
    r.pauses = c.pauses;
    r.restarts = c.restarts;
    r.clock_offsets = c.clock_offsets;
    s.cameras.push_back(r);
  }
  return s;
}

}  // namespace hullpipe::dds
