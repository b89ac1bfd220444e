// The one wrapper of Cyclone DDS's C API in hullpipe. Error policy: every call
// whose return code is negative throws DdsError naming the call and the code's
// text. Entities are move-only RAII owners (deleted with dds_delete).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

#include <dds/dds.h>

#include "hullpipe/util/interrupt.h"

namespace hullpipe::dds {

/// A Cyclone call failed; what() is "<call>: <dds_strretcode>".
class DdsError : public std::runtime_error {
 public:
  DdsError(const std::string& call, dds_return_t code);
  dds_return_t code() const { return code_; }

 private:
  dds_return_t code_;
};

/// Returns rc, or throws DdsError(call, rc) if rc < 0.
dds_return_t Check(dds_return_t rc, const char* call);

/// Owns one DDS entity handle; deletes it (and its children) on destruction.
class Entity {
 public:
  Entity() = default;
  explicit Entity(dds_entity_t handle) : handle_(handle) {}
  ~Entity();
  Entity(const Entity&) = delete;
  Entity& operator=(const Entity&) = delete;
  Entity(Entity&& o) noexcept : handle_(std::exchange(o.handle_, 0)) {}
  Entity& operator=(Entity&& o) noexcept;
  dds_entity_t handle() const { return handle_; }

 private:
  dds_entity_t handle_ = 0;
};

/// QoS settings used by hullpipe's topics.
struct QosSpec {
  bool reliable = true;
  bool transient_local = false;
  int32_t depth = 1;  ///< keep-last depth
  /// A best-effort reader's bound on the instances (keys) it keeps, each of
  /// `depth` samples: a peer publishing under ever new keys (tracker ids)
  /// can then not grow the reader's cache without end; a sample of a new key
  /// past the bound is dropped. 0: no bound. Writers and reliable readers
  /// ignore it: past its bound a Cyclone reader of a reliable topic holds up
  /// the participant's whole receive path (docs/reliability.md).
  int32_t max_instances = 0;
};

/// Owns a dds_qos_t built from a QosSpec.
class Qos {
 public:
  /// For a best-effort reader (`reader` true) max_instances sets its resource
  /// limits: max_instances, depth samples per instance, their product in all.
  explicit Qos(const QosSpec& spec, bool reader = false);
  ~Qos();
  Qos(const Qos&) = delete;
  Qos& operator=(const Qos&) = delete;
  const dds_qos_t* get() const { return qos_; }

 private:
  dds_qos_t* qos_;
};

/// A domain participant. The domain's configuration comes from CYCLONEDDS_URI
/// (the launcher writes one that keeps traffic on loopback).
class Participant : public Entity {
 public:
  explicit Participant(uint32_t domain_id);
};

/// Per-message-type facts: descriptor, topic name and QoS (specialized in topics.h).
template <typename T>
struct TopicTraits;

/// Creates the topic of T in the participant (one topic entity per reader/writer).
template <typename T>
Entity CreateTopic(const Participant& p, const char* name = TopicTraits<T>::kName) {
  return Entity(Check(dds_create_topic(p.handle(), TopicTraits<T>::Descriptor(), name, nullptr, nullptr),
                      "dds_create_topic"));
}

/// A typed data writer of T with T's QoS.
template <typename T>
class Writer : public Entity {
 public:
  explicit Writer(const Participant& p) : Writer(p, CreateTopic<T>(p), TopicTraits<T>::kQos) {}
  /// On topic `name` with `qos` (a type published on many topics: ROS 2's
  /// per-camera topics, docs/ros2.md).
  Writer(const Participant& p, const std::string& name, const QosSpec& qos)
      : Writer(p, CreateTopic<T>(p, name.c_str()), qos) {}
  /// Publishes one sample (serialized by Cyclone; the sample is not kept).
  void Write(const T& sample) const { Check(dds_write(handle(), &sample), "dds_write"); }
  /// Number of matched readers right now.
  uint32_t MatchedReaders() const {
    dds_publication_matched_status_t st;
    Check(dds_get_publication_matched_status(handle(), &st), "dds_get_publication_matched_status");
    return st.current_count;
  }

 private:
  Writer(const Participant& p, Entity topic, const QosSpec& qos)
      : Entity(Check(dds_create_writer(p.handle(), topic.handle(), Qos(qos).get(), nullptr), "dds_create_writer")),
        topic_(std::move(topic)) {}
  Entity topic_;
};

/// Whether a serialized sample of `size` bytes starting with `header` (its first
/// 4 bytes, or fewer when size < 4) is XCDR1: encapsulation CDR_BE 00 00 or
/// CDR_LE 00 01, what hullpipe's writers send. Cyclone 0.10.2 (Debian 12) reads
/// past its buffer deserializing some XCDR2-marked samples of these @final
/// types (docs/reliability.md), so recorded bytes (CdrWriter) and live samples
/// (TakeXcdr1) with any other encapsulation are refused before Cyclone
/// deserializes them.
inline bool IsXcdr1(const unsigned char* header, size_t size) {
  return size >= 4 && header[0] == 0 && header[1] <= 1;
}

/// Takes every available sample of `reader` serialized (dds_takecdr, in batches
/// of 32), refuses any whose encapsulation is not XCDR1 (CDR_BE 00 00 or CDR_LE
/// 00 01: what hullpipe's writers send) before Cyclone deserializes it,
/// deserializes the rest into a zeroed sample of `sample_size` bytes and calls
/// f(sample, info) for each valid one. Cyclone 0.10.2 delivers an XCDR2-marked
/// sample from another process and reads it past its buffer as garbage
/// (docs/reliability.md). Refused samples are counted in *refused, with one
/// warning naming the topic the first time. Returns how many f saw.
size_t TakeXcdr1(dds_entity_t reader, const dds_topic_descriptor_t* descriptor, size_t sample_size,
                 const char* topic, uint64_t* refused,
                 const std::function<void(const void*, const dds_sample_info_t&)>& f);

/// A typed data reader of T with T's QoS, with a read condition for waitsets.
template <typename T>
class Reader : public Entity {
 public:
  explicit Reader(const Participant& p) : Reader(p, CreateTopic<T>(p), TopicTraits<T>::kQos, TopicTraits<T>::kName) {}
  /// On topic `name` with `qos`.
  Reader(const Participant& p, const std::string& name, const QosSpec& qos)
      : Reader(p, CreateTopic<T>(p, name.c_str()), qos, name) {}

  /// Takes every available sample and calls f(const T&, const dds_sample_info_t&)
  /// for each valid one (TakeXcdr1: a sample not in XCDR1 is refused, counted in
  /// refused(), never deserialized). Returns how many.
  template <typename F>
  size_t TakeEach(F&& f) const {
    return TakeXcdr1(handle(), TopicTraits<T>::Descriptor(), sizeof(T), name_.c_str(), &refused_,
                     [&](const void* s, const dds_sample_info_t& info) { f(*static_cast<const T*>(s), info); });
  }
  /// Samples refused for their encapsulation since creation.
  uint64_t refused() const { return refused_; }
  dds_entity_t condition() const { return condition_.handle(); }
  /// Number of matched writers right now.
  uint32_t MatchedWriters() const {
    dds_subscription_matched_status_t st;
    Check(dds_get_subscription_matched_status(handle(), &st), "dds_get_subscription_matched_status");
    return st.current_count;
  }

 private:
  Reader(const Participant& p, Entity topic, const QosSpec& qos, std::string name)
      : Entity(Check(dds_create_reader(p.handle(), topic.handle(), Qos(qos, /*reader=*/true).get(), nullptr),
                     "dds_create_reader")),
        topic_(std::move(topic)),
        condition_(Check(dds_create_readcondition(handle(), DDS_ANY_STATE), "dds_create_readcondition")),
        name_(std::move(name)) {}
  Entity topic_;
  Entity condition_;
  std::string name_;  // the topic's, for the refusal's warning
  mutable uint64_t refused_ = 0;
};

/// Waits for data on attached readers, with a timeout so stop requests are seen.
class WaitSet : public Entity {
 public:
  explicit WaitSet(const Participant& p);
  template <typename T>
  void Attach(const Reader<T>& r) const {
    Check(dds_waitset_attach(handle(), r.condition(), 0), "dds_waitset_attach");
  }
  /// Attaches or detaches a condition (a reader's read condition, a guard
  /// condition) by its handle. Throws DdsError.
  void AttachCondition(dds_entity_t condition) const;
  void DetachCondition(dds_entity_t condition) const;
  /// Blocks until some attached reader has data or timeout_s passes. Returns the
  /// number of triggered conditions (0 on timeout).
  int Wait(double timeout_s) const;
};

/// A guard condition of participant p's (dds_create_guardcondition): set by one
/// thread, it wakes a waitset another waits on. Throws DdsError.
class GuardCondition : public Entity {
 public:
  explicit GuardCondition(const Participant& p);
  /// Sets it (wakes the waitsets it is attached to until Take).
  void Trigger() const;
  /// Clears it; returns whether it was set.
  bool Take() const;
};

/// Process-wide stop request, set by SIGINT/SIGTERM once InstallStopHandler ran.
bool StopRequested();
void RequestStop();
/// The same request as a flag that core loops poll (util/interrupt.h).
StopFlag StopRequestFlag();
/// Makes SIGINT and SIGTERM call RequestStop: blocks both in the calling thread
/// (so in every thread it starts later) and takes them in one thread of its own
/// with sigwait; a handler covers threads started earlier. Call it before any
/// other thread starts (StartNode does); a second call does nothing. Child
/// processes must reset their signal mask (launch's Process does).
void InstallStopHandler();

}  // namespace hullpipe::dds
