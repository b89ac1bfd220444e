// The hull surface's normal velocity at a contact against exact ground truth:
// a sphere translating at a known velocity, filmed with exact object-pixel maps
// by cameras that do not shoot together (each its own offset, jittering frame to
// frame). For a translating body the hull's surface at a point of camera c's
// cone moves along its normal by the body's displacement along that normal
// (the cone's tangent plane turns about c's centre keeping tangent), so the
// true normal speed is v . N, N the smooth hull's normal there.
#include "hullpipe/collision/hull_motion.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hullpipe/collision/hull_surface.h"
#include "hullpipe/evaluation/synthetic.h"
#include "hullpipe/testing/fixtures.h"

namespace hullpipe {
namespace {

constexpr double kR = 0.1;  // the moving sphere's radius, metres
const Eigen::Vector3d kStart(0.0, 0.0, -1.0);

// Per-camera capture offsets: a fixed offset each and a jitter that alternates
// sign from frame to frame (seconds; within half a period at 50 fps).
constexpr double kOffset[4] = {0.0, 0.003, -0.004, 0.005};
constexpr double kJitter[4] = {0.002, -0.002, 0.0015, -0.0015};

struct MapFrame {
  std::unique_ptr<VolumeQuery> query;
  TimedHull timed;
  std::vector<double> view_time_s;
};

class MovingSphere {
 public:
  MovingSphere(Eigen::Vector3d velocity, double fps, bool skew = true)
      : v_(std::move(velocity)), fps_(fps), skew_(skew),
        cams_(RingCameras(4, 3.0, 1.6, kStart, 1024, 768, 0.9)) {}
  Eigen::Vector3d CentreAt(double t) const { return kStart + t * v_; }
  SyntheticScene SceneAt(double t) const { return {{Shape::Sphere(CentreAt(t), kR)}}; }
  double ViewTime(size_t i, int k) const {
    return k / fps_ + (skew_ ? kOffset[i] + (k % 2 ? 1 : -1) * kJitter[i] : 0.0);
  }
  // Frame k: every camera's exact map of the sphere where it was when that
  // camera shot (or of nothing, `empty`).
  MapFrame Shoot(int k, bool empty = false) const {
    MapFrame f;
    std::vector<CameraMap> views;
    std::vector<int64_t> skew_ns;
    const int64_t t_ref = int64_t(std::llround(k / fps_ * 1e9)) + 1'000'000'000;
    for (size_t i = 0; i < cams_.size(); ++i) {
      const double t = ViewTime(i, k);
      f.view_time_s.push_back(t);
      views.push_back({cams_[i], RenderExactMap(cams_[i], empty ? SyntheticScene{} : SceneAt(t))});
      skew_ns.push_back(int64_t(std::llround(t * 1e9)) + 1'000'000'000 - t_ref);
    }
    f.query = std::make_unique<VolumeQuery>(views, test::BigBox());
    f.timed = TimedHull::Of(*f.query, t_ref, skew_ns);
    return f;
  }
  const std::vector<Camera>& cameras() const { return cams_; }
  std::vector<Eigen::Vector3d> Centres() const {
    std::vector<Eigen::Vector3d> c;
    for (const auto& cam : cams_) c.push_back(cam.Center());
    return c;
  }
  const Eigen::Vector3d& velocity() const { return v_; }

 private:
  Eigen::Vector3d v_;
  double fps_;
  bool skew_;
  std::vector<Camera> cams_;
};

// The contact: where a line from `towards` (outside) to the sphere's centre at
// frame time t meets the current hull, and the hull's normal there.
struct Contact {
  Eigen::Vector3d cp, n;
};
std::optional<Contact> ContactOn(const VolumeQuery& q, const Eigen::Vector3d& centre, const Eigen::Vector3d& d) {
  const auto cp = FirstHullPointAlong(q, centre + 0.5 * d, -d, 0.5);
  if (!cp) return std::nullopt;
  const auto n = HullSurfaceNormal(q, *cp);
  if (!n) return std::nullopt;
  return Contact{*cp, n->normal};
}

// The bound on |estimate - truth| (m/s). Each frame's crossing lies where the
// forming camera's pixelated silhouette puts it: its edge is off the true
// contour by at most 0.71 px (object pixels are those whose centre ray hits;
// the staircase is off by half a pixel in u and in v), so the displacement
// between two frames is off by at most 1.42 px, at the point's depth over fx;
// over the interval that is the speed's error. Plus 5% of |v|: the hull point
// is not the tangent point of the cone (it lies up to a radius from it along
// the generator, 3 m long), which scales the displacement by up to r/D ~ 3%.
// Plus the estimate's own first-order error: a surface of curvature radius rho
// sliding along itself at v_t in the interval dt is met by the normal line
// v_t^2 dt / (2 rho) further out than v . N dt (the cone's cross-section is at
// least the sphere's radius round).
double Bound(const MovingSphere& s, const Eigen::Vector3d& cp, const Eigen::Vector3d& n, double interval_s) {
  double footprint = 0;
  for (const auto& c : s.cameras()) footprint = std::max(footprint, (cp - c.Center()).norm() / c.fx);
  const double v_t = (s.velocity() - s.velocity().dot(n) * n).norm();
  return 1.42 * footprint / interval_s + 0.05 * s.velocity().norm() + v_t * v_t * interval_s / (2 * kR);
}

struct Case {
  double speed;  // m/s
  double fps;
  bool towards;  // towards the contact direction (else across it)
};

std::string Name(const testing::TestParamInfo<Case>& i) {
  return std::to_string(int(std::lround(i.param.speed * 10))) + "dmps_" + std::to_string(int(i.param.fps)) + "fps_" +
         (i.param.towards ? "towards" : "across");
}

class HullVelocityOf : public testing::TestWithParam<Case> {};

TEST_P(HullVelocityOf, ATranslatingSphereIsItsNormalSpeedWithinPixelsOverTheInterval) {
  const Case c = GetParam();
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0.3, -0.2).normalized();  // towards the struck ball
  const Eigen::Vector3d across = d.cross(Eigen::Vector3d::UnitZ()).normalized();
  const MovingSphere s((c.towards ? d : across) * c.speed, c.fps);
  int checked = 0;
  for (int k = 1; k <= 4; ++k) {
    const MapFrame prev = s.Shoot(k - 1), cur = s.Shoot(k);
    // Contact points around the struck side: the line to the ball and lines
    // turned from it by up to 25 degrees.
    for (const Eigen::Vector3d& off : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0.3, 0),
                                       Eigen::Vector3d(0, 0, 0.4), Eigen::Vector3d(0, -0.35, 0.2)}) {
      const Eigen::Vector3d dir = (d + off).normalized();
      const auto contact = ContactOn(*cur.query, s.CentreAt(k / c.fps), dir);
      ASSERT_TRUE(contact);
      const HullMotion motion(cur.timed, prev.timed);
      const HullVelocity est = motion.At(contact->cp, contact->n);
      // Moving across, the normal line of a contact off the motion's side can
      // miss the previous frame's sphere altogether (3 m/s at 50 fps moves it
      // 6 cm, over half its radius): no surface there to compare, so none.
      if (!c.towards && est.status == HullVelocityStatus::kAppeared) continue;
      ASSERT_EQ(est.status, HullVelocityStatus::kMeasured) << ToString(est.status);
      const Eigen::Vector3d n_true = SmoothHullNormal(s.SceneAt(k / c.fps), s.Centres(), contact->cp);
      const double truth = s.velocity().dot(n_true);
      const double bound = Bound(s, contact->cp, n_true, est.interval_s);
      EXPECT_NEAR(est.normal_speed, truth, bound) << "frame " << k << " direction " << dir.transpose();
      // The interval is the forming cameras' own: within the jitter of the
      // framesets' 1/fps.
      EXPECT_NEAR(est.interval_s, 1 / c.fps, 0.0131);
      ++checked;
    }
  }
  EXPECT_GE(checked, c.towards ? 16 : 8);
}

INSTANTIATE_TEST_SUITE_P(Speeds, HullVelocityOf,
                         testing::Values(Case{0.2, 25, true}, Case{0.2, 50, true}, Case{1.0, 25, true},
                                         Case{1.0, 50, true}, Case{3.0, 25, true}, Case{3.0, 50, true},
                                         Case{1.0, 25, false}, Case{3.0, 50, false}),
                         Name);

// Positive control for the timing: the same fast sphere timed by the
// framesets' reference times alone (as if every camera shot together) is off
// by v times the jitter over the interval, beyond the bound the right timing
// meets.
TEST(HullVelocity, TimingByTheFramesetsAloneFailsWhereCamerasJitter) {
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0.3, -0.2).normalized();
  const MovingSphere s(d * 3.0, 50);
  const MapFrame prev = s.Shoot(2), cur = s.Shoot(3);
  const auto contact = ContactOn(*cur.query, s.CentreAt(3 / 50.0), d);
  ASSERT_TRUE(contact);
  const Eigen::Vector3d n_true = SmoothHullNormal(s.SceneAt(3 / 50.0), s.Centres(), contact->cp);
  const double truth = s.velocity().dot(n_true);
  TimedHull cur_ref = cur.timed, prev_ref = prev.timed;
  cur_ref.view_time_ns.clear();
  prev_ref.view_time_ns.clear();
  const HullVelocity right = HullMotion(cur.timed, prev.timed).At(contact->cp, contact->n);
  const HullVelocity wrong = HullMotion(cur_ref, prev_ref).At(contact->cp, contact->n);
  ASSERT_TRUE(right.valid() && wrong.valid());
  const double bound = Bound(s, contact->cp, n_true, 0.02);
  EXPECT_NEAR(right.normal_speed, truth, bound);
  EXPECT_GT(std::abs(wrong.normal_speed - truth), bound);
}

TEST(HullVelocity, AStationaryHullIsExactlyZero) {
  const MovingSphere s(Eigen::Vector3d::Zero(), 25);
  const MapFrame prev = s.Shoot(0), cur = s.Shoot(1);
  const auto contact = ContactOn(*cur.query, kStart, Eigen::Vector3d(1, 0, 0));
  ASSERT_TRUE(contact);
  const HullVelocity v = HullMotion(cur.timed, prev.timed).At(contact->cp, contact->n);
  EXPECT_EQ(v.status, HullVelocityStatus::kMeasured);
  EXPECT_EQ(v.normal_speed, 0.0);
  EXPECT_EQ(v.displacement, 0.0);
}

TEST(HullVelocity, AHullThatAppearsGivesNoneAndAFarJumpIsClampedOrNone) {
  const Eigen::Vector3d d(1, 0, 0);
  const MovingSphere s(Eigen::Vector3d::Zero(), 50, /*skew=*/false);
  const MapFrame cur = s.Shoot(1);
  const auto contact = ContactOn(*cur.query, kStart, d);
  ASSERT_TRUE(contact);
  // Nothing in view before: the hull appeared.
  const MapFrame empty = s.Shoot(0, /*empty=*/true);
  EXPECT_EQ(HullMotion(cur.timed, empty.timed).At(contact->cp, contact->n).status, HullVelocityStatus::kAppeared);
  // The sphere 10 cm behind 20 ms earlier: 5 m/s, measured (positive control);
  // 30 cm behind: 15 m/s, clamped to the bound of 10 m/s; 50 cm behind: beyond
  // twice the bound, not the same surface.
  struct Jump {
    double back_m;
    HullVelocityStatus status;
    double speed;
  };
  // Moved back along the contact's normal line, so that the line meets it.
  for (const Jump& j : {Jump{0.1, HullVelocityStatus::kMeasured, 5.0}, Jump{0.3, HullVelocityStatus::kClamped, 10.0},
                        Jump{0.5, HullVelocityStatus::kAppeared, 0.0}}) {
    const MovingSphere before(Eigen::Vector3d::Zero(), 50, false);
    std::vector<CameraMap> views;
    const SyntheticScene moved{{Shape::Sphere(kStart - j.back_m * contact->n, kR)}};
    for (const auto& cam : before.cameras()) views.push_back({cam, RenderExactMap(cam, moved)});
    const VolumeQuery q(views, test::BigBox());
    const TimedHull prev = TimedHull::Of(q, cur.timed.time_ns - 20'000'000, std::vector<int64_t>(4, 0));
    const HullVelocity v = HullMotion(cur.timed, prev).At(contact->cp, contact->n);
    EXPECT_EQ(v.status, j.status) << j.back_m << " m: " << ToString(v.status) << " " << v.displacement << " "
                                  << v.interval_s;
    // 3 mm of silhouette quantization over 20 ms.
    EXPECT_NEAR(v.normal_speed, j.speed, 0.15) << j.back_m;
  }
}

TEST(HullVelocity, FramesetsTooFarApartOrOfOtherCamerasGiveNone) {
  const MovingSphere s(Eigen::Vector3d(0.5, 0, 0), 25, false);
  const MapFrame a = s.Shoot(0), b = s.Shoot(3);  // 0.12 s apart
  const auto contact = ContactOn(*b.query, s.CentreAt(0.12), Eigen::Vector3d(1, 0, 0));
  ASSERT_TRUE(contact);
  EXPECT_EQ(HullMotion(b.timed, a.timed).At(contact->cp, contact->n).status, HullVelocityStatus::kTooFarApart);
  HullMotionOptions wider;
  wider.max_interval = 0.15;
  EXPECT_EQ(HullMotion(b.timed, a.timed, wider).At(contact->cp, contact->n).status, HullVelocityStatus::kMeasured);
  TimedHull other = a.timed;
  other.camera_ids[2] = 9;
  EXPECT_EQ(HullMotion(b.timed, other).At(contact->cp, contact->n).status, HullVelocityStatus::kNoPrevious);
  EXPECT_EQ(HullMotion(b.timed, TimedHull{}).At(contact->cp, contact->n).status, HullVelocityStatus::kNoPrevious);
  HullMotionOptions off;
  off.enabled = false;
  EXPECT_EQ(HullMotion(b.timed, a.timed, off).At(contact->cp, contact->n).status, HullVelocityStatus::kNone);
}

TEST(HullVelocity, OptionsAreChecked) {
  for (double bad : {0.0, -1.0, std::nan(""), 1e9}) {
    HullMotionOptions o;
    o.max_speed = bad;
    EXPECT_THROW(o.Check(), std::invalid_argument);
    o = {};
    o.max_interval = bad;
    EXPECT_THROW(o.Check(), std::invalid_argument);
  }
}

TEST(HullVelocity, ReflectingOffAMovingSurfaceThrowsARestingBodyAtOnePlusETimesItsSpeed) {
  const Eigen::Vector3d n(0, 0, -1);
  HullVelocity h;
  h.status = HullVelocityStatus::kMeasured;
  h.normal_speed = 2.0;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  ReflectOffMovingSurface(n, h, 0.5, &v);
  EXPECT_TRUE(v.isApprox(Eigen::Vector3d(0, 0, -3.0)));
  // A body already leaving faster than the surface is untouched.
  v = Eigen::Vector3d(0.3, 0, -2.5);
  ReflectOffMovingSurface(n, h, 0.5, &v);
  EXPECT_EQ(v, Eigen::Vector3d(0.3, 0, -2.5));
  // No velocity (or none valid): the paper's reflection, bit for bit.
  for (HullVelocityStatus st : {HullVelocityStatus::kNone, HullVelocityStatus::kAppeared}) {
    HullVelocity none;
    none.status = st;
    Eigen::Vector3d a(0.2, 0.1, 1.5), b = a;
    ReflectOffMovingSurface(n, none, 0.7, &a);
    const double vn = b.dot(n);
    b -= (1 + 0.7) * vn * n;
    EXPECT_EQ(a, b);
  }
}

}  // namespace
}  // namespace hullpipe
