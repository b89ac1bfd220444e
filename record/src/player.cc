#include "hullpipe/record/player.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <stdexcept>
#include <thread>

namespace hullpipe::record {

void PlayerOptions::Check() const {
  if (!(rate == 0 || (rate >= kMinRate && rate <= kMaxRate)))
    throw std::invalid_argument("--rate must be 0 or in [0.001, 1000]");
  if (max_loops < 0) throw std::invalid_argument("--max-loops must be >= 0");
  if (!(start_offset_s >= 0 && start_offset_s <= kMaxStartOffsetS))
    throw std::invalid_argument("--start-offset must be in [0, 1e6] s");
}

namespace {
struct SteadyClock : PlayerClock {
  double Now() override {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  void SleepFor(double s) override { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }
};
}  // namespace

PlayStats Play(const RecordingReader& rec, const PlayerOptions& o,
               const std::function<void(const TopicInfo&, const Sample&)>& sink, PlayerControl* control,
               PlayerClock* clock) {
  o.Check();
  SteadyClock steady;
  if (!clock) clock = &steady;
  PlayerControl local;
  if (!control) control = &local;
  std::map<int64_t, const TopicInfo*> by_id;
  std::vector<int64_t> selected;
  for (const auto& t : rec.topics())
    if (TopicSelected(o.include, o.exclude, t.name)) {
      by_id[t.id] = &t;
      selected.push_back(t.id);
    }
  PlayStats stats;
  if (selected.empty()) return stats;
  int64_t first_ns = -1;
  rec.ForEach([&](const Sample& s) {
    first_ns = s.arrival_ns;
    return false;
  }, selected);
  if (first_ns < 0) return stats;
  const int64_t start_ns = first_ns + int64_t(o.start_offset_s * 1e9);
  if (o.start_offset_s > 0) {
    const int64_t last_ns = std::max(first_ns, rec.LastArrivalNs(selected).value_or(first_ns));
    if (start_ns > last_ns)
      throw std::invalid_argument("--start-offset " + std::to_string(o.start_offset_s) +
                                  " s is past the recording's end (" + std::to_string(double(last_ns - first_ns) * 1e-9) +
                                  " s)");
  }
  for (;;) {
    double wall0 = clock->Now();
    int64_t t0 = -1;  // arrival time of the first timed sample of this pass
    bool stopped = false;
    rec.ForEach([&](const Sample& s) {
      const TopicInfo& topic = *by_id.at(s.topic_id);
      if (s.arrival_ns < start_ns) {
        if (topic.transient_local) {  // durable state before the offset: at once
          sink(topic, s);
          ++stats.samples;
        }
        return !control->stop.load();
      }
      // Pause and step between samples; paused time does not count.
      if (control->paused.load()) {
        const double p0 = clock->Now();
        while (control->paused.load() && !control->stop.load()) {
          if (control->steps.load() > 0) {
            --control->steps;
            break;
          }
          clock->SleepFor(0.01);
        }
        wall0 += clock->Now() - p0;
      }
      if (control->stop.load()) {
        stopped = true;
        return false;
      }
      if (t0 < 0) t0 = s.arrival_ns;
      if (o.rate > 0) {
        const double due = wall0 + double(s.arrival_ns - t0) * 1e-9 / o.rate;
        double now = clock->Now();
        if (due <= now) stats.max_lateness_s = std::max(stats.max_lateness_s, now - due);
        // In slices, so a stop request is honoured within kSleepSliceS of any gap.
        while (due > now && !control->stop.load()) {
          clock->SleepFor(std::min(kSleepSliceS, due - now));
          now = clock->Now();
        }
        if (control->stop.load()) {
          stopped = true;
          return false;
        }
      }
      sink(topic, s);
      ++stats.samples;
      return true;
    }, selected);
    if (stopped || control->stop.load()) break;
    ++stats.loops;
    if (!o.loop || (o.max_loops > 0 && stats.loops >= o.max_loops)) break;
  }
  return stats;
}

}  // namespace hullpipe::record
