// Serialized samples (CDR, untouched) for recording and replaying DDS traffic
// (docs/architecture.md), through the same wrapper and error policy as dds.h.
//
// The recorder discovers topics from Cyclone's built-in DCPSPublication topic and
// records those whose type is one of hullpipe's (KnownTypes()); the replayer
// publishes recorded bytes with dds_writecdr. Cyclone 0.10 has no public call
// that gives a topic's sertype (needed to turn bytes back into a serdata), so a
// CdrWriter learns it once by a probe: a zeroed sample written and taken back on
// a private partition of its own participant, where no other endpoint can see it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hullpipe/dds/dds.h"

struct ddsi_sertype;

namespace hullpipe::dds {

/// A hullpipe message type and its topic.
struct KnownType {
  std::string topic_name;               ///< e.g. "hullpipe/camera_info".
  std::string type_name;                ///< e.g. "hullpipe::msg::CameraInfo".
  const dds_topic_descriptor_t* descriptor = nullptr;
  QosSpec qos;                          ///< The topic's QoS in hullpipe.
  bool keyed = false;
  /// Writes one zeroed (valid) sample with `writer` (used by the sertype probe).
  std::function<void(dds_entity_t writer)> write_probe;
  /// XCDR1 bytes of the fields appended to this @final type since recordings
  /// were first made of it (0: none). A recorded sample of the earlier layout
  /// is the new one's prefix: CdrWriter completes it with this many zeros (the
  /// appended fields' zero values, alignment included; then padding to a
  /// multiple of 4, as the header declares) when it does not deserialize as it
  /// is. CollisionReport: 24 (its hull velocity fields); VirtualObjectState: 31
  /// (7 of alignment and its box's half extents); ViewPose and CompositedView:
  /// 1 (the eye: VIEW_EYE_MONO); CameraImage: 16 (its region: none), after
  /// appended_alignment.
  size_t appended_bytes = 0;
  /// The appended fields' alignment (XCDR1, from the body's start): zeros pad
  /// the earlier layout's body to it before the appended_bytes. 1 where the
  /// earlier layout ends at a fixed offset (the counts above include that
  /// alignment); CameraImage: 4 (its uint32s after its data's bytes).
  size_t appended_alignment = 1;
  /// After those zeros, an empty string (the appended string field's empty
  /// value: length 1 and its NUL, in the sample's byte order, 4-aligned).
  /// VirtualMesh: its element key (read as an unnamed element).
  bool appended_empty_string = false;
};

/// Every topic of idl/hullpipe.idl.
const std::vector<KnownType>& KnownTypes();
/// The known type of that type name, or nullptr.
const KnownType* FindKnownType(const std::string& type_name);
/// The text of idl/hullpipe.idl as this build compiled it: every type's
/// definition. Recordings store it with each topic (record/recording.h).
const char* IdlText();

/// A reader of serialized samples of a known type, with the given QoS (depth is
/// the keep-last depth per instance).
class CdrReader : public Entity {
 public:
  CdrReader(const Participant& p, const KnownType& type, const QosSpec& qos);
  /// Takes every available sample; f(bytes, source_timestamp_ns) per valid one.
  /// Returns how many.
  size_t TakeEach(const std::function<void(const std::vector<uint8_t>&, int64_t)>& f) const;
  dds_entity_t condition() const { return condition_.handle(); }
  /// Samples lost before reaching this reader and samples it rejected (history
  /// or resource limits), since creation.
  uint64_t Lost() const;

 private:
  Entity topic_;
  Entity condition_;
};

/// A writer of serialized samples of a known type with the given QoS.
class CdrWriter : public Entity {
 public:
  /// kPublish: a writer on the domain. kDecodeOnly: no endpoint the domain can
  /// see (only the sertype probe's, on its private partition): for a process on
  /// a live domain that only decodes and encodes (hullpipe_bridge), so the
  /// pipeline never matches a writer that never writes. Write then throws
  /// std::logic_error and MatchedReaders is 0.
  enum class Scope { kPublish, kDecodeOnly };
  CdrWriter(const Participant& p, const KnownType& type, const QosSpec& qos, Scope scope = Scope::kPublish);
  ~CdrWriter();
  /// Publishes one serialized sample (CDR with its 4-byte header, as recorded).
  /// A sample of the type's earlier layout is completed first (KnownType::
  /// appended_bytes). Throws DdsError if Cyclone refuses it,
  /// std::invalid_argument if it is not XCDR1 (what hullpipe's writers send) or
  /// does not deserialize as this type.
  void Write(const std::vector<uint8_t>& cdr) const;
  uint32_t MatchedReaders() const;
  /// Deserializes a recorded sample of this writer's type into *sample (a
  /// zeroed struct of the type; its sequences/strings are allocated by Cyclone:
  /// free them with dds_sample_free(sample, descriptor, DDS_FREE_CONTENTS)).
  /// Returns false if the bytes are not a valid XCDR1 sample of the type (or of
  /// its earlier layout: KnownType::appended_bytes).
  bool Decode(const std::vector<uint8_t>& cdr, void* sample) const;
  /// Decodes `cdr` into a T (the idlc struct of this writer's type), calls
  /// f(const T&) and frees what Cyclone allocated; false (f not called) if it
  /// does not decode.
  template <typename T, typename F>
  bool DecodeWith(const std::vector<uint8_t>& cdr, F&& f) const {
    T m{};
    if (!Decode(cdr, &m)) return false;
    struct Free {
      const CdrWriter* w;
      T* m;
      ~Free() { dds_sample_free(m, w->descriptor_, DDS_FREE_CONTENTS); }
    } free_it{this, &m};
    f(static_cast<const T&>(m));
    return true;
  }
  /// Serializes a sample of this writer's type (the struct Decode fills) into
  /// CDR with its 4-byte header, as a recording stores it. Throws DdsError if
  /// Cyclone cannot serialize it.
  std::vector<uint8_t> Encode(const void* sample) const;

 private:
  // A serdata of the bytes, or of them completed to the current layout; nullptr
  // if neither deserializes.
  struct ddsi_serdata* FromSer(const std::vector<uint8_t>& cdr) const;
  Entity topic_;
  struct ddsi_sertype* sertype_ = nullptr;
  size_t appended_bytes_ = 0;
  size_t appended_alignment_ = 1;
  bool appended_empty_string_ = false;
  Scope scope_ = Scope::kPublish;
  const dds_topic_descriptor_t* descriptor_ = nullptr;
};

}  // namespace hullpipe::dds
