// hullpipe_rig: rig files (docs/rigs.md).
//   hullpipe_rig convert RIG -o rig.yaml [--frames P] [--background P] [--latency S]
//       rewrites a rig (Utrecht directory or YAML rig file) as a generic YAML rig
//       file, optionally pointing each camera's frames at a live source:
//       --frames 'udp://127.0.0.1:{5000+id}' ({id} -> the camera id, {BASE+id} -> BASE plus it).
//   hullpipe_rig import --from colmap|nerf|middlebury|opencv-yaml IN -o rig.yaml
//       [--scale M] [--width W --height H] [--frames P] [--background P] [--poses world_from_camera]
//       converts a calibration as the field writes it (rig_import.h) and states the
//       derived world (up, floor, orbit) and workspace in the file.
//   hullpipe_rig check RIG [--write OUT]
//       prints each camera's centre, viewing direction and field of view, the
//       workspace and which cameras see its centre, the world, and warns about what
//       looks wrong; exit 0 (warnings are not errors), 1 if the rig cannot be read.
//   hullpipe_rig synthesize -o DIR [--cameras N] [--size WxH] [--frames N] [--fps F]
//       [--format colmap|yaml] [--noise S] [--k1 K] [--skew PX]
//       writes a rig that is not the Utrecht one (synthetic_rig.h): the synthetic
//       figure filmed by N cameras as videos, calibrated in a z-up world of its own,
//       as a COLMAP text model (import it like any COLMAP rig) or a rig file.
// Exit 0 when done; 1 with one line on error.
#include <cmath>
#include <cstdio>
#include <regex>
#include <string>

#include <CLI/CLI.hpp>

#include "hullpipe/evaluation/synthetic_rig.h"
#include "hullpipe/geometry/calibration.h"
#include "hullpipe/geometry/rig_import.h"
#include "hullpipe/geometry/rig_world.h"
#include "hullpipe/util/logging.h"
#include "hullpipe/util/memory.h"

namespace {

std::string Expand(const std::string& pattern, int id) {
  std::string out = std::regex_replace(pattern, std::regex(R"(\{id\})"), std::to_string(id));
  std::smatch m;
  const std::regex sum(R"(\{(\d+)\+id\})");
  while (std::regex_search(out, m, sum))
    out = m.prefix().str() + std::to_string(std::stol(m[1].str()) + id) + m.suffix().str();
  return out;
}

void PointAt(hullpipe::Rig* rig, const std::string& frames, const std::string& background, double latency) {
  for (auto& rc : rig->cameras) {
    if (!frames.empty()) rc.frames = Expand(frames, rc.camera.id);
    if (background == "none") rc.background.clear();
    else if (!background.empty()) rc.background = Expand(background, rc.camera.id);
    if (latency >= 0) rc.latency_s = latency;
  }
}

std::string V(const Eigen::Vector3d& v) {
  char b[96];
  std::snprintf(b, sizeof b, "%8.3f %8.3f %8.3f", v.x(), v.y(), v.z());
  return b;
}

void PrintCheck(const hullpipe::Rig& rig) {
  const auto cams = rig.Cameras();
  const hullpipe::RigReport r = hullpipe::CheckRig(cams, rig.workspace, rig.world);
  std::printf("%s: %zu cameras\n", rig.source.c_str(), cams.size());
  std::printf("%-6s %-26s %-26s %8s %8s %9s %s\n", "camera", "centre (m)", "viewing direction", "hfov", "vfov",
              "skew (px)", "sees workspace centre");
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const auto& c = r.cameras[i];
    std::printf("%-6d %-26s %-26s %7.1f° %7.1f° %9.3f %s\n", c.id, V(c.centre).c_str(), V(c.view_dir).c_str(),
                c.hfov_deg, c.vfov_deg, i < cams.size() ? cams[i].skew : 0.0, c.sees_centre ? "yes" : "NO");
  }
  std::printf("workspace: min %s  max %s\n", V(rig.workspace.min).c_str(), V(rig.workspace.max).c_str());
  const hullpipe::Aabb& common = r.common_view;
  if (!common.empty())
    std::printf("seen by every camera: min %s  max %s\n", V(common.min).c_str(), V(common.max).c_str());
  std::printf("workspace centre (of what every camera sees in it): %s\n", V(r.workspace_centre).c_str());
  const auto& w = rig.world;
  std::printf("world: up %s (%s)\n", V(w.up).c_str(), w.up_stated ? "stated" : "derived: the cameras' mean image-up");
  std::printf("       floor %s (%s)\n", w.FloorText().c_str(), w.floor_stated ? "stated" : "derived");
  std::printf("       orbit radius %.3f m, height %.3f m (%s)\n", w.orbit_radius, w.orbit_height,
              w.orbit_stated ? "stated" : "derived: frames what every camera sees at 60° field of view");
  for (const auto& n : rig.notes) std::printf("note: %s\n", n.c_str());
  for (const auto& warn : r.warnings) std::printf("warning: %s\n", warn.c_str());
  if (r.warnings.empty()) std::printf("no warnings\n");
}

}  // namespace

int main(int argc, char** argv) {
  hullpipe::LogToStderr("hullpipe_rig");  // stdout carries only what a user asked for
  hullpipe::KeepFreedMemory();  // a loop over frames: no page faults per frame (util/memory.h)
  hullpipe::SetCommandLine(argc, argv);
  CLI::App app{"hullpipe_rig: rig files"};
  app.require_subcommand(1);
  std::string in, out, frames, background, from, poses = "cam_from_world";
  double latency = -1;
  hullpipe::ImportOptions io;
  auto* convert = app.add_subcommand("convert", "Write a rig as a generic YAML rig file");
  convert->add_option("rig", in, "Rig directory (Utrecht layout) or YAML rig file")->required();
  convert->add_option("-o,--out", out, "YAML rig file to write")->required();
  convert->add_option("--frames", frames, "Each camera's frames: a path, v4l2:N or URL; {id}, {BASE+id} expand");
  convert->add_option("--background", background, "Each camera's background (same expansion); 'none': learn it "
                                                   "from the live camera's first frames");
  convert->add_option("--latency", latency, "Each camera's latency setting, seconds [0, 10]");
  auto* import = app.add_subcommand("import", "Convert a COLMAP, NeRF, Middlebury or OpenCV calibration");
  import->add_option("--from", from, "colmap | nerf | middlebury | opencv-yaml | pmvs")
      ->required()
      ->check(CLI::IsMember({"colmap", "nerf", "middlebury", "opencv-yaml", "pmvs"}));
  import
      ->add_option("in", in,
                   "COLMAP model directory, transforms.json, *_par.txt, OpenCV YAML file/directory, or PMVS directory")
      ->required();
  import->add_option("-o,--out", out, "YAML rig file to write")->required();
  import->add_option("--scale", io.scale, "Metres per unit of the file's lengths (0.001: millimetres)")
      ->capture_default_str();
  import->add_option("--width", io.width, "Image width where the file has none (default: the image's)");
  import->add_option("--height", io.height, "Image height where the file has none (default: the image's)");
  import->add_option("--frames", frames, "Each camera's frames instead of its calibration image ({id} expands)");
  import->add_option("--background", background, "Each camera's background ({id} expands)");
  import->add_option("--poses", poses, "opencv-yaml: the file's poses are cam_from_world or world_from_camera")
      ->check(CLI::IsMember({"cam_from_world", "world_from_camera"}))
      ->capture_default_str();
  auto* check = app.add_subcommand("check", "Print what a rig is and warn about what looks wrong");
  check->add_option("rig", in, "Rig directory or YAML rig file")->required();
  check->add_option("--write", out, "Also write the rig with its derived world and workspace stated");
  hullpipe::SyntheticRigFilesOptions so;
  std::string size = "644x486";
  auto* synth = app.add_subcommand("synthesize", "Write a z-up rig of the synthetic figure: videos and a calibration");
  synth->add_option("-o,--out", out, "Directory to write (videos/, sparse/0/ or rig.yaml)")->required();
  synth->add_option("--cameras", so.cameras, "Cameras on the ring [3, 64]")->capture_default_str();
  synth->add_option("--size", size, "Image size WxH")->capture_default_str();
  synth->add_option("--frames", so.frames, "Video length in frames")->capture_default_str();
  synth->add_option("--fps", so.fps, "Frames per second")->capture_default_str();
  synth->add_option("--format", so.format, "colmap (text model) | yaml (rig file)")
      ->check(CLI::IsMember({"colmap", "yaml"}))
      ->capture_default_str();
  synth->add_option("--noise", so.noise_sigma, "Sensor noise sigma, grey levels")->capture_default_str();
  synth->add_option("--k1", so.k1, "Radial distortion k1 of every camera")->capture_default_str();
  synth->add_option("--skew", so.skew, "Skew of every camera's K in pixels (--format yaml)")->capture_default_str();
  synth->add_option("--threads", so.threads, "Cameras rendered in parallel")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    if (synth->parsed()) {
      char x = 0;
      if (std::sscanf(size.c_str(), "%d%c%d", &so.width, &x, &so.height) != 3 || x != 'x')
        throw std::invalid_argument("--size must be WxH, not '" + size + "'");
      const hullpipe::SyntheticRigFiles f = hullpipe::WriteSyntheticRigFiles(so, out);
      const Eigen::Vector3d at = f.world_from_figure.translation;
      std::printf("%s: %zu cameras, %d frames of %dx%d at %g fps; the figure stands at (%.2f, %.2f, %.2f) m, z up\n",
                  out.c_str(), f.cameras.size(), so.frames, so.width, so.height, so.fps, at.x(), at.y(), at.z());
      std::printf("calibration: %s\nframes: %s/%s\nbackground: %s/%s\n", f.calibration.c_str(), out.c_str(),
                  f.frames_pattern.c_str(), out.c_str(), f.background_pattern.c_str());
      return 0;
    }
    if (latency != -1 && !(latency >= 0 && latency <= 10))
      throw std::invalid_argument("--latency must be in [0, 10] s");
    if (import->parsed()) {
      io.poses_world_from_camera = poses == "world_from_camera";
      hullpipe::Rig rig = hullpipe::ImportRig(from, in, io);
      PointAt(&rig, frames, background, -1);
      hullpipe::WriteRigYaml(rig, out);
      std::printf("%s: %zu cameras from %s (%s)\n", out.c_str(), rig.cameras.size(), in.c_str(), from.c_str());
      PrintCheck(rig);
      return 0;
    }
    hullpipe::Rig rig = hullpipe::LoadRig(in);
    if (check->parsed()) {
      PrintCheck(rig);
      if (!out.empty()) {
        hullpipe::WriteRigYaml(rig, out);
        std::printf("wrote %s\n", out.c_str());
      }
      return 0;
    }
    PointAt(&rig, frames, background, latency);
    hullpipe::WriteRigYaml(rig, out);
    std::printf("%s: %zu cameras\n", out.c_str(), rig.cameras.size());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hullpipe_rig: %s\n", e.what());
    return 1;
  }
  return 0;
}
