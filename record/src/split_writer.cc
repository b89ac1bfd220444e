#include "hullpipe/record/split_writer.h"

#include <cstdio>
#include <filesystem>
#include <random>
#include <stdexcept>

namespace hullpipe::record {

void SplitOptions::Check() const {
  writer.Check();
  if (!(max_bytes == 0 || max_bytes >= 4096)) throw std::invalid_argument("--split-size must be 0 or >= 4096 bytes");
  if (!(max_duration_s == 0 || (max_duration_s >= 0.1 && max_duration_s <= 1e6)))
    throw std::invalid_argument("--split-duration must be 0 or in [0.1, 1e6] s");
}

std::string SplitWriter::PartPath(const std::string& dir, int index, Storage storage) {
  char name[32];
  std::snprintf(name, sizeof name, "part_%04d%s", index, StorageExtension(storage));
  return (std::filesystem::path(dir) / name).string();
}

SplitWriter::SplitWriter(const std::string& dir, const SplitOptions& options) : dir_(dir), options_(options) {
  options_.Check();
  std::error_code ec;
  if (std::filesystem::exists(dir, ec)) throw RecordingError(dir + ": exists; recordings are never overwritten");
  if (!std::filesystem::create_directories(dir, ec) || ec)
    throw RecordingError(dir + ": cannot create the directory: " + ec.message());
  std::random_device rd;
  char id[17];
  std::snprintf(id, sizeof id, "%08x%08x", rd(), rd());
  set_id_ = id;
  NextPart();
}

SplitWriter::~SplitWriter() = default;

void SplitWriter::NextPart() {
  if (part_) {
    committed_before_ += part_->samples_committed() + part_->samples_pending();
    stored_before_ += part_->stored_bytes();
    raw_before_ += part_->raw_bytes();
    part_.reset();  // commits and marks the part closed
  }
  ++index_;
  WriterOptions w = options_.writer;
  w.storage = w.storage.value_or(StorageForPath(dir_));
  part_ = std::make_unique<RecordingWriter>(PartPath(dir_, index_, *w.storage), w);
  part_->SetMeta("set", set_id_);
  part_->SetMeta("part", std::to_string(index_));
  for (const auto& [k, v] : meta_) part_->SetMeta(k, v);
  for (const auto& t : topics_) part_->AddTopic(t);
  part_first_arrival_ns_ = -1;
}

int64_t SplitWriter::AddTopic(const TopicInfo& topic) {
  const int64_t id = part_->AddTopic(topic);
  bool known = false;
  for (const auto& t : topics_) known = known || t.name == topic.name;
  if (!known) topics_.push_back(topic);
  return id;
}

void SplitWriter::Append(const Sample& s) {
  const bool full_by_size = options_.max_bytes > 0 && part_->stored_bytes() >= options_.max_bytes;
  const bool full_by_time = options_.max_duration_s > 0 && part_first_arrival_ns_ >= 0 &&
                            double(s.arrival_ns - part_first_arrival_ns_) * 1e-9 >= options_.max_duration_s;
  if (full_by_size || full_by_time) NextPart();
  if (part_first_arrival_ns_ < 0) part_first_arrival_ns_ = s.arrival_ns;
  part_->Append(s);
}

void SplitWriter::Commit() { part_->Commit(); }

void SplitWriter::SetMeta(const std::string& key, const std::string& value) {
  meta_[key] = value;
  part_->SetMeta(key, value);
}

}  // namespace hullpipe::record
