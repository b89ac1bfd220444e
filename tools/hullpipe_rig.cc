// hullpipe_rig: rewrites a rig (Utrecht directory or YAML rig file) as a generic
// YAML rig file, optionally pointing each camera's frames at a live source — how a
// lab turns its calibration into the rig file of live cameras (README, "Cameras
// on several machines and live cameras").
//   hullpipe_rig convert ../shared/data/utrecht-4cam -o live.yaml
//       --frames 'udp://127.0.0.1:{5000+id}' --latency 0.05   (one command line)
// {id} in --frames and --background is replaced by the camera id, {5000+id} by
// 5000 plus the id (any base). Exit 0 when written; 1 with one line on error.
#include <cstdio>
#include <regex>
#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/geometry/calibration.h"

namespace {

std::string Expand(const std::string& pattern, int id) {
  std::string out = std::regex_replace(pattern, std::regex(R"(\{id\})"), std::to_string(id));
  std::smatch m;
  const std::regex sum(R"(\{(\d+)\+id\})");
  while (std::regex_search(out, m, sum))
    out = m.prefix().str() + std::to_string(std::stol(m[1].str()) + id) + m.suffix().str();
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_rig: rig files"};
  app.require_subcommand(1);
  std::string in, out, frames, background;
  double latency = -1;
  auto* convert = app.add_subcommand("convert", "Write a rig as a generic YAML rig file");
  convert->add_option("rig", in, "Rig directory (Utrecht layout) or YAML rig file")->required();
  convert->add_option("-o,--out", out, "YAML rig file to write")->required();
  convert->add_option("--frames", frames, "Each camera's frames: a path, v4l2:N or URL; {id}, {BASE+id} expand");
  convert->add_option("--background", background, "Each camera's background (same expansion); 'none': learn it "
                                                   "from the live camera's first frames");
  convert->add_option("--latency", latency, "Each camera's latency setting, seconds [0, 10]");
  CLI11_PARSE(app, argc, argv);
  try {
    if (latency != -1 && !(latency >= 0 && latency <= 10)) throw std::invalid_argument("--latency must be in [0, 10] s");
    hullpipe::Rig rig = hullpipe::LoadRig(in);
    for (auto& rc : rig.cameras) {
      if (!frames.empty()) rc.frames = Expand(frames, rc.camera.id);
      if (background == "none") rc.background.clear();
      else if (!background.empty()) rc.background = Expand(background, rc.camera.id);
      if (latency >= 0) rc.latency_s = latency;
    }
    hullpipe::WriteRigYaml(rig, out);
    std::printf("%s: %zu cameras\n", out.c_str(), rig.cameras.size());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hullpipe_rig: %s\n", e.what());
    return 1;
  }
  return 0;
}
