#include "hullpipe/record/snapshot.h"

#include <algorithm>
#include <stdexcept>

namespace hullpipe::record {

void SnapshotOptions::Check() const {
  if (!(seconds > 0 && seconds <= 3600)) throw std::invalid_argument("--snapshot-seconds must be in (0, 3600]");
  if (max_bytes < 4096 || max_bytes > (int64_t(64) << 30))
    throw std::invalid_argument("--snapshot-bytes must be in [4096, 64 GiB]");
}

SnapshotBuffer::SnapshotBuffer(const SnapshotOptions& options) : options_(options) { options_.Check(); }

void SnapshotBuffer::AddTopic(const TopicInfo& topic) {
  if (topic_index_.count(topic.id)) return;
  topic_index_[topic.id] = topics_.size();
  topics_.push_back(topic);
}

size_t SnapshotBuffer::size() const {
  size_t n = window_.size();
  for (const auto& [id, d] : durable_) n += d.size();
  return n;
}

void SnapshotBuffer::Add(Sample sample) {
  if (!topic_index_.count(sample.topic_id))
    throw std::invalid_argument("snapshot: sample of topic id " + std::to_string(sample.topic_id) +
                                " that was not added");
  const int64_t now = sample.arrival_ns;
  bytes_ += int64_t(sample.data.size());
  window_.push_back(std::move(sample));
  Expire(now);
  // The byte bound: the oldest first, durable samples before the window's.
  while (bytes_ > options_.max_bytes && size() > 1) {
    auto oldest_durable = durable_.end();
    for (auto it = durable_.begin(); it != durable_.end(); ++it)
      if (!it->second.empty() && (oldest_durable == durable_.end() ||
                                  it->second.front().arrival_ns < oldest_durable->second.front().arrival_ns))
        oldest_durable = it;
    if (oldest_durable != durable_.end()) {
      bytes_ -= int64_t(oldest_durable->second.front().data.size());
      oldest_durable->second.pop_front();
    } else {
      bytes_ -= int64_t(window_.front().data.size());
      window_.pop_front();
    }
    ++dropped_for_bytes_;
  }
}

void SnapshotBuffer::TrimTo(int64_t now_ns) { Expire(now_ns); }

void SnapshotBuffer::Expire(int64_t now_ns) {
  const int64_t oldest_kept = now_ns - int64_t(options_.seconds * 1e9);
  while (!window_.empty() && window_.front().arrival_ns < oldest_kept) {
    Sample s = std::move(window_.front());
    window_.pop_front();
    const TopicInfo& t = topics_[topic_index_.at(s.topic_id)];
    if (t.transient_local) {
      auto& d = durable_[s.topic_id];
      d.push_back(std::move(s));
      while (int64_t(d.size()) > kDurableInstances * std::max<int64_t>(1, t.depth)) {
        bytes_ -= int64_t(d.front().data.size());
        d.pop_front();
      }
    } else {
      bytes_ -= int64_t(s.data.size());
    }
  }
}

std::vector<Sample> SnapshotBuffer::Contents() const {
  std::vector<Sample> out;
  for (const auto& [id, d] : durable_) out.insert(out.end(), d.begin(), d.end());
  std::stable_sort(out.begin(), out.end(),
                   [](const Sample& a, const Sample& b) { return a.arrival_ns < b.arrival_ns; });
  out.insert(out.end(), window_.begin(), window_.end());
  return out;
}

}  // namespace hullpipe::record
