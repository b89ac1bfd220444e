#include "hullpipe/reconstruction/volume_query.h"
#include "hullpipe/reconstruction/empty_space.h"
#include "hullpipe/geometry/conventions.h"
#include "hullpipe/util/parallel.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <unordered_map>
#include <mutex>
#include <optional>
#include <queue>
#include <set>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace hullpipe {

void VolumeQueryOptions::Check() const {
  if (min_seen < 1) throw std::invalid_argument("VolumeQueryOptions.min_seen must be >= 1");
  if (threads < 1 || threads > 256) throw std::invalid_argument("VolumeQueryOptions.threads must be in [1, 256]");
  if (empty_space_cells < 0 || empty_space_cells > EmptySpace::kMaxCellsPerAxis)
    throw std::invalid_argument("VolumeQueryOptions.empty_space_cells must be in [0, " +
                                std::to_string(EmptySpace::kMaxCellsPerAxis) + "]");
}

namespace {

// Does the camera see the whole box (every corner in front, inside the image and
// the valid radius)? Exact for a pinhole camera, whose view is a convex pyramid.
bool SeesWholeBox(const Camera& c, const Aabb& box) {
  if (box.empty()) return true;
  for (const auto& X : box.Corners()) {
    const auto uv = c.Project(X);
    if (!uv || !c.InImage(*uv)) return false;
  }
  return true;
}

// kUnknown's hull box. An inside point X is seen by a set T of at least m cameras
// and lies in each of their silhouette pyramids. For every m-subset S: take the
// box of the pyramids of S; a camera that sees all of that box sees X too, so it
// is in T and its pyramid is added; repeat until none is added. X lies in that
// final box for some S ⊆ T, so the union of the final boxes is conservative.
// Cameras that see the whole workspace join every S (they always vote).
// The subsets are C(n, m) (190 pairs at 20 cameras, each grown at O(n) clips):
// past kMaxSubsets the start is instead the union over the cameras of each
// one's pyramid in the workspace (an inside point lies in the pyramid of every
// camera that sees it), linear in n and looser, which the search then tightens.
constexpr int kMaxSubsets = 16;
Aabb UnknownPolicyHullBox(const std::vector<Camera>& cams, const std::vector<cv::Rect>& rects, const Aabb& workspace,
                          int m) {
  const size_t n = cams.size();
  Aabb out;
  // Each camera's pyramid once: its rectangle's border undistorted once, not
  // once per subset.
  std::vector<ObjectPyramid> pyramids;
  for (size_t i = 0; i < n; ++i) pyramids.push_back(MakeObjectPyramid(cams[i], rects[i]));
  double subsets_needed = 1;  // C(n, m), in floating point (no overflow)
  for (int k = 0; k < m; ++k) subsets_needed = subsets_needed * double(int(n) - k) / double(k + 1);
  if (subsets_needed > kMaxSubsets) {
    for (const ObjectPyramid& p : pyramids) {
      const Aabb box = PyramidsBox({&p}, workspace);
      if (!box.empty()) out.Extend(box.min), out.Extend(box.max);
    }
    return out;
  }
  std::vector<int> pick(n, 0);
  std::fill(pick.end() - m, pick.end(), 1);  // the first combination in next_permutation order
  // Camera sets already grown from: the growth from a set is the same whatever
  // subset it started from, so each is followed once (many subsets grow into the
  // same few sets).
  std::set<std::vector<char>> followed;
  do {
    std::vector<char> in(pick.begin(), pick.end());
    Aabb box;
    for (;;) {
      if (!followed.insert(in).second) {
        box = Aabb{};  // its final box is in `out` already
        break;
      }
      std::vector<const ObjectPyramid*> sp;
      for (size_t i = 0; i < n; ++i)
        if (in[i]) sp.push_back(&pyramids[i]);
      box = PyramidsBox(sp, workspace);
      if (box.empty()) break;
      bool added = false;
      for (size_t i = 0; i < n; ++i)
        if (!in[i] && SeesWholeBox(cams[i], box)) in[i] = 1, added = true;
      if (!added) break;
    }
    if (!box.empty()) {
      out.Extend(box.min);
      out.Extend(box.max);
    }
  } while (std::next_permutation(pick.begin(), pick.end()));
  return out;
}

// A distorted camera's pinhole projection and how far its lens moves a point:
// over the pinhole image of its picture (the undistorted image border's box, in
// pinhole pixels), within the distortion's valid radius, no point moves by more
// than `shift` px along either axis. Sampled on a 17x17 grid and the border
// every 8 px; the displacement field is smooth, so `shift` takes 10% and 1 px
// over the largest sample.
struct LensBound {
  double r2max;  // Camera::MaxValidRadius2: beyond it a point does not project
  double shift = 0;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;  // pinhole pixels
  /// Every border sample undistorts to a point within the valid radius whose
  /// distortion gives the sample back: the border's pinhole image bounds the
  /// picture's (ViewPyramid may use x0..y1).
  bool border_valid = true;
  explicit LensBound(const Camera& c) : r2max(c.MaxValidRadius2()) {
    auto visit = [&](double u, double v) {
      const Eigen::Vector2d xd = c.ImagePlaneFromPixel({u, v});
      const Eigen::Vector2d xn = c.Undistort(xd);
      if (!(xn.squaredNorm() <= r2max) || !((c.Distort(xn) - xd).norm() < 1e-9)) border_valid = false;
      const Eigen::Vector2d p = c.PixelFromImagePlane(xn);
      x0 = std::min(x0, p.x()), y0 = std::min(y0, p.y()), x1 = std::max(x1, p.x()), y1 = std::max(y1, p.y());
      shift = std::max({shift, std::abs(p.x() - u), std::abs(p.y() - v)});
    };
    for (double u = 0; u < c.width + 8; u += 8)
      visit(std::min(u, double(c.width)), 0), visit(std::min(u, double(c.width)), c.height);
    for (double v = 0; v < c.height + 8; v += 8)
      visit(0, std::min(v, double(c.height))), visit(c.width, std::min(v, double(c.height)));
    for (int i = 0; i <= 16; ++i)
      for (int j = 0; j <= 16; ++j) {
        const Eigen::Vector2d xn = c.ImagePlaneFromPixel({x0 + (x1 - x0) * i / 16, y0 + (y1 - y0) * j / 16});
        if (xn.squaredNorm() > r2max) continue;
        const Eigen::Vector2d d = c.PixelFromImagePlane(c.Distort(xn)) - c.PixelFromImagePlane(xn);
        shift = std::max({shift, std::abs(d.x()), std::abs(d.y())});
      }
    shift = 1.1 * shift + 1.0;
  }
};

// The rays a camera can see at all, as planes through its centre (camera
// frame): a point X_cam with n . X_cam > 0 for some plane n is out of its view.
// The sides of the pyramid over its picture (for a distorted camera, the box of
// its undistorted border in pinhole pixels, LensBound, grown by a pixel for the
// border's sampling), the square around the distortion's valid radius, and the
// image plane (z > 0). A box all of whose corners lie beyond one plane is seen
// by none of the camera's pixels: convexity.
struct ViewPyramid {
  std::vector<Eigen::Vector3d> planes;
  ViewPyramid(const Camera& c, const LensBound* lens) {
    double x0 = 0, y0 = 0, x1 = c.width, y1 = c.height;
    if (lens) x0 = lens->x0 - 1, y0 = lens->y0 - 1, x1 = lens->x1 + 1, y1 = lens->y1 + 1;
    const bool sides = !lens || lens->border_valid;
    // Corners in the normalised image plane, in order around the (convex)
    // quadrilateral: the skew makes it a parallelogram.
    const Eigen::Vector2d q[4] = {c.ImagePlaneFromPixel({x0, y0}), c.ImagePlaneFromPixel({x1, y0}),
                                  c.ImagePlaneFromPixel({x1, y1}), c.ImagePlaneFromPixel({x0, y1})};
    const Eigen::Vector2d mid = 0.25 * (q[0] + q[1] + q[2] + q[3]);
    const Eigen::Vector3d inner(mid.x(), mid.y(), 1.0);
    for (int k = 0; k < 4 && sides; ++k) {
      const Eigen::Vector3d a(q[k].x(), q[k].y(), 1.0), b(q[(k + 1) % 4].x(), q[(k + 1) % 4].y(), 1.0);
      Eigen::Vector3d n = a.cross(b);
      if (n.dot(inner) > 0) n = -n;  // pointing out of the pyramid
      planes.push_back(n);
    }
    const double r2 = c.MaxValidRadius2();
    if (r2 < 1e30) {
      const double r = std::sqrt(r2);
      planes.push_back({1, 0, -r}), planes.push_back({-1, 0, -r});
      planes.push_back({0, 1, -r}), planes.push_back({0, -1, -r});
    }
    planes.push_back({0, 0, -1});  // behind the camera: z <= 0
  }
  /// True if no point of the box with these corners (camera frame) is in view.
  bool Misses(const std::array<Eigen::Vector3d, 8>& corners_cam) const {
    for (const Eigen::Vector3d& n : planes) {
      bool all_out = true;
      for (const auto& X : corners_cam)
        if (!(n.dot(X) > 0)) {
          all_out = false;
          break;
        }
      if (all_out) return true;
    }
    return false;
  }
};

// What the cell rule needs of a camera alone (its lens bound and view
// pyramid): the same for every frameset of a rig, so made once per camera and
// kept (at most kMaxKept cameras, all dropped when more come: a process sees
// one rig or a few).
struct CameraBounds {
  std::optional<LensBound> lens;
  std::optional<ViewPyramid> pyramid;
};

std::shared_ptr<const CameraBounds> BoundsOf(const Camera& c) {
  constexpr size_t kMaxKept = 256;
  // The key: every parameter the bounds depend on, as raw bytes.
  std::string key;
  auto add = [&](const auto& v) { key.append(reinterpret_cast<const char*>(&v), sizeof v); };
  add(c.width), add(c.height), add(c.fx), add(c.fy), add(c.cx), add(c.cy), add(c.skew);
  for (const double d : c.distortion) add(d);
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const CameraBounds>> kept;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    const auto it = kept.find(key);
    if (it != kept.end()) return it->second;
  }
  auto b = std::make_shared<CameraBounds>();
  if (c.HasDistortion()) b->lens.emplace(c);
  b->pyramid.emplace(c, b->lens ? &*b->lens : nullptr);
  const std::lock_guard<std::mutex> lock(mutex);
  if (kept.size() >= kMaxKept) kept.clear();
  kept.emplace(key, b);
  return b;
}

}  // namespace

namespace detail {

// The cell rule of the hull box search (TightenHullBox's comment), kept for
// VolumeQuery::ProvesEmpty.
class CellProver {
 public:
  // threads: the cameras' integral images made on this many at once.
  CellProver(const std::vector<CameraMap>& views, std::vector<cv::Rect> rects, bool outside_vetoes,
             int required_seen, int threads)
      : views_(views), rects_(std::move(rects)), outside_vetoes_(outside_vetoes), required_seen_(required_seen) {
    const size_t n = views.size();
    // Integral images of each map within its object pixels' bounding rectangle
    // (none outside it): 0 under a rectangle iff it holds no object pixel.
    sums_.resize(n);
    bounds_.resize(n);
    for (size_t i = 0; i < n; ++i) bounds_[i] = BoundsOf(views[i].camera);
    ForEachRowDynamic(int(n), threads, [&](int row, int) {
      const size_t i = size_t(row);
      if (rects_[i].area() > 0) cv::integral(views[i].map(rects_[i]), sums_[i], CV_32S);
    });
  }
  // True if no hull point lies in `cell`. *hint: the camera tried first, set to
  // the one that proved it (neighbouring cells share it).
  bool Empty(const Aabb& cell, size_t* hint) const;
  // What a searched cell's cameras said, as far as its search needed them
  // (bit i: camera i; rigs of at most 64 cameras).
  struct CellCameras {
    uint64_t may = 0;   // may put a point of the cell on an object pixel
    uint64_t part = 0;  // see part of it, on background wherever they do
  };
  // Empty(cell) for a cell inside `parent`, a cell found not empty, asking
  // only the cameras that can still decide: a camera that misses the parent
  // misses the cell, and one on background wherever it sees the parent is on
  // background wherever it sees the cell (its projection lies within the
  // parent's). So the cameras that may see the cell are among the parent's
  // `may`, and only those and the parent's `part` (which may see all of the
  // cell on background) can prove it empty. Proves every cell Empty() proves,
  // and others whose own corner rectangle is looser than the parent's. When
  // false, *own holds the cell's cameras for its halves.
  bool EmptyWithin(const Aabb& cell, const CellCameras& parent, size_t* hint, CellCameras* own) const;
  size_t size() const { return views_.size(); }
  // True if camera i's map has no object pixel in [x0, x1) x [y0, y1) (within
  // the image), from the summed-area table of its object rectangle.
  bool NoObjectPixel(size_t i, int x0, int y0, int x1, int y1) const {
    const cv::Rect& o = rects_[i];
    const int a0 = std::clamp(x0 - o.x, 0, o.width), a1 = std::clamp(x1 - o.x, 0, o.width);
    const int b0 = std::clamp(y0 - o.y, 0, o.height), b1 = std::clamp(y1 - o.y, 0, o.height);
    if (a0 >= a1 || b0 >= b1) return true;
    const cv::Mat& s = sums_[i];
    return s.at<int>(b1, a1) - s.at<int>(b0, a1) - s.at<int>(b1, a0) + s.at<int>(b0, a0) == 0;
  }
  // How many cameras, up to `need`, see all of `cell` (grown by a pixel) and
  // put it on background (VolumeQuery::CountWholeBackground).
  int WholeBackground(const Aabb& cell, int need, size_t* hint) const;
  // The same for the cell with vertices o + t d at t0 and t1 for each
  // camera's (o, d_0..d_3) = in_camera[i].
  int WholeBackground(const std::vector<std::array<Eigen::Vector3d, 5>>& in_camera, double t0, double t1, int need,
                      size_t* hint) const;

 private:
  // What camera i says of every point of `cell`, its projection's rectangle
  // grown by margin_px (> 0 also keeps the corners a millimetre in front and
  // within the lens's radius by a relative 1e-4).
  enum class Verdict {
    kBackground,      // sees all of it and has no object pixel under it
    kPartBackground,  // sees part of it, on background wherever it does
    kMisses,          // sees none of it
    kMaySee,          // may put a point of it on an object pixel
  };
  Verdict Classify(const Aabb& cell, size_t i, double margin_px) const;
  // Classify for any convex cell with these 8 vertices (camera i's frame).
  Verdict ClassifyCorners(const std::array<Eigen::Vector3d, 8>& pc, size_t i, double margin_px) const;

  std::vector<CameraMap> views_;  // shares the maps
  std::vector<cv::Rect> rects_;
  bool outside_vetoes_;
  int required_seen_;
  std::vector<cv::Mat> sums_;
  std::vector<std::shared_ptr<const CameraBounds>> bounds_;  // per camera, shared across framesets
};

// The j-th camera to ask when `hint` goes first, then the others in order.
static size_t HintFirst(size_t j, size_t hint) { return j == 0 ? hint : (j <= hint ? j - 1 : j); }

CellProver::Verdict CellProver::Classify(const Aabb& cell, size_t i, double margin_px) const {
  const Eigen::Vector3d size = cell.max - cell.min;
  // The corners in the camera's frame (its rotation applied to the cell's
  // edges once, not to each corner).
  const Eigen::Matrix3d& R = views_[i].camera.cam_from_world.rotation;
  const Eigen::Vector3d base = R * cell.min + views_[i].camera.cam_from_world.translation;
  const Eigen::Vector3d ex = R.col(0) * size.x(), ey = R.col(1) * size.y(), ez = R.col(2) * size.z();
  std::array<Eigen::Vector3d, 8> pc;
  for (int k = 0; k < 8; ++k)
    pc[size_t(k)] = base + (k & 1 ? ex : Eigen::Vector3d::Zero()) + (k & 2 ? ey : Eigen::Vector3d::Zero()) +
                    (k & 4 ? ez : Eigen::Vector3d::Zero());
  return ClassifyCorners(pc, i, margin_px);
}

CellProver::Verdict CellProver::ClassifyCorners(const std::array<Eigen::Vector3d, 8>& pc, size_t i,
                                                double margin_px) const {
  // A pixel rectangle [u0, u1] x [v0, v1].
  struct Rect {
    double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
    double span() const { return std::max(u1 - u0, v1 - v0); }
    void Extend(const Eigen::Vector2d& uv) {
      u0 = std::min(u0, uv.x()), v0 = std::min(v0, uv.y());
      u1 = std::max(u1, uv.x()), v1 = std::max(v1, uv.y());
    }
  };
  const bool strict = margin_px > 0;
  const Camera& cam = views_[i].camera;
  // The corners' normalised image points as Camera::Project finds them: none
  // where a corner is not in front or lies beyond the lens model's valid
  // radius. In front, the cell's image in the normalised plane is the convex
  // hull of its corners' (perspective keeps convexity), so corners within the
  // valid disk (convex) put all of it there. Strict (a margin): in front by a
  // millimetre and within the radius by a relative 1e-4, so that float
  // arithmetic (VoteFast) agrees for every point.
  const double r2max = cam.MaxValidRadius2() * (strict ? 1 - 1e-4 : 1.0);
  const double zmin = strict ? 1e-3 : 1e-9;
  std::array<Eigen::Vector2d, 8> xn;
  bool projects = true;
  for (size_t k = 0; k < 8 && projects; ++k) {
    projects = pc[k].z() > zmin;
    if (projects) xn[k] = pc[k].head<2>() / pc[k].z();
    projects = projects && !(xn[k].squaredNorm() > r2max);
  }
  // A conservative rectangle of the cell's projection, or none: the camera
  // may see some of the cell and vetoes none of it.
  Rect r;
  bool bounded = false;
  if (projects && !bounds_[i]->lens) {
    for (const auto& x : xn) r.Extend(cam.PixelFromImagePlane(x));
    bounded = true;
  } else if (projects) {
    const LensBound& lens = *bounds_[i]->lens;
    Rect p;
    for (const auto& x : xn) p.Extend(cam.PixelFromImagePlane(x));
    if (p.u0 >= lens.x0 && p.v0 >= lens.y0 && p.u1 <= lens.x1 && p.v1 <= lens.y1) {
      r = {p.u0 - lens.shift, p.v0 - lens.shift, p.u1 + lens.shift, p.v1 + lens.shift};
      bounded = true;
    }
    if (!bounded || p.span() <= kMaxBulgeSpanPx) {
      Rect d;
      for (const auto& x : xn) d.Extend(cam.PixelFromImagePlane(cam.Distort(x)));
      if (d.span() <= kMaxBulgeSpanPx) {
        const double m = LensBulgePx(d.span());
        const Rect g{d.u0 - m, d.v0 - m, d.u1 + m, d.v1 + m};
        r = bounded ? Rect{std::max(r.u0, g.u0), std::max(r.v0, g.v0), std::min(r.u1, g.u1), std::min(r.v1, g.v1)}
                    : g;
        bounded = true;
      }
    }
  }
  if (!bounded) {
    // Corners behind the camera or beyond its lens model: the cell may still
    // lie wholly outside its view (a corner of the workspace below a dome).
    return !strict && bounds_[i]->pyramid->Misses(pc) ? Verdict::kMisses : Verdict::kMaySee;
  }
  r = {r.u0 - margin_px, r.v0 - margin_px, r.u1 + margin_px, r.v1 + margin_px};
  // Clamped in floating point first (FloorPixel): a corner far outside a
  // distorted view can project to ~1e11 px, past int.
  const int x0 = FloorPixel(r.u0), y0 = FloorPixel(r.v0);
  const int x1 = FloorPixel(r.u1) + 1, y1 = FloorPixel(r.v1) + 1;
  if (x1 <= 0 || y1 <= 0 || x0 >= cam.width || y0 >= cam.height) return Verdict::kMisses;
  // Object pixels under [x0, x1) x [y0, y1) within the image, counted within
  // the object rectangle.
  if (NoObjectPixel(i, x0, y0, x1, y1)) {
    const bool whole = x0 >= 0 && y0 >= 0 && x1 <= cam.width && y1 <= cam.height;
    return whole ? Verdict::kBackground : Verdict::kPartBackground;
  }
  return Verdict::kMaySee;
}

bool CellProver::Empty(const Aabb& cell, size_t* hint_io) const {
  const size_t n = views_.size();
  size_t& hint = *hint_io;
  if (hint >= n) hint = 0;
  int seeing = 0;
  for (size_t j = 0; j < n; ++j) {
    const size_t i = HintFirst(j, hint);
    switch (Classify(cell, i, 0)) {
      // Background wherever it sees the cell. Seeing all of it, or vetoing
      // what it cannot see (kOutside): no point is inside. Seeing part of it
      // (kUnknown): no inside point is one it sees, so it does not count
      // towards the cameras that may see one.
      case Verdict::kBackground: return hint = i, true;
      case Verdict::kMisses:
      case Verdict::kPartBackground:
        if (outside_vetoes_) return hint = i, true;
        break;
      case Verdict::kMaySee: ++seeing; break;
    }
  }
  return seeing < required_seen_;
}

bool CellProver::EmptyWithin(const Aabb& cell, const CellCameras& parent, size_t* hint_io, CellCameras* own) const {
  const size_t n = views_.size();
  size_t& hint = *hint_io;
  *own = {};
  int left = std::popcount(parent.may), seeing = 0;
  // Asks camera i; true when its verdict proves the cell empty.
  auto proves = [&](size_t i) {
    --left;
    switch (Classify(cell, i, 0)) {
      case Verdict::kBackground: return hint = i, true;
      case Verdict::kMisses:
        if (outside_vetoes_) return hint = i, true;
        break;
      case Verdict::kPartBackground:
        if (outside_vetoes_) return hint = i, true;
        own->part |= uint64_t{1} << i;
        break;
      case Verdict::kMaySee:
        ++seeing;
        own->may |= uint64_t{1} << i;
        break;
    }
    return false;
  };
  uint64_t ask = parent.may;
  if (hint < n && (ask >> hint & 1)) {
    ask &= ~(uint64_t{1} << hint);
    if (proves(hint)) return true;
  }
  for (; ask; ask &= ask - 1) {
    // Too few cameras left that may see a point of it: empty whatever they say.
    if (seeing + left < required_seen_) return true;
    if (proves(size_t(std::countr_zero(ask)))) return true;
  }
  if (seeing < required_seen_) return true;
  for (uint64_t rest = parent.part; rest; rest &= rest - 1) {
    const size_t i = size_t(std::countr_zero(rest));
    const Verdict v = Classify(cell, i, 0);
    if (v == Verdict::kBackground) return hint = i, true;
    // Its own rectangle may reach object pixels the parent's did not: still
    // on background wherever it sees the cell (the parent's bound holds).
    if (v != Verdict::kMisses) own->part |= uint64_t{1} << i;
  }
  return false;
}

// How many of n cameras, up to `need`, background(i) is true for, *hint_io
// asked first and set to the first counted.
template <class Background>
static int CountBackground(size_t n, int need, size_t* hint_io, Background background) {
  size_t& hint = *hint_io;
  if (hint >= n) hint = 0;
  int found = 0;
  for (size_t j = 0; j < n && found < need; ++j) {
    const size_t i = HintFirst(j, hint);
    if (background(i) && found++ == 0) hint = i;
  }
  return found;
}

int CellProver::WholeBackground(const Aabb& cell, int need, size_t* hint_io) const {
  return CountBackground(views_.size(), need, hint_io,
                         [&](size_t i) { return Classify(cell, i, 1.0) == Verdict::kBackground; });
}

int CellProver::WholeBackground(const std::vector<std::array<Eigen::Vector3d, 5>>& in_camera, double t0,
                                double t1, int need, size_t* hint_io) const {
  std::array<Eigen::Vector3d, 8> pc;
  return CountBackground(views_.size(), need, hint_io, [&](size_t i) {
    const auto& r = in_camera[i];
    for (size_t k = 0; k < 4; ++k) {
      pc[k] = r[0] + t0 * r[k + 1];
      pc[k + 4] = r[0] + t1 * r[k + 1];
    }
    return ClassifyCorners(pc, i, 1.0) == Verdict::kBackground;
  });
}

struct LazyEmptySpace {
  std::once_flag once;
  EmptySpace grid;
};

}  // namespace detail

namespace {

// Tightens a conservative hull box to within a small cell of the hull's own box
// (docs/rigs.md: on a ring of cameras the kUnknown pyramid boxes are metres
// wide, as two opposite cameras' pyramids meet along the line between them). A
// cell of the box is proven empty, holding no hull point, when
//   - a camera that sees all of it has no object pixel under its projection
//     (the integral image of its map): that camera votes background throughout;
//   - kOutside: a camera sees none of it (its projection lies off the image);
//   - kUnknown: fewer than required_seen cameras may see any of it.
// The projection is bounded by the cell's 8 corners: exact for a pinhole camera
// when all are in front, the cell being convex. A distorted camera bounds it two
// ways, and takes the intersection:
//   - its pinhole corner rectangle grown by the most the lens moves a point
//     (LensBound), where that rectangle lies in the pinhole image of the
//     picture and every corner within the valid radius;
//   - for cells whose distorted corners span at most 32 px, their rectangle
//     grown by 0.5 + span^2 / 400 px: the cell's edges' images bend out of it by
//     about c * span^2, measured c <= 7.5e-4 for k1 from -0.5 to 0.3 and the
//     Utrecht lenses (2.7 px at 64 px, 0.76 px at 32, 0.19 px at 16): the margin
//     is three times the largest bend measured.
// For each face of the box a best-first search pops the cell that reaches
// farthest out through that face: an empty cell is dropped; a cell no larger
// than a leaf (the box's largest side / 64, within [5 mm, 2 cm]) ends the search,
// its far side bounding the hull there. Every hull point lies in a cell not yet
// dropped, so the result stays conservative. Cells are classified once for all
// six searches. An empty hull gives an empty box.
// One face's search (TightenHullBox): how far the hull reaches through face
// `face` (axis face / 2; even faces the min side, as -axis), or nullopt when
// every cell is proven empty. `known` caches cells' verdicts: cells are made by
// halving, so one cell has the same bits whichever search made it.
// Shared by the six searches, also when they run at once: then in shards by
// the cell's hash, each under its own mutex, so that searches on several cores
// rarely wait for each other (a verdict costs about half a microsecond on a
// 4-camera rig: under one mutex, six searches took longer than one). Two
// searches may classify one cell at the same time, to the same verdict.
struct CellCache {
  using Key = std::array<double, 6>;
  struct Hash {
    size_t operator()(const Key& k) const {
      uint64_t h = 1469598103934665603ull;
      for (const double d : k) {
        const double z = d + 0.0;  // -0.0 == 0.0: one hash for both
        uint64_t b;
        std::memcpy(&b, &z, sizeof b);
        h = (h ^ b) * 1099511628211ull;
        h ^= h >> 29;
      }
      return size_t(h);
    }
  };
  struct Verdict {
    bool empty;
    detail::CellProver::CellCameras cameras;  // when not empty: for its halves
  };
  struct Shard {
    std::unordered_map<Key, Verdict, Hash> verdicts;
    std::mutex mutex;
  };
  static constexpr size_t kShards = 64;
  explicit CellCache(bool at_once) : concurrent(at_once) {}
  std::optional<Verdict> Find(const Key& k) {
    Shard& s = shards[Hash{}(k) % kShards];
    std::unique_lock<std::mutex> lock(s.mutex, std::defer_lock);
    if (concurrent) lock.lock();
    const auto it = s.verdicts.find(k);
    if (it == s.verdicts.end()) return std::nullopt;
    return it->second;
  }
  void Put(const Key& k, const Verdict& v) {
    Shard& s = shards[Hash{}(k) % kShards];
    std::unique_lock<std::mutex> lock(s.mutex, std::defer_lock);
    if (concurrent) lock.lock();
    s.verdicts.emplace(k, v);
  }
  const bool concurrent;  // searches run at once: lock the shards
  std::array<Shard, kShards> shards;
};
std::optional<double> FaceReach(const detail::CellProver& prover, const Aabb& box, double leaf, int face,
                                CellCache& known, size_t& hint) {
  using Cameras = detail::CellProver::CellCameras;
  // Up to 64 cameras, a cell asks only the cameras its parent left undecided
  // (CellProver::EmptyWithin); the box, where the search starts, asks all.
  const bool within = prover.size() <= 64;
  const Cameras all{prover.size() >= 64 ? ~uint64_t{0} : (uint64_t{1} << prover.size()) - 1, 0};
  auto empty = [&](const Aabb& c, const Cameras& parent, Cameras* own) {
    const CellCache::Key key{c.min.x(), c.min.y(), c.min.z(), c.max.x(), c.max.y(), c.max.z()};
    if (const std::optional<CellCache::Verdict> v = known.Find(key)) return *own = v->cameras, v->empty;
    const bool e = within ? prover.EmptyWithin(c, parent, &hint, own) : prover.Empty(c, &hint);
    known.Put(key, {e, *own});
    return e;
  };
  struct Item {
    double reach;
    Aabb cell;
    Cameras parent;  // what the cell's parent's cameras said
    bool operator<(const Item& o) const { return reach < o.reach; }
  };
  const int axis = face / 2;
  const double sign = face % 2 ? 1.0 : -1.0;
  auto reach = [&](const Aabb& c) { return sign > 0 ? c.max[axis] : -c.min[axis]; };
  std::vector<Item> storage;
  storage.reserve(1024);
  std::priority_queue<Item> queue(std::less<Item>(), std::move(storage));
  queue.push({reach(box), box, all});
  for (int pops = 0; !queue.empty(); ++pops) {
    // A pathological rig: stop where the search stands (still conservative).
    if (pops > 20000) return queue.top().reach;
    const Item it = queue.top();
    queue.pop();
    Cameras own;
    if (empty(it.cell, it.parent, &own)) continue;
    const Eigen::Vector3d size = it.cell.max - it.cell.min;
    if (size.maxCoeff() <= leaf) return it.reach;
    // Split in two along every axis longer than half the cell's largest side
    // (at most 8 parts, kept on the stack: a search pops thousands of cells).
    const Eigen::Vector3d c = it.cell.Center();
    const double half = 0.5 * size.maxCoeff();
    std::array<Aabb, 8> parts;
    parts[0] = it.cell;
    size_t n_parts = 1;
    for (int a = 0; a < 3; ++a) {
      if (size[a] < half) continue;
      for (size_t i = n_parts; i-- > 0;) {  // part i becomes parts 2i (low) and 2i + 1 (high)
        parts[2 * i] = parts[2 * i + 1] = parts[i];
        parts[2 * i].max[a] = parts[2 * i + 1].min[a] = c[a];
      }
      n_parts *= 2;
    }
    for (size_t i = 0; i < n_parts; ++i) queue.push({reach(parts[i]), parts[i], own});
  }
  return std::nullopt;  // every cell proven empty: no hull
}

// With threads > 1 the six faces are searched at once, sharing one cache (the
// searches meet near the hull's edges and start from the same large cells: with
// a cache each, the six searches classified those again, and on a real
// 20-camera dome six threads took as long as one); the verdicts, and so the
// box, are the same.
Aabb TightenHullBox(const detail::CellProver& prover, const Aabb& box, int threads) {
  if (box.empty()) return box;
  const double leaf = std::clamp((box.max - box.min).maxCoeff() / 64, 5e-3, 0.02);
  std::array<std::optional<double>, 6> reach;
  CellCache known(threads > 1);
  if (threads <= 1) {
    size_t hint = 0;
    for (int face = 0; face < 6; ++face) reach[size_t(face)] = FaceReach(prover, box, leaf, face, known, hint);
  } else {
    ForEachRowDynamic(6, threads, [&](int face, int) {
      size_t hint = 0;
      reach[size_t(face)] = FaceReach(prover, box, leaf, face, known, hint);
    });
  }
  Aabb out;
  for (int face = 0; face < 6; ++face) {
    if (!reach[size_t(face)]) return Aabb{};
    if (face % 2) out.max[face / 2] = *reach[size_t(face)];
    else out.min[face / 2] = -*reach[size_t(face)];
  }
  return out;
}

}  // namespace

VolumeQuery::VolumeQuery(std::vector<CameraMap> views, const Aabb& workspace, const VolumeQueryOptions& options)
    : views_(std::move(views)), workspace_(workspace), options_(options) {
  if (views_.empty()) throw std::invalid_argument("VolumeQuery: no cameras");
  options_.Check();
  const int n = int(views_.size());
  required_seen_ = options_.out_of_view == OutOfView::kOutside ? n : std::min(options_.min_seen, n);
  std::vector<Camera> cams;
  std::vector<cv::Rect>& rects = rects_;  // each map's object pixels' bounding rectangle, found once
  for (const auto& v : views_) {
    const Camera& c = v.camera;
    if (v.map.type() != CV_8UC1 || v.map.cols != c.width || v.map.rows != c.height)
      throw std::invalid_argument("VolumeQuery: map of camera " + std::to_string(c.id) +
                                  " must be CV_8UC1 " + std::to_string(c.width) + "x" +
                                  std::to_string(c.height));
    detail::FastCamera f{};
    for (int i = 0; i < 9; ++i) f.r[i] = float(c.cam_from_world.rotation(i / 3, i % 3));
    for (int i = 0; i < 3; ++i) f.t[i] = float(c.cam_from_world.translation[i]);
    f.fx = float(c.fx), f.fy = float(c.fy), f.cx = float(c.cx), f.cy = float(c.cy), f.skew = float(c.skew);
    f.k1 = float(c.distortion[0]), f.k2 = float(c.distortion[1]);
    f.p1 = float(c.distortion[2]), f.p2 = float(c.distortion[3]), f.k3 = float(c.distortion[4]);
    f.distorted = c.HasDistortion();
    const double r2 = c.MaxValidRadius2();
    f.r2max = r2 > 1e30 ? std::numeric_limits<float>::max() : float(r2);
    f.width = c.width, f.height = c.height;
    f.width_f = float(c.width), f.height_f = float(c.height);
    f.data = v.map.ptr<uint8_t>(0);
    f.step = v.map.step[0];
    fast_.push_back(f);
    cams.push_back(c);
    rects.push_back(v.object_rect ? *v.object_rect & cv::Rect(0, 0, c.width, c.height) : cv::boundingRect(v.map));
  }
  const bool outside = options_.out_of_view == OutOfView::kOutside;
  hull_box_ = outside ? HullBoundingBox(cams, rects, workspace_)
                      : UnknownPolicyHullBox(cams, rects, workspace_, required_seen_);
  prover_ = std::make_shared<const detail::CellProver>(views_, rects, outside, required_seen_, options_.threads);
  hull_box_ = TightenHullBox(*prover_, hull_box_, options_.threads);
  empty_space_ = std::make_shared<detail::LazyEmptySpace>();
}

bool VolumeQuery::NoObjectPixelIn(size_t i, int x0, int y0, int x1, int y1) const {
  return prover_->NoObjectPixel(i, x0, y0, x1, y1);
}

bool VolumeQuery::SegmentOnBackground(size_t i, const Eigen::Vector3f& a_cam, const Eigen::Vector3f& b_cam) const {
  const detail::FastCamera& cam = fast_.at(i);
  // A distorted camera's ends a millimetre in front (a pinhole's just in
  // front), and within the lens model's valid radius by a relative 1e-4.
  const float z_min = cam.distorted ? 1e-3f : 1e-6f;
  if (!(a_cam.z() > z_min && b_cam.z() > z_min)) return false;
  const float r2max = cam.r2max * (1 - 1e-4f);
  // The ends' pixels in VoteFast's float arithmetic (its samples' pixels
  // differ from them by float rounding, well within the pixel of growth).
  const auto pixel = [&](const Eigen::Vector3f& P, Eigen::Vector2f* px) {
    const float iz = 1.0f / P.z(), xn = P.x() * iz, yn = P.y() * iz;
    const float r2 = xn * xn + yn * yn;
    // Both ends within the (convex) valid disk: so is every point between.
    if (!(r2 <= r2max)) return false;
    detail::FastPixel(cam, xn, yn, r2, &px->x(), &px->y());
    return true;
  };
  Eigen::Vector2f pa, pb;
  if (!pixel(a_cam, &pa) || !pixel(b_cam, &pb)) return false;
  float grow = 1.0f;
  if (cam.distorted) {
    // The image bends from the chord between the ends by at most LensBulgePx.
    const float span = (pa - pb).cwiseAbs().maxCoeff();
    if (!(span <= float(kMaxBulgeSpanPx))) return false;
    grow += float(LensBulgePx(double(span)));
  }
  const float u0 = std::min(pa.x(), pb.x()) - grow, u1 = std::max(pa.x(), pb.x()) + grow;
  const float v0 = std::min(pa.y(), pb.y()) - grow, v1 = std::max(pa.y(), pb.y()) + grow;
  // Any part outside the image is no veto's proof.
  if (!(u0 >= 0.0f && v0 >= 0.0f && u1 < cam.width_f && v1 < cam.height_f)) return false;
  return NoObjectPixelIn(i, int(u0), int(v0), int(u1) + 1, int(v1) + 1);
}

const EmptySpace& VolumeQuery::empty_space(int threads) const {
  std::call_once(empty_space_->once, [&] {
    empty_space_->grid = EmptySpace(*this, options_.empty_space_cells, std::max(1, threads));
  });
  return empty_space_->grid;
}

Vote VolumeQuery::VoteOf(size_t i, const Eigen::Vector3d& X) const {
  const Camera& c = views_.at(i).camera;
  const auto uv = c.Project(X);
  if (!uv || !c.InImage(*uv)) return Vote::kUnseen;
  return views_[i].map.at<uint8_t>(int(uv->y()), int(uv->x())) != 0 ? Vote::kObject : Vote::kBackground;
}

int VolumeQuery::Count(const Eigen::Vector3d& X) const {
  int count = 0;
  for (size_t i = 0; i < views_.size(); ++i) {
    const Camera& c = views_[i].camera;
    const auto uv = c.Project(X);
    if (!uv || !c.InImage(*uv)) continue;
    if (views_[i].map.at<uint8_t>(int(uv->y()), int(uv->x())) != 0) ++count;
  }
  return count;
}

bool VolumeQuery::Inside(const Eigen::Vector3d& X) const {
  if (!workspace_.Contains(X)) return false;
  int object = 0, unseen = 0;
  for (size_t i = 0; i < views_.size(); ++i) {
    switch (VoteOf(i, X)) {
      case Vote::kBackground: return false;
      case Vote::kObject: ++object; break;
      case Vote::kUnseen: ++unseen; break;
    }
  }
  return Accepts(object, unseen);
}

bool VolumeQuery::ProvesEmpty(const Aabb& box, size_t* hint) const {
  if (box.empty() || !box.Intersects(hull_box_) || !box.Intersects(workspace_)) return true;
  size_t local = 0;
  return prover_->Empty(box, hint ? hint : &local);
}

int VolumeQuery::CountWholeBackground(const Aabb& box, int need, size_t* hint) const {
  if (box.empty() || need <= 0) return 0;
  size_t local = 0;
  return prover_->WholeBackground(box, need, hint ? hint : &local);
}

void VolumeQuery::BundleOf(const Eigen::Vector3d& origin_world, const std::array<Eigen::Vector3d, 4>& dirs_world,
                           RayBundle* out) const {
  out->in_camera.resize(views_.size());
  for (size_t i = 0; i < views_.size(); ++i) {
    const Rigid3d& T = views_[i].camera.cam_from_world;
    auto& r = out->in_camera[i];
    r[0] = T * origin_world;
    for (size_t k = 0; k < 4; ++k) r[k + 1] = T.rotation * dirs_world[k];
  }
}

int VolumeQuery::CountWholeBackground(const RayBundle& rays, double t0, double t1, int need, size_t* hint) const {
  if (need <= 0 || rays.in_camera.size() != views_.size() || !std::isfinite(t0) || !std::isfinite(t1)) return 0;
  size_t local = 0;
  return prover_->WholeBackground(rays.in_camera, t0, t1, need, hint ? hint : &local);
}

VolumeQuery VolumeQuery::Subset(const std::vector<int>& indices) const {
  std::vector<CameraMap> sub;
  for (int i : indices) sub.push_back(views_.at(size_t(i)));
  return VolumeQuery(std::move(sub), workspace_, options_);
}

}  // namespace hullpipe
