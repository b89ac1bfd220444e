// Launch descriptions: the shipped ones parse; each kind of bad file is refused
// on one line naming the node and key; node command lines as the launcher makes
// them (placeholders, the rig's world, the parent's view flags, ssh and nice).
#include "hullpipe/launch/description.h"
#include "hullpipe/launch/process.h"
#include "hullpipe/launch/supervisor.h"

#include <algorithm>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

namespace hullpipe::launch {
namespace {

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseLaunchDescription(yaml);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(accepted)";
}

const char* const kTwoNodes = R"(nodes:
  - {name: render, exec: render_node, args: ["${world}", --out, "${out}/x", --frames, "${frames}"]}
  - {name: capture, exec: capture_node, host: labpc, nice: 5, args: ["${source}", --start-time, "${start_time}"]}
)";

TEST(LaunchDescription, TheShippedDescriptionsParse) {
  for (const char* f : {"local.yaml", "local-one-recon.yaml", "split-capture.yaml", "two-hosts.yaml"}) {
    const LaunchDescription d = LoadLaunchDescription(std::string(HULLPIPE_SOURCE_DIR) + "/launch/" + f);
    ASSERT_FALSE(d.nodes.empty()) << f;
    EXPECT_EQ(d.nodes.front().exec, "render_node") << f;
    // hullpipe_launch --fps paces every capture node (a rig too large for the machine).
    for (const auto& n : d.nodes) {
      if (n.exec != "capture_node") continue;
      EXPECT_NE(std::find(n.args.begin(), n.args.end(), "${pace}"), n.args.end()) << f << ": " << n.name;
    }
  }
  const LaunchDescription local = LoadLaunchDescription(std::string(HULLPIPE_SOURCE_DIR) + "/launch/local.yaml");
  ASSERT_EQ(local.nodes.size(), 5u);
  EXPECT_EQ(local.nodes[1].name, "recon0");
}

TEST(LaunchDescription, BadFilesAreRefusedNamingTheNodeAndKey) {
  EXPECT_NE(ErrorOf("[1, 2").find("not YAML"), std::string::npos);
  EXPECT_NE(ErrorOf("- a\n- b\n").find("must be a map"), std::string::npos);
  EXPECT_NE(ErrorOf("node: []\n").find("unknown key 'node'"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes: {}\n").find("'nodes' must be a list"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes: []\n").find("first node must be render_node"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: render_node, arg: [x]}\n").find("node r: unknown key 'arg'"),
            std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r}\n").find("needs 'name' and 'exec'"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: /bin/sh}\n").find("not a hullpipe node"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: render_node, start_delay: 61}\n").find("start_delay"),
            std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: render_node, nice: x}\n").find("nice must be"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: s, exec: sim_node}\n").find("first node must be render_node"),
            std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: render_node, args: {a: 1}}\n").find("args a list"),
            std::string::npos);
}

// A node's name becomes logs/<name>.log under --out: a path in it would write
// outside --out, and two nodes of one name would share (and truncate) a log.
TEST(LaunchDescription, NamesArePlainAndUnique) {
  EXPECT_NE(ErrorOf("nodes:\n  - {name: ../../victim, exec: render_node}\n").find("must be 1-64 letters"),
            std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: '', exec: render_node}\n").find("must be 1-64 letters"), std::string::npos);
  EXPECT_NE(ErrorOf("nodes:\n  - {name: r, exec: render_node}\n  - {name: r, exec: sim_node}\n")
                .find("two nodes are named 'r'"),
            std::string::npos);
  EXPECT_EQ(ErrorOf("nodes:\n  - {name: render_0-a, exec: render_node}\n"), "(accepted)");  // control
}

TEST(LaunchDescription, ArgumentsAreExpandedAsTheLauncherGivesThem) {
  const LaunchDescription d = ParseLaunchDescription(kTwoNodes);
  LaunchContext ctx;
  ctx.vars = {{"out", "/o"}, {"frames", "7"}, {"start_time", "0"}};
  ctx.rig = "/rigs/u";
  ctx.parent_args = {"--view", "file", "--head-poses", "/h.csv"};
  ctx.domain = 42;
  ctx.run_id = "abc";
  EXPECT_EQ(ExpandArguments(d, 0, ctx),
            (std::vector<std::string>{"--rig", "/rigs/u", "--out", "/o/x", "--frames", "7", "--view", "file",
                                      "--head-poses", "/h.csv", "--domain", "42", "--run-id", "abc"}));
  EXPECT_EQ(ExpandArguments(d, 1, ctx), (std::vector<std::string>{"--rig", "/rigs/u", "--start-time", "0",
                                                                  "--domain", "42", "--run-id", "abc"}));
  // ${pace}: --fps where the launcher was given one, else nothing.
  LaunchDescription paced = d;
  paced.nodes[1].args.push_back("${pace}");
  EXPECT_EQ(ExpandArguments(paced, 1, ctx).size(), ExpandArguments(d, 1, ctx).size());
  ctx.capture_fps = "2.5";
  const auto with = ExpandArguments(paced, 1, ctx);
  EXPECT_EQ(std::vector<std::string>(with.begin() + 4, with.begin() + 6), (std::vector<std::string>{"--fps", "2.5"}));
  ctx.capture_fps.clear();
  ctx.synthetic = true;
  ctx.rig.clear();
  EXPECT_EQ(ExpandArguments(d, 1, ctx).front(), "--synthetic");      // ${source}
  EXPECT_EQ(ExpandArguments(d, 0, ctx).front(), "--out");            // ${world}: nothing
  EXPECT_EQ(NodeCommand(d.nodes[1], "/bin/capture_node", {"--x"}, "/o/dds.xml"),
            (std::vector<std::string>{"ssh", "--", "labpc",
                                      "env 'CYCLONEDDS_URI=file:///o/dds.xml' 'nice' '-n' '5' '/bin/capture_node' "
                                      "'--x'"}));
  EXPECT_EQ(NodeCommand(d.nodes[0], "/bin/render_node", {}, "/o/dds.xml"),
            (std::vector<std::string>{"/bin/render_node"}));
}

}  // namespace
}  // namespace hullpipe::launch

// The supervisor's policy with plain processes standing in for nodes.

namespace hullpipe::launch {
namespace {

std::vector<SupervisedNode> Start(const std::vector<std::string>& scripts) {
  std::vector<SupervisedNode> nodes;
  for (size_t i = 0; i < scripts.size(); ++i)
    nodes.push_back({"n" + std::to_string(i), std::make_unique<Process>(
                                                   std::vector<std::string>{"/bin/sh", "-c", scripts[i]}, ""),
                     ""});
  return nodes;
}

// A launch description must not run commands. A host is a host name or
// address, never an ssh option ("-oProxyCommand=..." ran its command on the
// launching machine); and a remote node's words reach it as they are: ssh
// joins them for the remote shell, so unquoted, "$(...)" ran there and a path
// with a space broke. A stand-in ssh does what sshd does (joins the words after
// the destination, runs them with sh -c); the control shows it expands an
// unquoted "$(...)".
TEST(LaunchDescription, AHostIsNoOptionAndRemoteWordsReachTheNodeUnexpanded) {
  const std::string base = "nodes:\n  - {name: render, exec: render_node}\n  - {name: c, exec: capture_node, host: ";
  for (const std::string bad : {"\"-oProxyCommand=touch /tmp/x\"", "\"lab pc\"", "\"lab;pc\"", "\"$(id)\"",
                                "\"-lroot\"", "\"\""}) {
    try {
      ParseLaunchDescription(base + bad + "}\n");
      ADD_FAILURE() << bad << " accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("node c: host"), std::string::npos) << e.what();
    }
  }
  for (const std::string good : {"labpc", "user@lab-pc.local", "10.0.0.2", "\"[fe80::1%eth0]\"", "fe80::1"})
    EXPECT_NO_THROW(ParseLaunchDescription(base + good + "}\n")) << good;
  NodeSpec hostile;
  hostile.host = "-oProxyCommand=x";
  EXPECT_THROW(NodeCommand(hostile, "/bin/true", {}, "/o/dds.xml"), std::invalid_argument);

  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("hullpipe_ssh_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const auto write = [&](const std::string& name, const std::string& text) {
    FILE* f = std::fopen((dir / name).c_str(), "w");
    ASSERT_TRUE(f);
    std::fputs(text.c_str(), f);
    std::fclose(f);
    std::filesystem::permissions(dir / name, std::filesystem::perms::owner_all);
  };
  write("ssh", "#!/bin/sh\n[ \"$1\" = -- ] && shift\nshift\nexec /bin/sh -c \"$*\"\n");
  write("node", "#!/bin/sh\nfor a in \"$@\"; do printf '%s\\n' \"$a\"; done > \"" + (dir / "args").string() +
                    "\"\nprintf '%s\\n' \"$CYCLONEDDS_URI\" > \"" + (dir / "uri").string() + "\"\n");
  const std::string pwned = (dir / "pwned").string();
  const std::vector<std::string> args = {"$(touch " + pwned + ")", "a path/with space", "it's", "`touch " + pwned + "`",
                                         "--rig", "x;touch " + pwned};
  NodeSpec spec;
  spec.host = "labpc";
  spec.nice = 3;
  std::vector<std::string> argv = NodeCommand(spec, (dir / "node").string(), args, "/o/my dds.xml");
  ASSERT_EQ(argv.front(), "ssh");
  argv.front() = (dir / "ssh").string();
  {
    Process p(argv, (dir / "log").string());
    ASSERT_EQ(p.Wait(20), 0);
  }
  std::ifstream in(dir / "args");
  std::vector<std::string> got;
  for (std::string line; std::getline(in, line);) got.push_back(line);
  EXPECT_EQ(got, args);
  std::ifstream uri(dir / "uri");
  std::string u;
  std::getline(uri, u);
  EXPECT_EQ(u, "file:///o/my dds.xml");
  EXPECT_FALSE(std::filesystem::exists(pwned)) << "a word ran as a command";
  // Control: the same words unquoted, as ssh was given them before, do run it.
  {
    Process p({(dir / "ssh").string(), "--", "labpc", (dir / "node").string(), args[0]}, (dir / "log").string());
    ASSERT_EQ(p.Wait(20), 0);
  }
  EXPECT_TRUE(std::filesystem::exists(pwned)) << "the stand-in ssh expands as sshd's shell does";
  std::filesystem::remove_all(dir);
}

TEST(Supervisor, TheParentFinishingEndsTheRunAndTheOthersAreStopped) {
  auto nodes = Start({"sleep 0.2", "exec sleep 30"});
  volatile std::sig_atomic_t stop = 0;
  EXPECT_EQ(RunUntilDone(nodes, stop), "n0 finished");
  StopAll(nodes, 5);  // the sleeper dies of SIGINT long before the grace
  EXPECT_FALSE(nodes[1].process->Running());
  EXPECT_TRUE(WIFSIGNALED(nodes[1].process->status()));
  EXPECT_EQ(ReportExits(nodes), 1);  // a node killed by SIGINT did not exit 0
}

TEST(Supervisor, AFailingNodeEndsTheRunAndIsNamed) {
  auto nodes = Start({"exec sleep 30", "exit 3"});
  volatile std::sig_atomic_t stop = 0;
  EXPECT_EQ(RunUntilDone(nodes, stop).rfind("n1 failed (exit 3)", 0), 0u);
  StopAll(nodes, 5);
  EXPECT_FALSE(nodes[0].process->Running());
}

TEST(Supervisor, AStopRequestEndsTheRunAndANodeIgnoringSigintIsKilled) {
  const std::string ready = ::testing::TempDir() + "supervisor_trap_" + std::to_string(getpid());
  std::remove(ready.c_str());
  auto nodes = Start({"trap '' INT; touch " + ready + "; exec sleep 30", "exit 0"});
  // The shell must have set its trap before the SIGINT comes (condition, deadline).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!std::filesystem::exists(ready) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(std::filesystem::exists(ready));
  std::remove(ready.c_str());
  volatile std::sig_atomic_t stop = 1;
  EXPECT_EQ(RunUntilDone(nodes, stop), "interrupted");
  StopAll(nodes, 0.3);
  EXPECT_TRUE(WIFSIGNALED(nodes[0].process->status()));
  EXPECT_EQ(WTERMSIG(nodes[0].process->status()), SIGKILL);
}

}  // namespace
}  // namespace hullpipe::launch
