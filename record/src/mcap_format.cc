// The MCAP format's shared helpers (mcap_format.h).
#include "mcap_format.h"

#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <algorithm>

namespace hullpipe::record::mcap {

uint32_t Crc(uint32_t crc, const uint8_t* p, size_t n) {
  uLong c = crc;
  while (n > 0) {
    const size_t k = std::min<size_t>(n, 1u << 30);
    c = crc32(c, p, uInt(k));
    p += k;
    n -= k;
  }
  return uint32_t(c);
}


std::string QosYaml(const TopicInfo& t) {
  YAML::Emitter e;
  e << YAML::BeginMap << YAML::Key << "reliability" << YAML::Value << t.reliable << YAML::Key << "durability"
    << YAML::Value << t.transient_local << YAML::Key << "ownership" << YAML::Value << false << YAML::Key << "keyed"
    << YAML::Value << t.keyed << YAML::Key << "depth" << YAML::Value << t.depth << YAML::EndMap;
  return std::string(e.c_str()) + "\n";
}

}  // namespace hullpipe::record::mcap
