#include "hullpipe/nodes/render_outputs.h"

#include <filesystem>

#include <opencv2/highgui.hpp>
#include <opencv2/imgcodecs.hpp>
#include <spdlog/spdlog.h>

namespace hullpipe::nodes {

namespace fs = std::filesystem;

RenderOutputs::RenderOutputs(RenderOutputOptions options) : o_(std::move(options)) {
  fs::create_directories(o_.out_dir);
}

std::string RenderOutputs::video_path() const { return (fs::path(o_.out_dir) / "hullpipe.mp4").string(); }

void RenderOutputs::WriteView(std::ofstream& out, const std::string& name, uint64_t frame_seq, double path_time_s,
                              const NovelView& view) {
  if (!out.is_open()) {
    out.open((fs::path(o_.out_dir) / name).string());
    out << "frame_seq,path_time_s,width,height,fx,fy,cx,cy,"
           "r00,r01,r02,r10,r11,r12,r20,r21,r22,tx,ty,tz\n";
  }
  const Eigen::Matrix3d& R = view.world_from_eye.rotation;
  const Eigen::Vector3d& t = view.world_from_eye.translation;
  out << frame_seq << ',' << cv::format("%.9f", path_time_s) << ',' << view.width << ',' << view.height;
  for (double x : {view.fx, view.fy, view.cx, view.cy, R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0),
                   R(2, 1), R(2, 2), t.x(), t.y(), t.z()})
    out << ',' << cv::format("%.17g", x);
  out << '\n' << std::flush;
}

void RenderOutputs::WriteFrame(const cv::Mat& frame, uint64_t frame_seq, uint64_t count, const NovelView& view,
                               const cv::Mat& hull_depth, double path_time_s, const RenderSink::RightEye* right) {
  if (!video_.isOpened() && !video_failed_) {
    video_.open(video_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), o_.video_fps, frame.size());
    if (!video_.isOpened()) {
      video_failed_ = true;
      Failed(video_path());
    }
  }
  if (video_.isOpened()) {
    video_.write(frame);
    ++video_frames_;
  }
  const auto every = uint64_t(o_.png_every);
  if (o_.png_every > 0 && count % every == 1 % every) {
    const std::string stem =
        (fs::path(o_.out_dir) / cv::format("frame_%05llu", (unsigned long long)frame_seq)).string();
    Write(stem + ".png", frame);
    if (o_.save_depth) {
      // The hull's eye-z depth (float TIFF, metres, +inf: no hull) and the view
      // it was seen from, so the frame can be checked against a reference.
      Write(stem + "_depth.tiff", hull_depth);
      WriteView(views_, "views.csv", frame_seq, path_time_s, view);
      if (right) {
        Write(stem + "_right_depth.tiff", right->hull_depth);
        WriteView(views_right_, "views_right.csv", frame_seq, path_time_s, right->view);
      }
    }
  }
  if (o_.show) {
    try {
      cv::imshow("hullpipe", frame);
      cv::waitKey(1);
    } catch (const cv::Exception& e) {
      spdlog::warn("cannot open a window ({}); continuing without", e.what());
      o_.show = false;
    }
  }
}

bool RenderOutputs::WriteTextFile(const std::string& name, const std::string& text) {
  const std::string path = (fs::path(o_.out_dir) / name).string();
  std::ofstream f(path);
  f << text;
  f.close();
  if (f) return true;
  Failed(path);
  return false;
}

void RenderOutputs::Write(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok) Failed(path);
}

void RenderOutputs::Failed(const std::string& path) {
  if (failures_++ == 0) {
    first_failure_ = path;
    spdlog::error("cannot write {} (further failures are counted)", path);
  }
}

}  // namespace hullpipe::nodes
