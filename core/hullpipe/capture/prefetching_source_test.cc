#include "hullpipe/capture/prefetching_source.h"

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <stdexcept>

#include <gtest/gtest.h>

namespace hullpipe {
namespace {

// Frames 0..n-1 of one 4x3 camera: frame k's map is all k, its time k / fps;
// frame 2 carries an error line. Counts its calls; the read of frame hold_at_
// waits until SetOpen(true).
class CountingSource final : public RigSource {
 public:
  explicit CountingSource(int n, bool live = false) : n_(n), live_(live) {
    Camera c;
    c.id = 7;
    c.width = 4;
    c.height = 3;
    cameras_.push_back(c);
  }
  const std::vector<Camera>& cameras() const override { return cameras_; }
  int rig_camera_count() const override { return 1; }
  Aabb workspace() const override { return {}; }
  double fps() const override { return 10; }
  int64_t frame_count() const override { return n_; }
  bool live() const override { return live_; }
  std::vector<bool> tracked_by_topic() const override { return {true}; }
  bool Next(RigFrame* f) override {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      ++next_calls_;
      changed_.notify_all();
      changed_.wait(lock, [&] { return open_ || index_ != hold_at_; });
    }
    if (throw_at_ == index_) throw std::runtime_error("reader broke");
    if (index_ >= n_) return false;
    f->maps.assign(1, cv::Mat(3, 4, CV_8UC1, cv::Scalar(index_)));
    f->images.assign(1, cv::Mat(3, 4, CV_8UC3, cv::Scalar(index_, 0, 0)));
    f->errors.clear();
    if (index_ == 2) f->errors.push_back("camera 7: frame 2 damaged");
    f->time_s = double(index_) / fps();
    ++index_;
    return true;
  }
  bool Skip() override {
    ++skip_calls_;
    if (index_ >= n_) return false;
    ++index_;
    return true;
  }
  bool Rewind() override {
    index_ = 0;
    return true;
  }
  std::string IncompleteEnd() const override { return index_ >= n_ ? "camera 7 ended early" : ""; }

  void SetOpen(bool open) {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = open;
    changed_.notify_all();
  }
  // Waits (at most 5 s) until Next has been called `calls` times.
  bool WaitForNextCalls(int calls) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(5), [&] { return next_calls_ >= calls; });
  }
  int next_calls() {
    std::lock_guard<std::mutex> lock(mutex_);
    return next_calls_;
  }
  int skip_calls_ = 0;
  int throw_at_ = -1;
  int hold_at_ = -1;

 private:
  std::vector<Camera> cameras_;
  int n_;
  bool live_;
  int index_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  int next_calls_ = 0;
  bool open_ = false;
};

int FrameNumber(const RigFrame& f) { return f.maps.empty() ? -1 : int(f.maps[0].at<uint8_t>(0, 0)); }

TEST(PrefetchingSource, GivesTheWrappedSourcesFramesErrorsAndEndUnchanged) {
  auto owned = std::make_unique<CountingSource>(5);
  CountingSource& inner = *owned;
  PrefetchingSource source(std::move(owned));
  EXPECT_EQ(source.cameras().size(), 1u);
  EXPECT_EQ(source.cameras()[0].id, 7);
  EXPECT_EQ(source.frame_count(), 5);
  EXPECT_EQ(source.tracked_by_topic(), std::vector<bool>{true});  // capture_node poses it live
  RigFrame f;
  for (int k = 0; k < 5; ++k) {
    ASSERT_TRUE(source.Next(&f)) << k;
    EXPECT_EQ(FrameNumber(f), k);
    EXPECT_DOUBLE_EQ(f.time_s, k / 10.0);
    EXPECT_EQ(f.errors.size(), k == 2 ? 1u : 0u) << k;
  }
  EXPECT_FALSE(source.Next(&f));
  EXPECT_EQ(source.IncompleteEnd(), "camera 7 ended early");
  // Frames 2..4 and the end were read ahead (from the second frame taken);
  // nothing after the end.
  EXPECT_EQ(source.prefetched(), 4);
  EXPECT_EQ(inner.next_calls(), 6);
}

TEST(PrefetchingSource, ReadsTheNextFrameWhileTheCallerPublishesThisOne) {
  auto owned = std::make_unique<CountingSource>(5);
  CountingSource& inner = *owned;
  PrefetchingSource source(std::move(owned));
  RigFrame f;
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 0);
  EXPECT_EQ(inner.next_calls(), 1);  // one frame taken: not yet known to keep up
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 1);
  // Two in a row, and no further call from here: frame 2's read starts on its own.
  EXPECT_TRUE(inner.WaitForNextCalls(3));
  // Control: the same source unwrapped reads nothing before it is asked.
  CountingSource bare(5);
  ASSERT_TRUE(bare.Next(&f));
  EXPECT_EQ(bare.next_calls(), 1);
}

TEST(PrefetchingSource, NextWaitsForAReadInFlight) {
  auto owned = std::make_unique<CountingSource>(5);
  CountingSource& inner = *owned;
  inner.hold_at_ = 2;  // frame 2's read (the one ahead) is held
  PrefetchingSource source(std::move(owned));
  RigFrame f;
  ASSERT_TRUE(source.Next(&f));
  ASSERT_TRUE(source.Next(&f));
  ASSERT_TRUE(inner.WaitForNextCalls(3));
  auto next = std::async(std::launch::async, [&] { return source.Next(&f); });
  // The absence: Next has not returned while the read is held...
  EXPECT_EQ(next.wait_for(std::chrono::milliseconds(50)), std::future_status::timeout);
  inner.SetOpen(true);
  // ...and its control: it returns frame 2 once the read ends.
  ASSERT_EQ(next.wait_for(std::chrono::seconds(5)), std::future_status::ready);
  ASSERT_TRUE(next.get());
  EXPECT_EQ(FrameNumber(f), 2);
}

TEST(PrefetchingSource, SkipsDiscardTheFrameReadAheadThenSkipWithoutReading) {
  auto owned = std::make_unique<CountingSource>(10);
  CountingSource& inner = *owned;
  PrefetchingSource source(std::move(owned));
  RigFrame f;
  ASSERT_TRUE(source.Next(&f));  // frame 0
  ASSERT_TRUE(source.Next(&f));  // frame 1; frame 2 read ahead
  ASSERT_TRUE(inner.WaitForNextCalls(3));
  ASSERT_TRUE(source.Skip());    // frame 2, discarded
  ASSERT_TRUE(source.Skip());    // frame 3: the wrapped Skip, no read
  ASSERT_TRUE(source.Skip());    // frame 4
  EXPECT_EQ(inner.next_calls(), 3);
  EXPECT_EQ(inner.skip_calls_, 2);
  EXPECT_EQ(source.prefetch_discarded(), 1);
  // The caller is behind: the frame after the skips is read when asked for,
  // and nothing is read ahead of it (it would be skipped in its turn)...
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 5);
  EXPECT_EQ(inner.next_calls(), 4);
  // ...until two frames come without a skip between.
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 6);
  EXPECT_TRUE(inner.WaitForNextCalls(6));  // frame 7, read ahead
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 7);
  EXPECT_EQ(source.prefetched(), 1);  // frame 7 (frame 2 was read ahead and skipped)
  EXPECT_EQ(source.prefetch_discarded(), 1);
}

TEST(PrefetchingSource, RewindStartsFromTheFirstFrameAgain) {
  PrefetchingSource source(std::make_unique<CountingSource>(4));
  RigFrame f;
  ASSERT_TRUE(source.Next(&f));
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 1);
  ASSERT_TRUE(source.Rewind());  // frame 2, read ahead, is discarded
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 0);
  ASSERT_TRUE(source.Next(&f));
  EXPECT_EQ(FrameNumber(f), 1);
}

TEST(PrefetchingSource, AnExceptionOfTheReaderThreadReachesTheCaller) {
  auto owned = std::make_unique<CountingSource>(5);
  owned->throw_at_ = 2;  // the read ahead
  PrefetchingSource source(std::move(owned));
  RigFrame f;
  ASSERT_TRUE(source.Next(&f));
  ASSERT_TRUE(source.Next(&f));
  EXPECT_THROW(source.Next(&f), std::runtime_error);
}

TEST(PrefetchingSource, LiveSourcesAreNotWrapped) {
  auto live = std::make_unique<CountingSource>(3, /*live=*/true);
  RigSource* raw = live.get();
  EXPECT_EQ(ReadAhead(std::move(live)).get(), raw);
  auto files = std::make_unique<CountingSource>(3);
  raw = files.get();
  EXPECT_NE(ReadAhead(std::move(files)).get(), raw);
}

}  // namespace
}  // namespace hullpipe
