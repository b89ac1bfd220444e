// Shared by the libFuzzer targets: the input as a file, for parsers that read
// paths (rig, scene and CSV files, recordings).
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace hullpipe::fuzz {

/// Writes data to a file of this process (in TMPDIR or /tmp, with `suffix`) and
/// removes it on destruction.
class InputFile {
 public:
  InputFile(const uint8_t* data, size_t size, const std::string& suffix) {
    const char* tmp = std::getenv("TMPDIR");
    path_ = (std::filesystem::path(tmp ? tmp : "/tmp") /
             ("hullpipe_fuzz_" + std::to_string(getpid()) + suffix))
                .string();
    std::ofstream(path_, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data),
                                                                    std::streamsize(size));
  }
  ~InputFile() { std::remove(path_.c_str()); }
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace hullpipe::fuzz
