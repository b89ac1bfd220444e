#include "record_export.h"

#include <filesystem>
#include <fstream>
#include <memory>
#include <set>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <spdlog/spdlog.h>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/record/recording.h"
#include "hullpipe/reconstruction/tile_set.h"
#include "hullpipe/util/logging.h"
#include "record_foxglove.h"
#include "record_ros2.h"

namespace hullpipe::record {
namespace {

using nlohmann::json;
using namespace hullpipe::dds;

json Vec(const hullpipe_msg_Vec3& v) { return {v.x, v.y, v.z}; }
template <size_t N>
json Arr(const double (&a)[N]) {
  return std::vector<double>(a, a + N);
}

// What one topic's export wrote.
struct Counts {
  int64_t samples = 0, undecodable = 0, pngs = 0, video_frames = 0, csv_rows = 0, json_lines = 0;
};

std::string FileName(const std::string& topic) {
  std::string s = topic;
  for (char& c : s)
    if (c == '/') c = '_';
  return s;
}

class Exporter {
 public:
  Exporter(const ExportOptions& o, const Participant& p) : o_(o), participant_(p) {
    if (o.foxglove)
      fox_ = std::make_unique<FoxgloveExport>((std::filesystem::path(o.out) / "foxglove.mcap").string(), p);
    if (o.ros2) ros2_ = std::make_unique<Ros2Export>((std::filesystem::path(o.out) / "ros2.mcap").string(), p);
  }
  const FoxgloveExport* foxglove() const { return fox_.get(); }
  const Ros2Export* ros2() const { return ros2_.get(); }

  // Decodes `s` of topic `t`, writes what its type exports; false if it did not decode.
  bool Add(const TopicInfo& t, const Sample& s, Counts* c) {
    const KnownType* kt = FindKnownType(t.type);
    if (!kt) return false;
    auto& w = writers_[t.type];
    if (!w) w = std::make_unique<CdrWriter>(participant_, *kt, QosSpec{t.reliable, t.transient_local, t.depth});
    json j = {{"topic", t.name}, {"arrival_ns", s.arrival_ns}, {"source_ns", s.source_ns}};
    if (fox_) fox_->Add(t, s);
    // (A sample that does not convert is counted below as undecodable; a file
    // that cannot be written ends the export with its error.)
    if (ros2_) ros2_->Add(t, s);
    bool ok = false;
    try {
      ok = Decode(t, s, *w, &j, c);
    } catch (const std::exception& e) {  // MessageError and friends: a sample the nodes would refuse
      j["error"] = e.what();
      ok = false;
    }
    if (o_.echo) {
      std::printf("%s\n", j.dump(-1, ' ', false, json::error_handler_t::replace).c_str());
      ++c->json_lines;
    } else if (o_.jsonl) {
      auto& f = jsonl_[t.name];
      const auto path = std::filesystem::path(o_.out) / (FileName(t.name) + ".jsonl");
      if (!f) f = std::make_unique<std::ofstream>(path);
      *f << j.dump(-1, ' ', false, json::error_handler_t::replace) << '\n';
      if (*f)
        ++c->json_lines;
      else
        Failed(path.string());
    }
    return ok;
  }

  // Closes the videos and the JSON lines and CSV files; a file that could not
  // be written in full is counted (Failed).
  void Finish() {
    for (auto& [name, v] : videos_) {
      v.release();
      const std::string path = (std::filesystem::path(o_.out) / (name + ".mp4")).string();
      std::error_code ec;
      if (std::filesystem::file_size(path, ec) == 0 || ec) Failed(path);
    }
    for (auto& [topic, f] : jsonl_) {
      f->close();
      if (!*f) Failed((std::filesystem::path(o_.out) / (FileName(topic) + ".jsonl")).string());
    }
    for (auto& [name, f] : csv_) {
      f->close();
      if (!*f) Failed((std::filesystem::path(o_.out) / (name + ".csv")).string());
    }
  }

  /// Records an output that could not be written (a full disk, a quota): the
  /// export exits 1 naming the first.
  void Failed(const std::string& path) {
    if (write_failures_++ == 0) first_failure_ = path;
  }
  int64_t write_failures() const { return write_failures_; }
  const std::string& first_failure() const { return first_failure_; }

 private:
  template <typename T, typename F>
  bool With(const CdrWriter& w, const Sample& s, F&& f) {
    return w.DecodeWith<T>(s.data, std::forward<F>(f));
  }

  void Frame(const std::string& name, const cv::Mat& bgr, Counts* c) {
    auto& v = videos_[name];
    if (!v.isOpened()) {
      const std::string path = (std::filesystem::path(o_.out) / (name + ".mp4")).string();
      if (!v.open(path, cv::VideoWriter::fourcc('m', 'p', '4', 'v'), o_.video_fps, bgr.size()))
        throw std::runtime_error(path + ": cannot open a video writer");
      video_size_[name] = bgr.size();
    }
    if (bgr.size() != video_size_[name]) return;  // a size change mid-stream: not written, not counted
    v.write(bgr);
    ++c->video_frames;
  }

  std::ofstream& Csv(const std::string& name, const char* header) {
    auto& f = csv_[name];
    if (!f) {
      f = std::make_unique<std::ofstream>(std::filesystem::path(o_.out) / (name + ".csv"));
      *f << header << '\n';
    }
    return *f;
  }

  bool Decode(const TopicInfo& t, const Sample& s, const CdrWriter& w, json* j, Counts* c) {
    const std::string& type = t.type;
    if (type == "hullpipe::msg::CameraInfo")
      return With<hullpipe_msg_CameraInfo>(w, s, [&](const auto& m) {
        (*j)["camera_id"] = m.camera_id, (*j)["width"] = m.width, (*j)["height"] = m.height;
        (*j)["K"] = Arr(m.K), (*j)["distortion"] = Arr(m.distortion);
        (*j)["cam_from_world_rotation"] = Arr(m.cam_from_world_rotation);
        (*j)["cam_from_world_translation"] = Arr(m.cam_from_world_translation);
        (*j)["workspace_min"] = Arr(m.workspace_min), (*j)["workspace_max"] = Arr(m.workspace_max);
        regions_.Calibrated(m.camera_id, int(std::min(m.width, 1u << 30)), int(std::min(m.height, 1u << 30)));
      });
    if (type == "hullpipe::msg::ObjectPixelMap")
      return With<hullpipe_msg_ObjectPixelMap>(w, s, [&](const auto& m) {
        (*j)["camera_id"] = m.camera_id, (*j)["frame_seq"] = m.frame_seq, (*j)["capture_time_ns"] = m.capture_time_ns;
        (*j)["width"] = m.width, (*j)["height"] = m.height, (*j)["runs"] = m.runs._length;
        const cv::Mat map = MapFromMsg(m);
        (*j)["object_pixels"] = cv::countNonZero(map);
        if (o_.media) {
          const auto dir = std::filesystem::path(o_.out) / "maps" / ("cam" + std::to_string(m.camera_id));
          std::filesystem::create_directories(dir);
          char name[32];
          std::snprintf(name, sizeof name, "%08llu.png", (unsigned long long)m.frame_seq);
          bool written = false;
          try {
            written = cv::imwrite((dir / name).string(), map);
          } catch (const cv::Exception&) {
          }
          if (written) {
            ++c->pngs;
          } else {
            Failed((dir / name).string());
          }
        }
      });
    if (type == "hullpipe::msg::CameraImage")
      return With<hullpipe_msg_CameraImage>(w, s, [&](const auto& m) {
        (*j)["camera_id"] = m.camera_id, (*j)["frame_seq"] = m.frame_seq, (*j)["capture_time_ns"] = m.capture_time_ns;
        (*j)["width"] = m.width, (*j)["height"] = m.height, (*j)["encoding"] = m.encoding;
        (*j)["bytes"] = m.data._length;
        if (ImageHasRegion(m)) {
          // Only that region of a whole image was sent (capture_node --image-region).
          (*j)["x"] = m.x, (*j)["y"] = m.y, (*j)["full_width"] = m.full_width, (*j)["full_height"] = m.full_height;
        }
        regions_.CheckRegion(m);
        const cv::Mat bgr = ImageFromMsg(m);
        if (o_.media) Frame("images_cam" + std::to_string(m.camera_id), bgr, c);
      });
    if (type == "hullpipe::msg::ViewPose")
      return With<hullpipe_msg_ViewPose>(w, s, [&](const auto& m) {
        const NovelView v = ViewFromMsg(m);
        (*j)["pose_seq"] = m.pose_seq, (*j)["frame_seq"] = m.frame_seq, (*j)["stamp_ns"] = m.stamp_ns;
        (*j)["width"] = v.width, (*j)["height"] = v.height, (*j)["fx"] = v.fx, (*j)["fy"] = v.fy;
        (*j)["cx"] = v.cx, (*j)["cy"] = v.cy, (*j)["run_id"] = m.run_id;
        (*j)["world_from_eye_rotation"] = Arr(m.world_from_eye_rotation);
        (*j)["world_from_eye_translation"] = Arr(m.world_from_eye_translation);
        (*j)["eye"] = m.eye;
        eyes_[m.pose_seq] = ViewEye(m.eye);  // checked by ViewFromMsg
        while (eyes_.size() > 256) eyes_.erase(eyes_.begin());
      });
    if (type == "hullpipe::msg::CompositedView")
      return With<hullpipe_msg_CompositedView>(w, s, [&](const auto& m) {
        const cv::Mat bgr = CompositedViewFromMsg(m);
        (*j)["pose_seq"] = m.pose_seq, (*j)["frame_seq"] = m.frame_seq, (*j)["capture_time_ns"] = m.capture_time_ns;
        (*j)["width"] = m.width, (*j)["height"] = m.height, (*j)["view_width"] = m.view_width;
        (*j)["view_height"] = m.view_height, (*j)["bytes"] = m.data._length, (*j)["run_id"] = m.run_id;
        (*j)["eye"] = m.eye;
        if (o_.media) Frame(ForEye("composited", ViewEye(m.eye), '_'), bgr, c);  // a video per eye
      });
    if (type == "hullpipe::msg::HullView")
      return With<hullpipe_msg_HullView>(w, s, [&](const auto& m) {
        HullTile tile = TileFromMsg(m);
        (*j)["node_id"] = m.node_id, (*j)["tile_index"] = m.tile_index, (*j)["tile_count"] = m.tile_count;
        (*j)["rect"] = {m.x, m.y, m.width, m.height}, (*j)["pose_seq"] = m.pose_seq, (*j)["frame_seq"] = m.frame_seq;
        (*j)["capture_time_ns"] = m.capture_time_ns, (*j)["planes"] = m.planes, (*j)["render_ms"] = m.render_ms;
        if (o_.media) AddTile(std::move(tile), c);
      });
    if (type == "hullpipe::msg::VirtualObjectState")
      return With<hullpipe_msg_VirtualObjectState>(w, s, [&](const auto& m) {
        const VirtualObjectSample o = VirtualObjectFromMsg(m);
        (*j)["object_id"] = o.object_id, (*j)["frame_seq"] = o.frame_seq, (*j)["sim_time"] = o.sim_time;
        (*j)["shape"] = o.shape == VirtualObjectSample::Shape::kBox ? "box" : "sphere";
        (*j)["radius"] = o.radius, (*j)["position"] = Vec(m.position), (*j)["velocity"] = Vec(m.velocity);
        (*j)["orientation_wxyz"] = Arr(m.orientation), (*j)["half_extents"] = Vec(m.half_extents);
        (*j)["colliding"] = o.colliding;
      });
    if (type == "hullpipe::msg::CollisionReport")
      return With<hullpipe_msg_CollisionReport>(w, s, [&](const auto& m) {
        (*j)["object_id"] = m.object_id, (*j)["frame_seq"] = m.frame_seq, (*j)["capture_time_ns"] = m.capture_time_ns;
        (*j)["triangles"] = m.triangle_ids._length, (*j)["collision_points"] = m.collision_points._length;
        (*j)["has_response"] = m.has_response, (*j)["cp_obj"] = Vec(m.cp_obj), (*j)["cp_hull"] = Vec(m.cp_hull);
        (*j)["v_rec"] = Vec(m.v_rec), (*j)["d_rec"] = m.d_rec, (*j)["n_hull"] = Vec(m.n_hull);
        if (o_.media) {
          auto& f = Csv("collision_report",
                        "arrival_ns,object_id,frame_seq,capture_time_ns,triangles,collision_points,has_response,"
                        "cp_obj_x,cp_obj_y,cp_obj_z,cp_hull_x,cp_hull_y,cp_hull_z,v_rec_x,v_rec_y,v_rec_z,d_rec,"
                        "n_hull_x,n_hull_y,n_hull_z");
          f << s.arrival_ns << ',' << m.object_id << ',' << m.frame_seq << ',' << m.capture_time_ns << ','
            << m.triangle_ids._length << ',' << m.collision_points._length << ',' << int(m.has_response);
          for (const auto& v : {m.cp_obj, m.cp_hull, m.v_rec}) f << ',' << v.x << ',' << v.y << ',' << v.z;
          f << ',' << m.d_rec << ',' << m.n_hull.x << ',' << m.n_hull.y << ',' << m.n_hull.z << '\n';
          ++c->csv_rows;
        }
      });
    if (type == "hullpipe::msg::NodeStats")
      return With<hullpipe_msg_NodeStats>(w, s, [&](const auto& m) {
        const NodeStatsSample st = NodeStatsFromMsg(m);
        (*j)["node"] = st.name, (*j)["host"] = st.host, (*j)["fps"] = st.fps, (*j)["backend"] = st.backend;
        (*j)["latency_ms_p50"] = st.latency_ms_p50, (*j)["latency_ms_p95"] = st.latency_ms_p95;
        (*j)["frames_in"] = st.frames_in, (*j)["frames_out"] = st.frames_out, (*j)["dropped"] = st.dropped;
        (*j)["rejected"] = st.rejected, (*j)["final_report"] = st.final_report;
        for (const auto& [name, g] : st.stages)
          (*j)["stages"][name] = {
              {"ms_mean", g.ms_mean}, {"ms_p50", g.ms_p50}, {"ms_p95", g.ms_p95}, {"count", g.count}};
        if (o_.media) {
          auto& f = Csv("node_stats",
                        "arrival_ns,node,host,fps,latency_ms_p50,latency_ms_p95,frames_in,frames_out,dropped,"
                        "rejected,final_report,backend");
          f << s.arrival_ns << ',' << st.name << ',' << st.host << ',' << st.fps << ',' << st.latency_ms_p50 << ','
            << st.latency_ms_p95 << ',' << st.frames_in << ',' << st.frames_out << ',' << st.dropped << ','
            << st.rejected << ',' << int(st.final_report) << ",\"" << st.backend << "\"\n";
          ++c->csv_rows;
        }
      });
    if (type == "hullpipe::msg::VirtualMesh")
      return With<hullpipe_msg_VirtualMesh>(w, s, [&](const auto& m) {
        const VirtualMeshSample mesh = VirtualMeshFromMsg(m);
        (*j)["object_id"] = mesh.object_id, (*j)["kind"] = mesh.kind, (*j)["frame_seq"] = mesh.frame_seq;
        (*j)["vertices"] = mesh.draw.vertices.size(), (*j)["triangles"] = mesh.draw.triangles.size();
        int colliding = 0;
        for (auto flag : mesh.draw.colliding) colliding += flag != 0;
        (*j)["colliding_triangles"] = colliding, (*j)["clearance"] = mesh.clearance;
        (*j)["element"] = mesh.element;
      });
    if (type == "hullpipe::msg::EyeViews")
      return With<hullpipe_msg_EyeViews>(w, s, [&](const auto& m) {
        const EyeViewsSample v = EyeViewsFromMsg(m);
        (*j)["tracker_id"] = v.tracker_id, (*j)["stamp_ns"] = v.stamp_ns;
        for (int k = 0; k < 2; ++k) {
          const hullpipe_msg_EyeView& e = m.eyes[k];
          (*j)[k == 0 ? "left" : "right"] = {{"position", Arr(e.position)},
                                             {"orientation_xyzw", Arr(e.orientation)},
                                             {"fov_left_right_up_down", Arr(e.fov)}};
        }
      });
    if (type == "hullpipe::msg::CameraPose")
      return With<hullpipe_msg_CameraPose>(w, s, [&](const auto& m) {
        (void)CameraPoseFromMsg(m);
        (*j)["camera_id"] = m.camera_id, (*j)["stamp_ns"] = m.stamp_ns;
        (*j)["world_from_camera_rotation"] = Arr(m.world_from_camera_rotation);
        (*j)["world_from_camera_translation"] = Arr(m.world_from_camera_translation);
      });
    if (type == "hullpipe::msg::ModelPart")
      return With<hullpipe_msg_ModelPart>(w, s, [&](const auto& m) {
        const ModelPartSample p = ModelPartFromMsg(m);
        (*j)["object_id"] = p.object_id, (*j)["model_id"] = p.model_id, (*j)["part_index"] = p.part_index;
        (*j)["part_count"] = p.part_count, (*j)["name"] = p.name, (*j)["file"] = p.file;
        (*j)["vertices"] = p.vertices.size(), (*j)["triangles"] = p.triangles.size();
        (*j)["colour_bgr"] = {p.colour[0], p.colour[1], p.colour[2]};
      });
    if (type == "hullpipe::msg::ModelState")
      return With<hullpipe_msg_ModelState>(w, s, [&](const auto& m) {
        const ModelStateSample st = ModelStateFromMsg(m);
        (*j)["model_id"] = st.model_id, (*j)["frame_seq"] = st.frame_seq, (*j)["capture_time_ns"] = st.capture_time_ns;
        (*j)["triangles"] = st.triangles, (*j)["boxes_tested"] = st.boxes_tested;
        (*j)["triangles_queried"] = st.triangles_queried, (*j)["query_ms"] = st.query_ms;
        // Each part's pose and contact; past 64 parts only counted (a line per step stays small).
        json parts = json::array();
        for (size_t i = 0; i < st.parts.size() && i < 64; ++i) {
          const PartStateSample& ps = st.parts[i];
          parts.push_back(
              {{"position", {ps.position.x(), ps.position.y(), ps.position.z()}},
               {"orientation_wxyz", {ps.orientation[0], ps.orientation[1], ps.orientation[2], ps.orientation[3]}},
               {"contact", ps.contact},
               {"clearance", ps.clearance}});
        }
        (*j)["parts"] = std::move(parts), (*j)["part_count"] = st.parts.size();
      });
    if (type == "hullpipe::msg::SceneCommand")
      return With<hullpipe_msg_SceneCommand>(w, s, [&](const auto& m) {
        (*j)["command_seq"] = m.command_seq, (*j)["stamp_ns"] = m.stamp_ns, (*j)["command"] = m.command;
        (*j)["value"] = m.value;
      });
    if (type == "hullpipe::msg::HeadPose")
      return With<hullpipe_msg_HeadPose>(w, s, [&](const auto& m) {
        (void)HeadPoseFromMsg(m);
        (*j)["tracker_id"] = m.tracker_id, (*j)["stamp_ns"] = m.stamp_ns;
        (*j)["world_from_eye_rotation"] = Arr(m.world_from_eye_rotation);
        (*j)["world_from_eye_translation"] = Arr(m.world_from_eye_translation);
      });
    return false;
  }

  // Hull views: the tiles of one pose, pasted into one frame once all arrived.
  void AddTile(HullTile t, Counts* c) {
    const auto eye = eyes_.find(t.pose_seq);  // its ViewPose's eye; unseen: the one view
    const std::string name = ForEye("hull_view", eye == eyes_.end() ? ViewEye::kMono : eye->second, '_');
    if (const auto view = tiles_.Add(std::move(t))) Frame(name, view->colour, c);
  }

  const ExportOptions& o_;
  const Participant& participant_;
  std::map<std::string, std::unique_ptr<CdrWriter>> writers_;
  std::map<std::string, std::unique_ptr<std::ofstream>> jsonl_, csv_;
  std::map<std::string, cv::VideoWriter> videos_;
  std::map<std::string, cv::Size> video_size_;
  TileSet tiles_;  // HullView tiles by pose, until a view is whole
  std::map<uint64_t, ViewEye> eyes_;  // the newest 256 ViewPoses' eyes by pose_seq
  RegionBounds regions_;  // the cameras' calibrated sizes: what bounds a region's whole image
  std::unique_ptr<FoxgloveExport> fox_;
  std::unique_ptr<Ros2Export> ros2_;
  int64_t write_failures_ = 0;
  std::string first_failure_;
};

}  // namespace

void AddExportOptions(CLI::App* sub, ExportOptions& o, bool echo) {
  sub->add_option("recording", o.recording, "Recording (file or split directory)")->required();
  sub->add_option("--topic", o.topics, "Only topics matching these globs (default: all)");
  sub->add_option("--start", o.start_s, "From this many seconds after the recording's start");
  sub->add_option("--end", o.end_s, "Up to this many seconds after the recording's start (0: its end)");
  sub->fallthrough();
  if (echo) return;
  sub->add_option("-o,--output", o.out, "Directory to create (never overwritten)")->required();
  sub->add_flag("!--no-jsonl", o.jsonl, "No JSON lines");
  sub->add_flag("!--no-media", o.media, "No PNG, video or CSV");
  sub->add_option("--fps", o.video_fps, "Frame rate of the videos")->capture_default_str();
  sub->add_flag("--ros2", o.ros2,
                "Also OUT/ros2.mcap: the cameras, maps and frames as ROS 2 topics, as rosbag2 writes MCAP "
                "(ros2 bag play, Foxglove; docs/ros2.md)");
  sub->add_flag("--foxglove", o.foxglove,
                "Also OUT/foxglove.mcap: the recording's channels and viewable ones in Foxglove's schemas (images, "
                "maps, calibration, transforms, balls and collision points, node rates)");
}

int Export(const ExportOptions& o, const dds::CommonOptions& common) {
  if (!(o.start_s >= 0 && o.start_s <= 1e6)) throw std::invalid_argument("--start must be in [0, 1e6] s");
  if (!(o.end_s == 0 || (o.end_s > o.start_s && o.end_s <= 1e6)))
    throw std::invalid_argument("--end must be 0 or after --start, at most 1e6 s");
  if (!(o.video_fps > 0 && o.video_fps <= 1000)) throw std::invalid_argument("--fps must be in (0, 1000]");
  const RecordingReader rec(o.recording);
  if (!o.echo && std::filesystem::exists(o.out))
    throw std::runtime_error(o.out + ": exists; exports are never overwritten");
  std::vector<int64_t> ids;
  std::map<int64_t, const TopicInfo*> by_id;
  for (const auto& t : rec.topics())
    if (TopicSelected(o.topics, {}, t.name)) {
      ids.push_back(t.id);
      by_id[t.id] = &t;
    }
  if (ids.empty()) throw std::runtime_error(o.recording + ": no topic matches --topic");
  if (!o.echo) std::filesystem::create_directories(o.out);
  auto participant = StartNode("export", common);
  Exporter ex(o, *participant);
  std::map<std::string, Counts> counts;
  for (const auto& [id, t] : by_id) counts[t->name];
  const int64_t first = rec.FirstArrivalNs().value_or(0);
  const int64_t from = first + int64_t(o.start_s * 1e9), to = o.end_s > 0 ? first + int64_t(o.end_s * 1e9) : INT64_MAX;
  std::set<std::string> reported;
  rec.ForEach([&](const Sample& s) {
    if (StopRequested()) return false;
    if (s.arrival_ns < from) return true;
    if (s.arrival_ns > to) return false;
    const TopicInfo& t = *by_id.at(s.topic_id);
    Counts& c = counts[t.name];
    ++c.samples;
    if (!ex.Add(t, s, &c)) {
      ++c.undecodable;
      if (reported.insert(t.name).second)
        spdlog::warn("{}: a sample at {} ns does not decode as {} (further ones counted)", t.name, s.arrival_ns,
                     t.type);
    }
    return true;
  }, ids);
  ex.Finish();
  if (rec.damaged_samples() > 0)
    spdlog::error("{}: {} damaged sample(s) skipped (CRC-32 mismatch, a bad frame or an unknown topic); "
                  "`hullpipe_record info` says more", o.recording, rec.damaged_samples());
  // What the samples read cannot show (a file cut short, a record that lies
  // about its length, a channel redefined, a message on no channel): the
  // structural check `info` makes, so echo and export name the damage and exit
  // 3 as info does, after giving what reads.
  const std::string structural = StopRequested() ? std::string() : rec.QuickCheck();
  if (!structural.empty())
    spdlog::error("{}: damaged: {} ({} what reads; `hullpipe_record repair` keeps the sound part)", o.recording,
                  structural, o.echo ? "echoed" : "exported");
  json summary;
  summary["recording"] = o.recording;
  int64_t undecodable = 0;
  for (const auto& [name, c] : counts) {
    summary["topics"][name] = {{"samples", c.samples},   {"undecodable", c.undecodable}, {"pngs", c.pngs},
                               {"video_frames", c.video_frames}, {"csv_rows", c.csv_rows},
                               {"json_lines", c.json_lines}};
    spdlog::info("{}: {} samples -> {} PNG, {} video frames, {} CSV rows, {} JSON lines{}", name, c.samples, c.pngs,
                 c.video_frames, c.csv_rows, c.json_lines,
                 c.undecodable ? fmt::format(" ({} did not decode)", c.undecodable) : "");
    undecodable += c.undecodable;
  }
  if (const FoxgloveExport* fox = ex.foxglove()) {
    summary["foxglove"]["file"] = fox->path();
    for (const auto& [channel, n] : fox->counts()) summary["foxglove"]["channels"][channel] = n;
    spdlog::info("{}: the recording's channels and {} viewable ones (open it in Foxglove or Lichtblick)", fox->path(),
                 fox->counts().size());
  }
  if (const Ros2Export* r = ex.ros2()) {
    summary["ros2"]["file"] = r->path();
    for (const auto& [topic, n] : r->counts()) summary["ros2"]["topics"][topic] = n;
    spdlog::info("{}: {} ROS 2 topics (ros2 bag play, Foxglove)", r->path(), r->counts().size());
  }
  summary["command"] = CommandLine();
  if (!o.echo) {
    const auto path = std::filesystem::path(o.out) / "export.json";
    std::ofstream f(path);
    f << summary.dump(1) << '\n';
    f.close();
    if (!f) ex.Failed(path.string());
  }
  if (ex.write_failures() > 0) {
    spdlog::error("{} output file(s) could not be written (a full disk?), the first {}; the export is incomplete",
                  ex.write_failures(), ex.first_failure());
    return 1;
  }
  if (StopRequested()) {
    spdlog::error("export stopped by a signal before the end; {} is incomplete", o.out);
    return 1;
  }
  if (!rec.missing_parts().empty())
    spdlog::error("{}: {}: exported what the other parts hold (exit 3)", o.recording, rec.missing_parts());
  return undecodable || rec.damaged_samples() > 0 || !rec.missing_parts().empty() || !structural.empty() ? 3 : 0;
}

}  // namespace hullpipe::record
