#include "hullpipe/nodes/launch_flags.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hullpipe/testing/fixtures.h"

namespace hullpipe::nodes {
namespace {

// `Flags` (LaunchFlags, RenderFlags, ReconFlags) registered on an app, parsed
// from `args` as the program `exe` parses them and resolved with `resolve`,
// without starting anything.
template <class Flags, class... ResolveArgs>
Flags ParseAs(const std::string& exe, std::vector<std::string> args, ResolveArgs... resolve) {
  CLI::App app;
  Flags flags;
  flags.Register(app);
  args.insert(args.begin(), exe);
  std::vector<const char*> argv;
  for (const auto& a : args) argv.push_back(a.c_str());
  app.parse(int(argv.size()), argv.data());
  flags.Resolve(resolve...);
  return flags;
}

// hullpipe_launch's flags as the launcher takes them; what render_node and
// recon_node make of the arguments it hands them.
LaunchFlags ParseLaunch(const std::vector<std::string>& args) {
  return ParseAs<LaunchFlags>("hullpipe_launch", args, std::string(HULLPIPE_SOURCE_DIR));
}
RenderFlags ParseRender(const std::vector<std::string>& args) {
  return ParseAs<RenderFlags>("render_node", args, false);
}
ReconFlags ParseRecon(const std::vector<std::string>& args) { return ParseAs<ReconFlags>("recon_node", args); }

TEST(LaunchFlags, DefaultsGiveTheDescriptionItsVariablesAndRenderNothingMore) {
  const LaunchFlags f = ParseLaunch({"--synthetic"});
  const launch::LaunchContext ctx = f.Context("/tmp/out", 1000);
  EXPECT_EQ(ctx.vars.at("out"), "/tmp/out");
  EXPECT_EQ(ctx.vars.at("width"), "320");
  EXPECT_EQ(ctx.vars.at("height"), "240");
  EXPECT_EQ(ctx.vars.at("planes"), "50");
  EXPECT_EQ(ctx.vars.at("backend"), "auto");
  EXPECT_EQ(ctx.vars.at("frames"), "0");
  EXPECT_EQ(ctx.vars.at("start_time"), "0");
  EXPECT_EQ(ctx.vars.at("scene"), std::filesystem::absolute(std::string(HULLPIPE_SOURCE_DIR) + "/scenes/ball.yaml"));
  EXPECT_EQ(f.description, std::string(HULLPIPE_SOURCE_DIR) + "/launch/local.yaml");
  EXPECT_TRUE(ctx.synthetic);
  EXPECT_TRUE(ctx.rig.empty());
  EXPECT_TRUE(ctx.capture_fps.empty());
  EXPECT_TRUE(ctx.parent_args.empty());
  EXPECT_EQ(ctx.run_id.size(), 16u);
  EXPECT_NE(f.run_id, 0u);
}

// The view and sweep flags reach the nodes as each node parses its own: the
// values render_node and recon_node resolve from the launcher's arguments are
// the ones the launcher resolved (one registration, one set of checks).
TEST(LaunchFlags, TheViewAndSweepFlagsReachTheNodesAsTheyParseThem) {
  const std::string poses = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/head_track_example.csv";
  const LaunchFlags f =
      ParseLaunch({"--synthetic", "--backend", "cpu", "--planes", "80", "--width", "200", "--height", "100", "--up",
                   "0,0,1", "--floor", "0.25", "--orbit-radius", "2.5", "--orbit-height", "0.4", "--head-poses",
                   poses, "--fps", "12.5", "--start-in", "2", "--frames", "30", "--run-id", "abc"});
  const launch::LaunchContext ctx = f.Context("/o", 1'000'000'000);
  EXPECT_EQ(ctx.vars.at("backend"), "cpu");
  EXPECT_EQ(ctx.vars.at("planes"), "80");
  EXPECT_EQ(ctx.vars.at("width"), "200");
  EXPECT_EQ(ctx.vars.at("height"), "100");
  EXPECT_EQ(ctx.vars.at("frames"), "30");
  EXPECT_EQ(ctx.vars.at("start_time"), "3000000000");
  EXPECT_EQ(ctx.capture_fps, "12.5");
  EXPECT_EQ(ctx.run_id, "0000000000000abc");
  EXPECT_EQ(ctx.parent_args,
            (std::vector<std::string>{"--up", "0,0,1", "--floor", "0.25", "--orbit-radius", "2.5", "--orbit-height",
                                      "0.4", "--view", "file", "--head-poses", std::filesystem::absolute(poses)}));

  // The head-mounted display's flags reach render_node as given; a runtime's
  // per-eye log as "--view eyes" with its absolute path.
  {
    const std::string eyes = std::string(HULLPIPE_SOURCE_DIR) + "/scenes/eye_views_example.csv";
    const LaunchFlags st = ParseLaunch({"--synthetic", "--stereo", "--ipd", "0.07", "--fov-left",
                                        "-0.8,0.7,0.8,-0.8"});
    const launch::LaunchContext sc = st.Context("/o", 1'000'000'000);
    EXPECT_EQ(sc.parent_args, (std::vector<std::string>{"--stereo", "--ipd", "0.07", "--fov-left",
                                                        "-0.8,0.7,0.8,-0.8"}));
    const RenderFlags node = ParseRender(sc.parent_args);
    ASSERT_TRUE(node.options.stereo.has_value());
    EXPECT_EQ(node.options.stereo->ipd_m, 0.07);
    EXPECT_EQ(node.options.stereo->left.left, -0.8);
    EXPECT_EQ(node.options.stereo->right.right, 0.8) << "the left eye's, mirrored";
    const LaunchFlags ev = ParseLaunch({"--synthetic", "--eye-views", eyes});
    EXPECT_EQ(ev.Context("/o", 1).parent_args,
              (std::vector<std::string>{"--view", "eyes", "--eye-views", std::filesystem::absolute(eyes)}));
    const RenderFlags en = ParseRender(ev.Context("/o", 1).parent_args);
    EXPECT_EQ(en.options.view, RenderOptions::View::kEyes);
    EXPECT_TRUE(en.options.stereo.has_value());
    // Live views: a headset client's EyeViews, a tracker's HeadPose; --view
    // eyes with its file once (not twice).
    for (const std::string live : {"eyes-topic", "topic"}) {
      const LaunchFlags lf = ParseLaunch({"--synthetic", "--view", live});
      EXPECT_EQ(lf.Context("/o", 1).parent_args, (std::vector<std::string>{"--view", live}));
      const RenderFlags ln = ParseRender(lf.Context("/o", 1).parent_args);
      EXPECT_EQ(ln.options.view, live == "topic" ? RenderOptions::View::kTopic : RenderOptions::View::kEyesTopic);
      EXPECT_EQ(ln.options.stereo.has_value(), live == "eyes-topic");
    }
    EXPECT_EQ(ParseLaunch({"--synthetic", "--view", "eyes", "--eye-views", eyes}).Context("/o", 1).parent_args,
              (std::vector<std::string>{"--view", "eyes", "--eye-views", std::filesystem::absolute(eyes)}));
  }

  std::vector<std::string> render_args = {"--width", ctx.vars.at("width"), "--height", ctx.vars.at("height")};
  render_args.insert(render_args.end(), ctx.parent_args.begin(), ctx.parent_args.end());
  const RenderFlags node = ParseRender(render_args);
  EXPECT_EQ(node.options.width, f.render.options.width);
  EXPECT_EQ(node.options.height, f.render.options.height);
  EXPECT_EQ(node.options.up, f.render.options.up);
  EXPECT_EQ(node.options.up, Eigen::Vector3d(0, 0, 1));
  EXPECT_DOUBLE_EQ(node.options.floor_height, f.render.options.floor_height);
  EXPECT_DOUBLE_EQ(node.options.orbit_radius, 2.5);
  EXPECT_DOUBLE_EQ(node.options.orbit_radius, f.render.options.orbit_radius);
  EXPECT_DOUBLE_EQ(node.options.orbit_height, f.render.options.orbit_height);
  EXPECT_EQ(node.options.view, RenderOptions::View::kFile);
  EXPECT_EQ(node.options.track.size(), f.render.options.track.size());
  EXPECT_GT(node.options.track.size(), 0u);

  const ReconFlags recon = ParseRecon({"--tile", "1/2", "--backend", ctx.vars.at("backend"), "--planes",
                                       ctx.vars.at("planes")});
  EXPECT_EQ(recon.backend.name, "cpu");
  EXPECT_EQ(recon.options.sweep.num_planes, 80);
  EXPECT_EQ(recon.options.tile, 1);
  EXPECT_EQ(recon.options.tile_count, 2);
}

TEST(LaunchFlags, TheRigGivesRenderItsWorldUnlessTheFlagsSayOtherwise) {
  if (!test::HaveRig()) GTEST_SKIP() << "the Utrecht rig is not at " << test::RigDir();
  const LaunchFlags f = ParseLaunch({"--rig", test::RigDir()});
  const launch::LaunchContext ctx = f.Context("/o", 0);
  EXPECT_FALSE(ctx.synthetic);
  EXPECT_EQ(ctx.rig, std::filesystem::absolute(test::RigDir()).string());
  EXPECT_TRUE(ctx.parent_args.empty());
  // What render_node resolves from ${world} (--rig) alone.
  const RenderFlags node = ParseRender({"--rig", ctx.rig});
  EXPECT_EQ(f.render.options.up, node.options.up);
  EXPECT_EQ(f.render.options.up, Eigen::Vector3d(0, 0, -1));  // the Utrecht world is z down
  const LaunchFlags up = ParseLaunch({"--rig", test::RigDir(), "--up", "0,1,0"});
  EXPECT_EQ(up.render.options.up, Eigen::Vector3d(0, 1, 0));
}

TEST(LaunchFlags, BadFlagsAreRefusedNamingTheFlag) {
  auto refused = [](std::vector<std::string> args, const std::string& named) {
    try {
      ParseLaunch(args);
    } catch (const CLI::ParseError& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
      return true;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(named), std::string::npos) << e.what();
      return true;
    }
    return false;
  };
  // Control: each of these is accepted with a good value.
  EXPECT_FALSE(refused({"--synthetic", "--backend", "gl", "--planes", "2", "--width", "8", "--orbit-radius", "1"}, ""));
  EXPECT_TRUE(refused({"--synthetic", "--backend", "fast"}, "--backend"));  // the node's IsMember, now the launcher's
  EXPECT_TRUE(refused({"--synthetic", "--planes", "1"}, "--planes"));
  EXPECT_TRUE(refused({"--synthetic", "--width", "0"}, "--width"));
  EXPECT_TRUE(refused({"--synthetic", "--orbit-radius", "nan"}, "--orbit-radius"));
  EXPECT_TRUE(refused({"--synthetic", "--up", "0,0"}, "--up"));
  EXPECT_TRUE(refused({"--synthetic", "--up", "0,0,0"}, "--up"));
  EXPECT_TRUE(refused({"--synthetic", "--fps", "-1"}, "--fps"));
  EXPECT_TRUE(refused({"--synthetic", "--domain", "300"}, "--domain"));
  EXPECT_TRUE(refused({"--synthetic", "--run-id", "xyz"}, "--run-id"));
  EXPECT_TRUE(refused({"--synthetic", "--head-poses", "/nonexistent/poses.csv"}, "/nonexistent/poses.csv"));
  EXPECT_TRUE(refused({}, "--synthetic"));
  EXPECT_TRUE(refused({"--synthetic", "--rig", "some/rig"}, "--rig"));
}

}  // namespace
}  // namespace hullpipe::nodes
