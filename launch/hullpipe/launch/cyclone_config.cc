#include "hullpipe/launch/cyclone_config.h"

#include <fstream>
#include <stdexcept>

namespace hullpipe::launch {

std::string CycloneConfigXml(const CycloneConfigOptions& o) {
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  if (!o.comment.empty()) x += "<!-- " + o.comment + " -->\n";
  x += "<CycloneDDS xmlns=\"https://cdds.io/config\">\n  <Domain id=\"any\">\n";
  x += "    <General>\n      <Interfaces><NetworkInterface name=\"" + o.interface + "\"/></Interfaces>\n";
  x += "      <AllowMulticast>false</AllowMulticast>\n      <MaxMessageSize>65500B</MaxMessageSize>\n    </General>\n";
  x += "    <Discovery>\n      <ParticipantIndex>auto</ParticipantIndex>\n";
  x += "      <MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>\n      <Peers>";
  for (const auto& p : o.peers) x += "<Peer address=\"" + p + "\"/>";
  x += "</Peers>\n";
  if (o.fast_announcements) x += "      <SPDPInterval>1s</SPDPInterval>\n";
  x += "    </Discovery>\n";
  if (o.fast_repair || o.loss_per_mille > 0) {
    x += "    <Internal>\n";
    if (o.fast_repair)
      x += "      <HeartbeatInterval min=\"2ms\" minsched=\"5ms\">10ms</HeartbeatInterval>\n"
           "      <NackDelay>2ms</NackDelay>\n      <AutoReschedNackDelay>20ms</AutoReschedNackDelay>\n";
    if (o.loss_per_mille > 0)
      x += "      <Test><XmitLossiness>" + std::to_string(o.loss_per_mille) + "</XmitLossiness></Test>\n";
    x += "    </Internal>\n";
  }
  x += "  </Domain>\n</CycloneDDS>\n";
  return x;
}

std::string WriteCycloneConfig(const std::string& path, const CycloneConfigOptions& options) {
  std::ofstream f(path);
  f << CycloneConfigXml(options);
  if (!f) throw std::runtime_error(path + ": cannot write the Cyclone DDS config");
  return path;
}

}  // namespace hullpipe::launch
