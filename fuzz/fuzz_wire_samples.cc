// libFuzzer: samples on the wire. The first byte picks one of the topics of
// idl/hullpipe.idl (dds/cdr.h KnownTypes); the rest is that sample's CDR with
// its 4-byte header, as a writer on the domain (or a recording) could send it.
// Cyclone deserializes it (its own checks); what it accepts goes through the
// same converters the nodes use (dds/convert.h: sizes, lengths, finiteness,
// run-length decoding, UTF-8), which may only refuse with MessageError.
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "hullpipe/dds/cdr.h"
#include "hullpipe/dds/convert.h"
#include "hullpipe/dds/topics.h"
#include "hullpipe/launch/cyclone_config.h"
#include "hullpipe/launch/domain.h"

namespace {

using namespace hullpipe;
using namespace hullpipe::dds;

struct Decoders {
  launch::DomainLease domain;  // a domain of our own, as every multi-process run
  std::unique_ptr<Participant> participant;
  std::vector<std::unique_ptr<CdrWriter>> writers;  // one per known type, for its sertype
};

Decoders* g = nullptr;

void Convert(const std::string& type, const void* sample) {
  if (type == "hullpipe::msg::CameraInfo") {
    Aabb ws;
    CameraFromMsg(*static_cast<const hullpipe_msg_CameraInfo*>(sample), &ws);
  } else if (type == "hullpipe::msg::ObjectPixelMap") {
    const auto& m = *static_cast<const hullpipe_msg_ObjectPixelMap*>(sample);
    MapPoseFromMsg(m);
    MapFromMsg(m);
  } else if (type == "hullpipe::msg::CameraImage") {
    ImageFromMsg(*static_cast<const hullpipe_msg_CameraImage*>(sample));
  } else if (type == "hullpipe::msg::ViewPose") {
    ViewFromMsg(*static_cast<const hullpipe_msg_ViewPose*>(sample));
  } else if (type == "hullpipe::msg::HullView") {
    TileFromMsg(*static_cast<const hullpipe_msg_HullView*>(sample));
  } else if (type == "hullpipe::msg::VirtualMesh") {
    VirtualMeshFromMsg(*static_cast<const hullpipe_msg_VirtualMesh*>(sample));
  } else if (type == "hullpipe::msg::HeadPose") {
    HeadPoseFromMsg(*static_cast<const hullpipe_msg_HeadPose*>(sample));
  } else if (type == "hullpipe::msg::VirtualObjectState") {
    VirtualObjectFromMsg(*static_cast<const hullpipe_msg_VirtualObjectState*>(sample));
  } else if (type == "hullpipe::msg::NodeStats") {
    NodeStatsFromMsg(*static_cast<const hullpipe_msg_NodeStats*>(sample));
  } else if (type == "hullpipe::msg::ModelPart") {
    ModelPartFromMsg(*static_cast<const hullpipe_msg_ModelPart*>(sample));
  } else if (type == "hullpipe::msg::ModelState") {
    ModelStateFromMsg(*static_cast<const hullpipe_msg_ModelState*>(sample));
  } else if (type == "hullpipe::msg::CompositedView") {
    CompositedViewFromMsg(*static_cast<const hullpipe_msg_CompositedView*>(sample));
  }
  // CollisionReport and SceneCommand: only counted or range-checked by the
  // nodes; Cyclone's deserialization above is what they rely on.
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (!std::getenv("CYCLONEDDS_URI") || !*std::getenv("CYCLONEDDS_URI")) {
    // Loopback only, no multicast: nothing leaves the machine.
    launch::CycloneConfigOptions o;
    const std::string path = launch::WriteCycloneConfig(
        (std::string(std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp") + "/hullpipe_fuzz_cyclonedds.xml"), o);
    setenv("CYCLONEDDS_URI", ("file://" + path).c_str(), 1);
  }
  g = new Decoders;
  g->participant = std::make_unique<Participant>(g->domain.id());
  for (const KnownType& t : KnownTypes()) g->writers.push_back(std::make_unique<CdrWriter>(*g->participant, t, t.qos));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const auto& types = KnownTypes();
  const size_t which = data[0] % types.size();
  const KnownType& type = types[which];
  const std::vector<uint8_t> cdr(data + 1, data + size);
  // A zeroed sample of the type, aligned for any of its members.
  std::vector<std::max_align_t> storage((type.descriptor->m_size + sizeof(std::max_align_t) - 1) /
                                        sizeof(std::max_align_t));
  void* sample = storage.data();
  std::memset(sample, 0, type.descriptor->m_size);
  if (g->writers[which]->Decode(cdr, sample)) {
    try {
      Convert(type.type_name, sample);
    } catch (const MessageError&) {
    }
  }
  dds_sample_free(sample, type.descriptor, DDS_FREE_CONTENTS);
  return 0;
}
