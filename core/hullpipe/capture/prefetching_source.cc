#include "hullpipe/capture/prefetching_source.h"

#include <utility>

namespace hullpipe {

PrefetchingSource::PrefetchingSource(std::unique_ptr<RigSource> inner)
    : inner_(std::move(inner)),
      cameras_(inner_->cameras()),
      rig_camera_count_(inner_->rig_camera_count()),
      workspace_(inner_->workspace()),
      fps_(inner_->fps()),
      frame_count_(inner_->frame_count()),
      live_(inner_->live()),
      tracked_by_topic_(inner_->tracked_by_topic()) {}

PrefetchingSource::~PrefetchingSource() {
  if (read_.valid()) read_.wait();  // the reader thread uses inner_ and ahead_
}

bool PrefetchingSource::Collect(RigFrame* frame) {
  const bool ok = read_.get();  // rethrows what the reader thread threw
  if (frame) {
    std::swap(*frame, ahead_);
    ++prefetched_;
  } else {
    ++discarded_;
  }
  return ok;
}

void PrefetchingSource::StartAhead() {
  if (live_) return;
  read_ = std::async(std::launch::async, [this] { return inner_->Next(&ahead_); });
}

bool PrefetchingSource::Next(RigFrame* frame) {
  const bool ok = read_.valid() ? Collect(frame) : inner_->Next(frame);
  // Read ahead only while the caller keeps up: two frames taken in a row, no
  // skip between. A caller that skips is behind, and the frame read ahead
  // would only be skipped in its turn (a source slower than its rate read
  // every published frame twice, and once more at the start).
  ++streak_;
  if (ok && streak_ >= 2) StartAhead();
  return ok;
}

bool PrefetchingSource::Skip() {
  streak_ = 0;
  if (read_.valid()) return Collect(nullptr);
  return inner_->Skip();
}

bool PrefetchingSource::Rewind() {
  if (read_.valid()) Collect(nullptr);
  streak_ = 0;
  const bool ok = inner_->Rewind();
  frame_count_ = inner_->frame_count();
  return ok;
}

std::string PrefetchingSource::IncompleteEnd() const {
  if (read_.valid()) read_.wait();
  return inner_->IncompleteEnd();
}

std::unique_ptr<RigSource> ReadAhead(std::unique_ptr<RigSource> inner) {
  if (inner->live()) return inner;
  return std::make_unique<PrefetchingSource>(std::move(inner));
}

}  // namespace hullpipe
