#include "hullpipe/nodes/capture_flags.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hullpipe/capture/prefetching_source.h"

namespace hullpipe::nodes {
namespace {

// capture_node's flags parsed as the node parses them, without starting it.
CaptureFlags ParseCapture(std::vector<std::string> args) {
  CLI::App app;
  CaptureFlags flags;
  flags.Register(app);
  args.insert(args.begin(), "capture_node");
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  app.parse(int(argv.size()), argv.data());
  flags.Resolve();
  return flags;
}

TEST(CaptureFlags, ParsedIntoTheControllersOptionsAndTheSourcesOnce) {
  const CaptureFlags d = ParseCapture({"--rig", "some/rig.yaml"});
  EXPECT_EQ(d.rig, "some/rig.yaml");
  EXPECT_EQ(d.jpeg_quality, -1);
  EXPECT_TRUE(d.read_ahead);
  EXPECT_DOUBLE_EQ(d.options.image_scale, 0.5);
  EXPECT_DOUBLE_EQ(d.options.max_lag_s, 0.1);
  const CaptureFlags f = ParseCapture({"--synthetic", "--synthetic-size", "64x48", "--synthetic-cameras", "5",
                                       "--cameras", "2,4", "--frames", "12", "--fps", "10", "--loop",
                                       "--image-scale", "0.25", "--jpeg", "0", "--max-lag", "0.5",
                                       "--start-time", "123", "--timeline-window", "30", "--threads", "3",
                                       "--wait-readers", "4", "--wait-timeout", "2", "--no-read-ahead"});
  EXPECT_EQ(f.synthetic_options.width, 64);
  EXPECT_EQ(f.synthetic_options.height, 48);
  EXPECT_EQ(f.synthetic_options.cameras, 5);
  EXPECT_EQ(f.synthetic_options.camera_ids, (std::vector<int>{2, 4}));
  EXPECT_EQ(f.synthetic_options.frames, 12);
  EXPECT_EQ(f.options.frames, 12);
  EXPECT_DOUBLE_EQ(f.options.fps, 10);
  EXPECT_TRUE(f.options.loop);
  EXPECT_DOUBLE_EQ(f.options.image_scale, 0.25);
  EXPECT_EQ(f.jpeg_quality, 0);
  EXPECT_DOUBLE_EQ(f.options.max_lag_s, 0.5);
  EXPECT_EQ(f.options.start_ns, 123);
  EXPECT_DOUBLE_EQ(f.options.timeline_window_s, 30);
  EXPECT_EQ(f.options.threads, 3);
  EXPECT_EQ(f.wait_readers, 4u);
  EXPECT_DOUBLE_EQ(f.wait_timeout_s, 2);
  EXPECT_FALSE(f.read_ahead);
}

TEST(CaptureFlags, BadFlagsAreRefusedNamingTheFlag) {
  auto refused = [](std::vector<std::string> args, const std::string& flag) {
    try {
      ParseCapture(args);
    } catch (const CLI::ParseError& e) {
      return std::string(e.what()).find(flag) != std::string::npos ? std::string() : std::string(e.what());
    } catch (const std::invalid_argument& e) {
      return std::string(e.what()).find(flag) != std::string::npos ? std::string() : std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_EQ(refused({"--rig", "r", "--jpeg", "101"}, "--jpeg"), "");
  EXPECT_EQ(refused({"--rig", "r", "--image-scale", "0"}, "--image-scale"), "");
  EXPECT_EQ(refused({"--rig", "r", "--max-lag", "nan"}, "--max-lag"), "");
  EXPECT_EQ(refused({"--synthetic", "--synthetic-size", "64x48x"}, "--synthetic-size"), "");
  EXPECT_EQ(refused({"--frames", "3"}, "--rig"), "");  // no source named
  // The control: the same flags with good values are taken.
  EXPECT_EQ(refused({"--rig", "r", "--jpeg", "100", "--image-scale", "1", "--max-lag", "60"}, ""), "accepted");
}

// The source the flags name: read one frame ahead by default, as it is with
// --no-read-ahead; --jpeg -1 settled by the cameras' size.
TEST(CaptureFlags, OpenTheSourceTheyNameReadAheadByDefault) {
  CaptureFlags small = ParseCapture({"--synthetic", "--synthetic-cameras", "3", "--frames", "2"});
  const auto ahead = small.OpenSource(nullptr);
  EXPECT_NE(dynamic_cast<PrefetchingSource*>(ahead.get()), nullptr);
  EXPECT_EQ(ahead->cameras().size(), 3u);
  EXPECT_EQ(small.jpeg_quality, 0);  // 3 x 160x120 raw: far below 2 MiB
  CaptureFlags big = ParseCapture({"--synthetic", "--synthetic-cameras", "20", "--synthetic-size", "1024x768",
                                   "--frames", "1", "--no-read-ahead"});
  const auto plain = big.OpenSource(nullptr);
  EXPECT_EQ(dynamic_cast<PrefetchingSource*>(plain.get()), nullptr);
  EXPECT_EQ(big.jpeg_quality, kAutoJpegQuality);  // 20 x 512x384 raw: 11.8 MB
  EXPECT_TRUE(big.options.image_regions) << "--image-region auto: regions for such a frame";
  EXPECT_FALSE(small.options.image_regions);
  CaptureFlags whole = ParseCapture({"--synthetic", "--synthetic-cameras", "20", "--synthetic-size", "1024x768",
                                     "--frames", "1", "--no-read-ahead", "--image-region", "whole"});
  (void)whole.OpenSource(nullptr);
  EXPECT_FALSE(whole.options.image_regions);
}

}  // namespace
}  // namespace hullpipe::nodes
