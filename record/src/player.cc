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
  if (!(end_offset_s >= 0 && end_offset_s <= kMaxStartOffsetS))
    throw std::invalid_argument("--end must be in [0, 1e6] s");
  if (end_offset_s > 0 && end_offset_s <= start_offset_s)
    throw std::invalid_argument("--end (or --start-offset + --duration) must be after --start-offset");
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
  const auto first = rec.FirstArrivalNs(selected);
  if (!first) return stats;
  const int64_t first_ns = *first;
  const int64_t last_ns = std::max(first_ns, rec.LastArrivalNs(selected).value_or(first_ns));
  int64_t start_ns = first_ns + int64_t(o.start_offset_s * 1e9);
  const int64_t end_ns = o.end_offset_s > 0 ? first_ns + int64_t(o.end_offset_s * 1e9) : last_ns;
  if (o.start_offset_s > 0 && start_ns > last_ns)
    throw std::invalid_argument("--start-offset " + std::to_string(o.start_offset_s) +
                                " s is past the recording's end (" + std::to_string(double(last_ns - first_ns) * 1e-9) +
                                " s)");
  double rate = o.rate;
  for (;;) {
    double wall0 = clock->Now();
    int64_t t0 = -1;  // arrival time the wall clock counts from (first timed sample, or since a rate change)
    bool stopped = false, seeked = false;
    // Takes pending rate and seek requests; true if a seek ends this pass's ForEach.
    auto take_requests = [&](int64_t current_ns) {
      const double r = control->new_rate.exchange(-1);
      if (r >= 0) {
        if (r == 0 || (r >= PlayerOptions::kMinRate && r <= PlayerOptions::kMaxRate)) {
          // Go on from where the recording's time is now at the old rate, so the
          // rest of the current gap is scaled by the new one.
          const double now = clock->Now();
          t0 = rate > 0 ? std::min(current_ns, t0 + int64_t((now - wall0) * rate * 1e9)) : current_ns;
          wall0 = now;
          rate = r;
        } else {
          ++stats.refused_requests;
        }
      }
      const double seek = control->seek_s.exchange(-1);
      if (seek >= 0) {
        start_ns = first_ns + int64_t(std::min(seek, PlayerOptions::kMaxStartOffsetS) * 1e9);
        ++stats.seeks;
        seeked = true;
      }
      return seeked;
    };
    rec.ForEach([&](const Sample& s) {
      const TopicInfo& topic = *by_id.at(s.topic_id);
      if (s.arrival_ns < start_ns) {
        if (topic.transient_local) {  // durable state before the offset: at once
          sink(topic, s);
          ++stats.samples;
        }
        return !control->stop.load();
      }
      if (s.arrival_ns > end_ns) return false;
      // Pause and step between samples; paused time does not count.
      if (control->paused.load()) {
        const double p0 = clock->Now();
        while (control->paused.load() && !control->stop.load() && control->seek_s.load() < 0) {
          if (control->steps.load() > 0) {
            --control->steps;
            break;
          }
          clock->SleepFor(0.01);
        }
        wall0 += clock->Now() - p0;
      }
      if (t0 < 0) t0 = s.arrival_ns;
      if (take_requests(s.arrival_ns)) return false;
      if (control->stop.load()) {
        stopped = true;
        return false;
      }
      for (bool first_wait = true; rate > 0; first_wait = false) {
        const double due = wall0 + double(s.arrival_ns - t0) * 1e-9 / rate;
        double now = clock->Now();
        if (first_wait && due <= now) stats.max_lateness_s = std::max(stats.max_lateness_s, now - due);
        // In slices, so a stop, seek or rate request is honoured within
        // kSleepSliceS of any gap.
        while (due > now && !control->stop.load() && control->seek_s.load() < 0 && control->new_rate.load() < 0) {
          clock->SleepFor(std::min(kSleepSliceS, due - now));
          now = clock->Now();
        }
        if (control->stop.load()) {
          stopped = true;
          return false;
        }
        if (control->seek_s.load() < 0 && control->new_rate.load() < 0) break;  // due
        if (take_requests(s.arrival_ns)) return false;
        // A new rate mid-gap: the rest of the gap at the new rate (the loop again).
      }
      sink(topic, s);
      ++stats.samples;
      control->position_s = double(s.arrival_ns - first_ns) * 1e-9;
      return true;
    }, selected);
    if (stopped || control->stop.load()) break;
    if (seeked) {
      if (start_ns > end_ns) break;  // a seek past the end ends the pass
      continue;
    }
    ++stats.loops;
    if (!o.loop || (o.max_loops > 0 && stats.loops >= o.max_loops)) break;
    start_ns = first_ns + int64_t(o.start_offset_s * 1e9);
  }
  return stats;
}

}  // namespace hullpipe::record
