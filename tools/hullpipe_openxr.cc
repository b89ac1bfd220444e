// hullpipe_openxr: a headset's eyes from an OpenXR runtime (docs/hmd.md, "An
// OpenXR client"): each frame's two views (xrLocateViews at the predicted
// display time) registered into the rig's world and published as EyeViews
// for render_node --view eyes-topic. With --display it also shows
// render_node's composited eyes in the headset (docs/hmd.md, "Display"): each
// eye's CompositedView, matched to its ViewPose, uploaded to the eye's
// swapchain and submitted as a projection layer at the pose it was drawn
// from. Links the Khronos loader only; the runtime is whichever is active
// (XR_RUNTIME_JSON or the system's).
//   hullpipe_openxr --domain 7 [--display] [--space stage|local]
//                   [--world-from-space x,y,z,qx,qy,qz,qw] [--tracker-id 20] [--frames N]
// Ends when the runtime ends the session (exit 0), after --frames views, or
// within a second of SIGINT (the session ended first). Exits 1 with one line
// naming the OpenXR call when there is no runtime, no headset, no headless
// session (or, with --display, no EGL binding or OpenGL context).
#include <algorithm>
#include <chrono>
#include <deque>
#include <memory>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/node.h"
#include "hullpipe/openxr/xr_display.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/util/image_file.h"

using namespace hullpipe;
using namespace hullpipe::dds;

namespace {

// render_node's composited eyes, paired with their poses (openxr/eye_images.h).
// The composites are best-effort; a few are kept so both eyes of a pose arrive.
// Only poses drawn from views this client sent are taken (render_node stamps a
// ViewPose with the EyeViews' stamp_ns): another render_node's, another
// headset's or a replay's on the domain are not shown in this headset.
class CompositeInput {
 public:
  // Composites larger than max_width x max_height are refused undecoded.
  CompositeInput(const Participant& p, int max_width, int max_height)
      : poses_(p),
        images_(p, TopicTraits<hullpipe_msg_CompositedView>::kName, QosSpec{false, false, 4, 0}),
        max_width_(max_width),
        max_height_(max_height) {}
  // The EyeViews this client sent, by stamp (the last kSentKept).
  void Sent(int64_t stamp_ns) {
    sent_.push_back(stamp_ns);
    if (sent_.size() > kSentKept) sent_.pop_front();
  }
  // Takes what arrived; returns the newest pair not shown yet.
  std::optional<std::array<openxr::EyeImage, 2>> Take() {
    poses_.TakeEach([&](const hullpipe_msg_ViewPose& m, const dds_sample_info_t&) {
      if (std::find(sent_.rbegin(), sent_.rend(), m.stamp_ns) == sent_.rend()) {
        if (foreign_++ == 0)
          spdlog::info("ViewPose {} (run {:x}) was not drawn from this client's views (another render_node, headset "
                       "or replay on the domain, or render's own eyes before ours arrived): its images are not shown",
                       m.pose_seq, m.run_id);
        return;
      }
      try {
        pairs_.AddPose(m.run_id, m.pose_seq, ViewEyeFromMsg("ViewPose", m.eye), ViewFromMsg(m));
      } catch (const std::exception& e) {
        Skip(std::string("ViewPose: ") + e.what());
      }
    });
    images_.TakeEach([&](const hullpipe_msg_CompositedView& m, const dds_sample_info_t&) {
      try {
        CheckCompositedViewMsg(m);
        if (int64_t(m.width) > max_width_ || int64_t(m.height) > max_height_) {
          Skip("CompositedView " + std::to_string(m.width) + "x" + std::to_string(m.height) +
               " is larger than the headset's largest eye image " + std::to_string(max_width_) + "x" +
               std::to_string(max_height_) + ": not decoded");
          return;
        }
        // Its header checked above; its pixels decoded only if it is shown (a
        // newer composite of its eye may supersede it first).
        auto bytes = std::make_shared<const std::vector<uint8_t>>(m.data._buffer, m.data._buffer + m.data._length);
        const uint64_t frame_seq = m.frame_seq;
        const auto decode = [this, bytes, frame_seq] {
          std::string why;
          cv::Mat img = DecodeImage(bytes->data(), bytes->size(), cv::IMREAD_COLOR, &why);
          if (img.empty()) Skip("CompositedView of frame " + std::to_string(frame_seq) + ": " + why);
          return img;
        };
        const std::string why = pairs_.AddImage(m.run_id, m.pose_seq, ViewEyeFromMsg("CompositedView", m.eye),
                                                m.frame_seq, decode);
        if (!why.empty()) Skip("CompositedView not shown: " + why);
      } catch (const std::exception& e) {
        Skip(std::string("CompositedView: ") + e.what());
      }
    });
    return pairs_.TakeNewPair();
  }
  uint64_t skipped() const { return skipped_; }
  // ViewPoses not drawn from this client's views.
  uint64_t foreign() const { return foreign_; }
  // Times render_node's run changed (a restarted render_node).
  uint64_t run_changes() const { return pairs_.counts().run_changes; }

 private:
  void Skip(const std::string& why) {
    ++skipped_;
    if (why != last_) spdlog::warn("{}", why);  // once per reason in a row
    last_ = why;
  }
  Reader<hullpipe_msg_ViewPose> poses_;
  Reader<hullpipe_msg_CompositedView> images_;
  int max_width_, max_height_;
  openxr::EyeImagePairs pairs_;
  static constexpr size_t kSentKept = 256;  // ~3 s of views at 90 Hz
  std::deque<int64_t> sent_;
  uint64_t skipped_ = 0, foreign_ = 0;
  std::string last_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hullpipe_openxr: a headset's eyes from an OpenXR runtime, as EyeViews for render_node"};
  CommonOptions common;
  OpenCommandLine(argc, argv, "hullpipe_openxr", app, common, /*with_run_id=*/false);
  openxr::XrClientOptions o;
  std::string world_from_space;
  uint64_t frames = 0;
  bool display = false;
  int gl_device = -1;
  app.add_option("--space", o.space, "OpenXR reference space of the views: stage or local")->capture_default_str();
  app.add_option("--world-from-space", world_from_space,
                 "The lab's registration of that space to the rig's world: x,y,z,qx,qy,qz,qw (metres; default: "
                 "the identity)");
  app.add_option("--tracker-id", o.tracker_id, "EyeViews.tracker_id of the views sent")->capture_default_str();
  app.add_option("--frames", frames, "Stop after this many views sent (0: when the runtime ends the session)")
      ->capture_default_str();
  auto* display_flag =
      app.add_flag("--display", display,
                   "Show render_node's composited eyes in the headset (an EGL-bound session, XR_MNDX_egl_enable)");
  app.add_option("--gl-device", gl_device, "With --display: the EGL device (-1: the first hardware one)")
      ->capture_default_str()
      ->needs(display_flag);
  CLI11_PARSE(app, argc, argv);
  try {
    if (!world_from_space.empty())
      o.world_from_space = openxr::RigidFromPoseText(world_from_space, "--world-from-space");
    o.Check();
    auto participant = StartNode("openxr", common);
    Writer<hullpipe_msg_EyeViews> writer(*participant);
    SystemClock clock;
    NodeCounters counters(clock);
    NodeReporter reporter(*participant, "openxr", counters);
    // Display: the GL context first, bound to the session, outliving it.
    std::optional<gl::EglContext> context;
    std::unique_ptr<openxr::XrEglBinding> binding;
    if (display) {
      std::string why;
      context = gl::EglContext::TryCreate(gl::EglOptions{gl_device}, &why);
      if (!context) throw std::runtime_error("--display: no OpenGL context: " + why);
      binding = std::make_unique<openxr::XrEglBinding>(*context);
    }
    openxr::XrEyeSession session(o, binding ? &binding->graphics() : nullptr);
    std::unique_ptr<openxr::XrEyeDisplay> shown;
    std::unique_ptr<CompositeInput> composites;
    if (display) {
      shown = std::make_unique<openxr::XrEyeDisplay>(session);
      composites = std::make_unique<CompositeInput>(*participant, shown->max_width(), shown->max_height());
      spdlog::info("OpenXR runtime {}; showing the composited eyes ({}, {}) and locating both eyes in its {} space",
                   session.runtime(), context->renderer(),
                   shown->format() == openxr::kGlSrgb8Alpha8 ? "GL_SRGB8_ALPHA8" : "GL_RGBA8", o.space);
    } else {
      spdlog::info("OpenXR runtime {}; locating both eyes in its {} space", session.runtime(), o.space);
    }
    uint64_t sent = 0;
    std::string last_skip;
    // One frame: the views sent, the newest composited pair shown.
    const auto turn = [&](bool send) {
      const auto frame = session.BeginFrame();
      if (!frame) return false;
      if (frame->views && send) {
        if (composites) composites->Sent(frame->views->stamp_ns);
        writer.Write(EyeViewsToMsg(*frame->views));
        ++sent;
        counters.FrameOut(frame->views->stamp_ns);
      } else if (!frame->views && session.last_skip() != last_skip) {
        last_skip = session.last_skip();
        spdlog::warn("views not sent: {}", last_skip);  // once per reason in a row
      }
      std::vector<const XrCompositionLayerBaseHeader*> layers;
      if (shown) {
        if (auto pair = composites->Take()) shown->Show(*pair);
        if (frame->should_render && shown->Layer()) layers.push_back(shown->Layer());
      }
      session.EndFrame(*frame, layers);
      const auto& c = session.counts();
      counters.SetRejected(c.untracked + c.refused + (composites ? composites->skipped() : 0));
      return true;
    };
    while (!StopRequested() && !session.exiting() && (frames == 0 || sent < frames)) {
      if (!turn(true)) std::this_thread::sleep_for(std::chrono::milliseconds(5));  // not begun yet, or stopping
    }
    // The session ended before the process: the runtime gets its frames back.
    session.RequestExit();
    const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (!session.exiting() && std::chrono::steady_clock::now() < until) {
      if (!turn(false)) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    const auto& c = session.counts();
    spdlog::info("sent {} eye views of {} frames; {} untracked, {} refused", sent, c.frames, c.untracked, c.refused);
    if (shown)
      spdlog::info(
          "showed {} composited eye pairs; {} composites or poses not shown; {} poses not drawn from "
          "this client's views; {} render run changes",
          shown->counts().pairs_shown, composites->skipped(), composites->foreign(), composites->run_changes());
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
