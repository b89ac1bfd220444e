// The rejection log's bound, on a fake clock: a burst in full, then one line a
// second carrying the count of the lines not written.
#include "hullpipe/util/reject_log.h"

#include <sstream>

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

namespace hullpipe {
namespace {

TEST(RejectLog, AFloodIsWrittenAsABurstThenALineASecondWithTheCount) {
  std::ostringstream text;
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::ostream_sink_mt>(text)));
  RejectLog log;
  // 10,000 rejections 1/4096 s apart (exact in binary) on the node's clock.
  int written = 0;
  for (int i = 0; i < 10000; ++i) written += log.Log("sample " + std::to_string(i), 100.0 + i / 4096.0) ? 1 : 0;
  spdlog::set_default_logger(previous);
  // The burst (samples 0..19), then samples 4115 and 8211, each a second
  // after the line before.
  EXPECT_EQ(written, RejectLog::kBurst + 2);
  EXPECT_EQ(log.lines(), written);
  const std::string out = text.str();
  EXPECT_NE(out.find("rejected: sample 0\n"), std::string::npos) << out;
  EXPECT_NE(out.find("rejected: sample 19\n"), std::string::npos);
  EXPECT_EQ(out.find("rejected: sample 20\n"), std::string::npos) << "past the burst: not at once";
  // The line a second after the burst names its sample and how many were
  // not written: samples 20 .. 4114.
  EXPECT_NE(out.find("rejected: sample 4115 (4095 more rejected since the last such line"), std::string::npos) << out;
  EXPECT_NE(out.find("rejected: sample 8211 (4095 more"), std::string::npos) << out;
  EXPECT_EQ(log.unlogged(), 9999 - 8211) << "since the last line";
}

}  // namespace
}  // namespace hullpipe
