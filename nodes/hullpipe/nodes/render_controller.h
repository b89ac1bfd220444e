// render_node's run-time logic (paper §3–§4, the parent pipe): it owns the
// user's viewpoint, requests each new complete frameset's tiles with a ViewPose
// (at most max_in_flight at once), assembles the recon nodes' tiles, gives up on
// a pose whose tiles do not come within tile_timeout, lets a composited pose
// supersede older ones, composites hull and virtual objects with the depth test
// (colliding objects red), notices recon nodes that fall silent, detects the end
// of input and writes the stats.json schema. DDS-free and GL-free: the main feeds
// it samples and gives it a RenderSink; tests drive it with a FakeClock.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "hullpipe/geometry/aabb.h"
#include "hullpipe/geometry/head_pose.h"
#include "hullpipe/pipeline/clock.h"
#include "hullpipe/util/reject_log.h"
#include "hullpipe/nodes/latency_budget.h"
#include "hullpipe/pipeline/messages.h"
#include "hullpipe/pipeline/node_counters.h"
#include "hullpipe/nodes/peer_liveness.h"
#include "hullpipe/nodes/run_filter.h"
#include "hullpipe/nodes/run_report.h"
#include "hullpipe/reconstruction/frameset.h"
#include "hullpipe/reconstruction/plane_sweep.h"
#include "hullpipe/reconstruction/stereo_views.h"
#include "hullpipe/geometry/rig_world.h"
#include "hullpipe/scenes/lighting.h"

namespace hullpipe::nodes {

/// render_node's world flags as given on its command line; unset ones come
/// from the rig's world (RenderOptions::ApplyWorld).
struct WorldFlags {
  std::optional<Eigen::Vector3d> up;  ///< --up
  std::string floor;                  ///< --floor: "" (the rig's), metres along up, "hull" or "none"
  std::optional<double> orbit_radius, orbit_height;  ///< --orbit-radius, --orbit-height
};

/// render_node's settings (its flags). Lengths in metres, times in seconds.
struct RenderOptions {
  int width = 320, height = 240;  ///< Novel view, pixels (1..8192).
  double hfov_deg = 50;           ///< Horizontal field of view, degrees (0, 179].
  int tiles = 2;                  ///< Tiles per frame = recon nodes (1..64).
  int max_in_flight = 2;          ///< Poses rendered at once (1..64).
  int64_t max_frames = 0;         ///< Stop after compositing this frame_seq (0: never).
  double idle_timeout = 5;        ///< End when no new frameset came for this long.
  /// Give up on a pose's missing tiles after this long, at first: a tile that
  /// comes later than this for a pose already given up raises it to twice
  /// that tile's round trip (at most kMaxTileTimeoutS), so a rig whose recon
  /// nodes need longer (many cameras) composites at the rate it can, not none.
  double tile_timeout = 1.0;
  /// Once a pose's tiles are all in, wait at most this long (seconds) for the
  /// simulation's output of its frameset (sim_node publishes every object
  /// after each step; paper §4: objects drawn where that frame's hull put
  /// them), where a simulation is publishing and has not reached the frameset
  /// yet; past it, the newest states before it are drawn.
  double sim_wait = 0.1;
  double recon_silence = 1.0;     ///< A recon node without NodeStats this long is silent.
  double end_grace = 0.5;         ///< After capture's final report, time for its last samples.
  /// The scripted orbit (used until a tracked pose exists).
  double orbit_radius = 3.0, orbit_height = 0.7, orbit_period = 12.0;
  std::optional<Eigen::Vector3d> orbit_centre;  ///< Default: the first hull box's centre.
  Eigen::Vector3d up{0, 0, -1};                 ///< World up (Utrecht rig: z down).
  /// The floor drawn (rig_world.h): the plane up . x = floor_height, under the
  /// first hull (its box's lowest point along up), or none. Default: the Utrecht
  /// rig's, z = 0.
  RigWorld::Floor floor = RigWorld::Floor::kPlane;
  double floor_height = 0;
  /// kEyes: each eye's pose and field of view from eye_track (an HMD runtime's
  /// xrLocateViews log, stereo_views.h), in stereo; kEyesTopic: from the newest
  /// EyeViews sample (OnEyeViews; the orbit's eyes until the first arrives).
  enum class View { kOrbit, kFile, kTopic, kEyes, kEyesTopic } view = View::kOrbit;
  PoseTrack track;                   ///< For View::kFile.
  std::optional<StereoViewTrack> eye_track;  ///< For View::kEyes.
  std::optional<LightConfig> light;  ///< The scene's light (shadows), if any.
  /// A head-mounted display's two eyes (--stereo, --ipd, --fov-left,
  /// --fov-right; reconstruction/stereo_views.h): each frame's head pose (the
  /// orbit's, the pose log's or the tracker's) gives a left and a right eye,
  /// each width x height with its own off-axis projection (StereoOptions'
  /// width and height are taken from these), asked of the recon nodes as two
  /// ViewPoses of one frameset; each eye is composited and lit on its own, the
  /// video and PNGs show them side by side (left, right: 2 width x height), and
  /// each eye's composite is published with its own pose. nullopt: one view
  /// (hfov_deg).
  std::optional<StereoOptions> stereo;
  /// Each composited frame also goes to RenderSink::PublishComposite (the
  /// CompositedView topic, for viewers and recordings), scaled down to at most
  /// publish_max_side px on its longer side (16..16384) and JPEG-encoded at
  /// publish_jpeg_quality (1..100).
  bool publish_composite = true;
  int publish_max_side = 1280;
  int publish_jpeg_quality = 85;
  /// This run (nodes/run_filter.h): its poses carry it, and tiles and NodeStats of
  /// another run are ignored. The main gives --run-id or a random id; 0 (tests)
  /// takes only tiles without one.
  uint64_t run_id = 0;
  /// Throws std::invalid_argument naming the flag that is out of range.
  void Check() const;
  /// Resolves up, floor and orbit: the rig's world (rig_world.h; nullptr: keep
  /// these defaults, the Utrecht rig's world: up -z, the floor z = 0), then each
  /// flag that was given over it. Throws std::invalid_argument naming --floor
  /// when its text is not metres, 'hull' or 'none'.
  void ApplyWorld(const RigWorld* rig, const WorldFlags& flags);
};

/// Where render's outputs go (ViewPose messages; the video, PNGs and window).
class RenderSink {
 public:
  virtual ~RenderSink() = default;
  /// Ask the recon nodes for frameset frame_seq seen from `view`, the view of
  /// `eye` (kMono: the one view; in stereo the left eye's pose, then the
  /// right's, pose_seq one apart). stamp_ns: when the pose was sampled
  /// (ViewPose.stamp_ns, CLOCK_REALTIME ns): the tracker's HeadPose or the
  /// HMD runtime's EyeViews stamp it came from, so that a headset client can
  /// tell the poses drawn from its views; 0 for a scripted view (the sink
  /// stamps it now).
  virtual void PublishPose(const NovelView& view, uint64_t pose_seq, uint64_t frame_seq, ViewEye eye,
                           int64_t stamp_ns) = 0;
  /// One composited frame (CV_8UC3), the `count`-th, of frameset frame_seq, seen
  /// from `view`; hull_depth: the assembled tiles' eye-z depth (CV_32FC1 metres,
  /// kNoDepth where no hull), path_time_s: the time along the viewpoint's path
  /// (orbit or tracker log: the frameset's source time less the first one's).
  /// In stereo (RenderOptions::stereo) `frame` holds both eyes side by side,
  /// `view` and hull_depth are the left eye's, and right (non-null) the right
  /// eye's.
  struct RightEye {
    const NovelView& view;
    const cv::Mat& hull_depth;
  };
  virtual void WriteFrame(const cv::Mat& frame, uint64_t frame_seq, uint64_t count, const NovelView& view,
                          const cv::Mat& hull_depth, double path_time_s, const RightEye* right = nullptr) = 0;
  /// The same frame for viewers (RenderOptions::publish_composite): composited
  /// for pose pose_seq (of `eye`) from frameset frame_seq, captured at
  /// capture_time_ns. In stereo, once per eye with that eye's image alone. A
  /// sink that publishes nothing may ignore it.
  virtual void PublishComposite(const cv::Mat& frame, uint64_t pose_seq, uint64_t frame_seq,
                                int64_t capture_time_ns, ViewEye eye) {
    (void)frame, (void)pose_seq, (void)frame_seq, (void)capture_time_ns, (void)eye;
  }
};

class RenderController {
 public:
  /// `assembler` is fed by the caller (maps and camera info); `options` are
  /// checked (std::invalid_argument).
  RenderController(RenderOptions options, const Clock& clock, FramesetAssembler& assembler, RenderSink& sink);

  // Inputs, as they arrive. A tile for an unknown pose is counted late; one that
  // does not fit the view is rejected (std::invalid_argument, nothing kept). A
  // tile or NodeStats of another run is ignored, counted in stats.json
  // ("ignored_from_other_runs") and named in one warning per run.
  /// sent_ns: the tile's DDS source timestamp (CLOCK_REALTIME ns on the recon
  /// node's host; 0: unknown), for the budget's "transport_tile".
  void OnTile(HullTile tile, int64_t sent_ns = 0);
  void OnObjectState(const VirtualObjectSample& state);
  void OnMesh(VirtualMeshSample mesh);
  /// A CAD model part's geometry (sent once, transient-local); a part sent
  /// again replaces it.
  void OnModelPart(ModelPartSample part);
  /// A model's part poses and contact states for one frameset.
  void OnModelState(ModelStateSample state);
  /// A tracker's head pose (View::kTopic), measured at stamp_ns (CLOCK_REALTIME
  /// ns; 0: unknown). The frame composited from it times the stage
  /// "tracker_to_eye": that stamp to its eye images written (docs/hmd.md).
  void OnHeadPose(const Rigid3d& world_from_eye, int64_t stamp_ns = 0);
  /// An HMD runtime's two views (View::kEyesTopic); the frame composited from
  /// them times "tracker_to_eye" from their stamp_ns.
  void OnEyeViews(const EyeViewsSample& views);
  /// A CollisionReport: whether it has collision points, and its response's
  /// hull velocity (HullVelocityStatus value, 0: none; the normal speed, m/s),
  /// counted into stats.json's "hull_velocity".
  void OnCollisionReport(bool has_points, uint8_t hull_velocity_status = 0, double hull_normal_speed = 0);
  void OnNodeStats(const NodeStatsSample& stats);
  /// Most node names whose reports are kept; reports of further names are
  /// ignored and counted (stats.json "node_stats_over_limit").
  static constexpr size_t kMaxNodes = RunReport::kMaxNodes;
  uint64_t node_stats_over_limit() const { return report_.node_stats_over_limit(); }
  /// Whether a peer heard from (any node name but render's own) has not yet
  /// sent its final report: render, stopping, waits for those (bounded by its
  /// caller) so stats.json holds every node's last figures.
  bool AwaitingFinalReports() const;
  /// A malformed sample the caller could not convert: counted, its line
  /// written as RejectLog bounds it.
  void Reject(const std::string& why);
  /// Input samples the caller could not decode before they reached the
  /// assembler (counted into this node's rejected, with the assembler's own).
  void SetMalformedInput(uint64_t n) { malformed_input_ = n; }

  /// One round: new poses for new complete framesets, composites every pose
  /// whose tiles are in, drops timed-out poses, recon liveness, end of input.
  /// Returns the number of frames composited this round. Throws Interrupted
  /// (util/interrupt.h) when the stop flag is set mid-composite: the node is
  /// stopping, and that frame is not written.
  int Step();
  /// The flag compositing and lighting poll per row (nullptr: never stops).
  void set_stop(StopFlag stop) { stop_ = stop; }
  /// The run is over (max_frames reached, input ended or idle).
  bool done() const { return done_; }
  /// Once every capture node reported the end of its input: one line naming the
  /// cameras whose input ended early (FramesetAssembler::EndedEarly; with a
  /// camera per capture node, no capture node can see that itself), else "".
  /// render_node then exits 3, as capture_node does for its own cameras.
  std::string IncompleteInput() const;

  /// stats.json (RunReport::StatsJson): the view, counts, outages, payload
  /// clearances, the world drawn (up, floor, orbit, the first hull's box) and
  /// every node's newest report (this node's own under "render").
  nlohmann::json StatsJson() const;
  /// The end-of-run table (RunReport::Table), one row per node, then the latency budget.
  std::string Table() const;
  /// What this controller knows of the run, for its report.
  RunFacts Facts() const;
  /// The latency budget from every node's newest report and render's own
  /// (nodes/latency_budget.h); in stats.json as "latency_budget".
  LatencyBudget Budget() const;

  const NodeCounters& counters() const { return counters_; }
  NodeCounters& counters() { return counters_; }
  uint64_t rejected() const { return rejected_; }
  uint64_t tiles_late() const { return tiles_late_; }
  /// Poses given up on whose tiles all came later and were composited then.
  uint64_t late_composited() const { return late_composited_; }
  /// At the input's end, a pose given up on is waited for this long after it
  /// was sent (its tiles may still come: a first frameset that takes seconds).
  static constexpr double kLateWaitS = 10;
  /// The tile time-out in force (tile_timeout, or raised by late tiles).
  double tile_timeout() const { return tile_timeout_; }
  /// The most the tile time-out is raised to, seconds.
  static constexpr double kMaxTileTimeoutS = 60;
  uint64_t last_composited() const { return last_composited_; }
  size_t in_flight() const { return in_flight_.size(); }
  const PeerLiveness& recon_liveness() const { return recon_liveness_; }
  const OrbitPath& orbit() const { return orbit_; }
  const RunFilter& runs() const { return runs_; }

 private:
  struct InFlight {
    uint64_t frame_seq = 0;
    int64_t capture_time_ns = 0;
    double path_time_s = 0;
    double sent_s = 0;
    double tiles_in_s = 0;  // when its last tile came
    struct Eye {
      NovelView view;
      std::map<uint32_t, HullTile> tiles;  // by tile index
    };
    std::vector<Eye> eyes;                     // one, or left and right: eye k's pose_seq is the key + k
    cv::Mat light_hull_depth;                  // the hull seen from the light (HullDepthFromLight), with a light
    int64_t head_stamp_ns = 0;                 // the tracker's sample it was seen from (0: none)
    bool Complete(int tiles_per_eye) const {
      for (const Eye& e : eyes)
        if (int(e.tiles.size()) < tiles_per_eye) return false;
      return true;
    }
    size_t TilesIn() const {
      size_t n = 0;
      for (const Eye& e : eyes) n += e.tiles.size();
      return n;
    }
  };
  // The pose (in `poses`, keyed by its first eye's pose_seq) that pose_seq
  // names, and which of its eyes; poses.end() if none.
  static std::map<uint64_t, InFlight>::iterator FindPose(std::map<uint64_t, InFlight>& poses, uint64_t pose_seq,
                                                         size_t* eye);
  // A frameset's virtual objects as drawn (the boxes' triangles, the meshes'
  // and models' parts: draws points into boxes, meshes_ and model_parts_,
  // unchanged until drawn), counted into the statistics once.
  struct FrameObjects {
    FrameObjects() = default;
    FrameObjects(const FrameObjects&) = delete;  // draws points into boxes: moved, never copied
    FrameObjects(FrameObjects&&) = default;
    std::vector<VirtualSphere> spheres;
    std::vector<VirtualMeshDraw> boxes;
    MeshDraws draws;
    uint64_t spheres_colliding = 0;
    size_t meshes_drawn = 0;
  };
  FrameObjects GatherObjects(uint64_t frame_seq);
  // One eye composited and lit (shadow: the light's map, or null): its tiles
  // pasted, the objects drawn. Reads the controller and changes nothing, so
  // the eyes of a stereo frame run at once.
  struct EyeImage {
    cv::Mat frame, hull_depth;
    double hull_fraction = 0, composite_ms = 0, light_ms = 0;
  };
  EyeImage CompositeEye(const InFlight::Eye& eye, const FrameObjects& objects, const ShadowMap* shadow) const;
  void IssuePoses();
  void Composite(uint64_t pose_seq, InFlight& f);
  // Appends the models' parts as of frame_seq to *draws (amber when near, red
  // when colliding), and counts them into the models' statistics.
  void DrawModels(uint64_t frame_seq, MeshDraws* draws);

  struct ModelPartDraw {
    ModelPartSample part;
    VirtualMeshDraw world;               // vertices moved by `pose`
    Eigen::Vector3d position = Eigen::Vector3d::Constant(std::nan(""));
    Eigen::Vector4d orientation = Eigen::Vector4d::Zero();
  };

  RenderOptions o_;
  const Clock& clock_;
  RejectLog reject_log_;  // the rejected samples' warning lines, bounded
  FramesetAssembler& assembler_;
  RenderSink& sink_;
  NodeCounters counters_;
  PeerLiveness recon_liveness_;
  RunFilter runs_;
  OrbitPath orbit_;
  bool floor_known_ = true;    // false until the first hull places a floor under it
  bool floor_checked_ = false;  // the first hull's box compared with the floor
  Aabb first_hull_box_;         // that box (world metres), for stats.json's "world"
  bool centre_known_ = false;
  CompositeOptions comp_;
  std::optional<Rigid3d> tracked_;
  std::optional<EyeViewsSample> eye_views_;
  int64_t tracked_stamp_ns_ = 0;
  std::map<uint64_t, InFlight> in_flight_;  // by pose_seq
  std::map<uint32_t, std::map<uint64_t, VirtualObjectSample>> states_;  // object -> frame -> state
  // The simulation's newest frameset (any state, mesh or model state), and
  // whether one is publishing at all (else nothing is waited for).
  uint64_t sim_seq_ = 0;
  bool sim_seen_ = false;
  void SimStepped(uint64_t frame_seq) {
    sim_seen_ = true;
    sim_seq_ = std::max(sim_seq_, frame_seq);
  }
  std::map<uint32_t, std::map<uint64_t, VirtualMeshSample>> meshes_;    // object -> frame -> mesh
  std::map<uint32_t, ModelPartDraw> model_parts_;                        // object id -> part
  std::map<uint32_t, std::map<uint64_t, ModelStateSample>> model_states_; // model -> frame -> state
  RunReport report_;  // what stats.json and the table tell
  uint64_t seen_restarts_ = 0, malformed_input_ = 0;
  uint64_t pose_seq_ = 0, last_requested_ = 0, last_composited_ = 0, rejected_ = 0, tiles_late_ = 0;
  double tile_timeout_ = 1.0;                // in force (see RenderOptions::tile_timeout)
  // Poses given up on (at most kMaxGivenUp, newest kept): their tiles may still
  // come, and a pose whose tiles all come is composited then if it is newer than
  // the last composited (a rig whose first frameset takes seconds loses nothing).
  std::map<uint64_t, InFlight> given_up_;
  static constexpr size_t kMaxGivenUp = 4;
  uint64_t late_composited_ = 0;
  double first_source_time_ = 0;
  double last_new_frame_s_ = 0;
  bool any_frame_ = false, done_ = false, capture_done_ = false;
  StopFlag stop_ = nullptr;
  double capture_done_s_ = 0;
  std::map<std::string, bool> capture_final_;  ///< Capture node name -> it sent its final report.
};

}  // namespace hullpipe::nodes
