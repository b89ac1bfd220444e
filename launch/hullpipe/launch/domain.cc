#include "hullpipe/launch/domain.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace hullpipe::launch {

DomainLease::DomainLease(uint32_t first, uint32_t last) {
  if (first > last || last > kMaxDomainId)
    throw std::invalid_argument("DomainLease: ids must lie in 0.." + std::to_string(kMaxDomainId));
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "hullpipe-domains";
  std::filesystem::create_directories(dir);
  const uint32_t n = last - first + 1;
  const uint32_t start = uint32_t(getpid()) % n;  // spreads processes; the lock decides
  for (uint32_t k = 0; k < n; ++k) {
    const uint32_t id = first + (start + k) % n;
    const std::string path = (dir / ("domain-" + std::to_string(id) + ".lock")).string();
    const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
    if (fd < 0) continue;
    if (flock(fd, LOCK_EX | LOCK_NB) == 0) {
      id_ = id;
      fd_ = fd;
      return;
    }
    close(fd);
  }
  throw std::runtime_error("no free DDS domain in " + std::to_string(first) + ".." + std::to_string(last));
}

DomainLease::DomainLease(DomainLease&& o) noexcept : id_(o.id_), fd_(o.fd_) { o.fd_ = -1; }

DomainLease& DomainLease::operator=(DomainLease&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) close(fd_);
    id_ = o.id_;
    fd_ = o.fd_;
    o.fd_ = -1;
  }
  return *this;
}

DomainLease::~DomainLease() {
  if (fd_ >= 0) close(fd_);  // releases the lock
}

}  // namespace hullpipe::launch
