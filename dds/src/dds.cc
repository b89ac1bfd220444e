#include "hullpipe/dds/dds.h"

#include <dds/ddsi/ddsi_serdata.h>

#include <pthread.h>
#include <signal.h>

#include <csignal>
#include <cstddef>
#include <cstring>
#include <mutex>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

namespace hullpipe::dds {

DdsError::DdsError(const std::string& call, dds_return_t code)
    : std::runtime_error(call + ": " + dds_strretcode(code)), code_(code) {}

dds_return_t Check(dds_return_t rc, const char* call) {
  if (rc < 0) throw DdsError(call, rc);
  return rc;
}

Entity::~Entity() {
  if (handle_ > 0) dds_delete(handle_);
}

Entity& Entity::operator=(Entity&& o) noexcept {
  if (this != &o) {
    if (handle_ > 0) dds_delete(handle_);
    handle_ = std::exchange(o.handle_, 0);
  }
  return *this;
}

Qos::Qos(const QosSpec& s, bool reader) : qos_(dds_create_qos()) {
  dds_qset_reliability(qos_, s.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_durability(qos_, s.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, s.depth);
  if (reader && !s.reliable && s.max_instances > 0 && s.depth > 0) {
    const int64_t samples = int64_t(s.max_instances) * s.depth;
    dds_qset_resource_limits(qos_, samples > INT32_MAX ? DDS_LENGTH_UNLIMITED : int32_t(samples), s.max_instances,
                             s.depth);
  }
}

Qos::~Qos() { dds_delete_qos(qos_); }

Participant::Participant(uint32_t domain_id)
    : Entity(Check(dds_create_participant(dds_domainid_t(domain_id), nullptr, nullptr),
                   "dds_create_participant")) {}

WaitSet::WaitSet(const Participant& p)
    : Entity(Check(dds_create_waitset(p.handle()), "dds_create_waitset")) {}

void WaitSet::AttachCondition(dds_entity_t condition) const {
  Check(dds_waitset_attach(handle(), condition, 0), "dds_waitset_attach");
}

void WaitSet::DetachCondition(dds_entity_t condition) const {
  Check(dds_waitset_detach(handle(), condition), "dds_waitset_detach");
}

GuardCondition::GuardCondition(const Participant& p)
    : Entity(Check(dds_create_guardcondition(p.handle()), "dds_create_guardcondition")) {}

void GuardCondition::Trigger() const { Check(dds_set_guardcondition(handle(), true), "dds_set_guardcondition"); }

bool GuardCondition::Take() const {
  bool was = false;
  Check(dds_take_guardcondition(handle(), &was), "dds_take_guardcondition");
  return was;
}

int WaitSet::Wait(double timeout_s) const {
  dds_attach_t xs[16];
  return int(Check(dds_waitset_wait(handle(), xs, 16, timeout_s > 0 ? dds_duration_t(timeout_s * 1e9) : 0),
                   "dds_waitset_wait"));
}

size_t TakeXcdr1(dds_entity_t reader, const dds_topic_descriptor_t* descriptor, size_t sample_size,
                 const char* topic, uint64_t* refused,
                 const std::function<void(const void*, const dds_sample_info_t&)>& f) {
  // One zeroed sample, made at the first sample taken (most polls take none),
  // refilled per sample and its contents freed after f.
  std::vector<std::max_align_t> storage;
  size_t taken = 0;
  for (;;) {
    struct ddsi_serdata* data[32] = {nullptr};
    dds_sample_info_t infos[32];
    const dds_return_t n = Check(dds_takecdr(reader, data, 32, infos, DDS_ANY_STATE), "dds_takecdr");
    struct Refs {  // drops the serdata references even if f throws
      struct ddsi_serdata** d;
      int32_t n;
      ~Refs() {
        for (int32_t i = 0; i < n; ++i)
          if (d[i]) ddsi_serdata_unref(d[i]);
      }
    } refs{data, n};
    for (int32_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      unsigned char header[4] = {0xff, 0xff, 0, 0};
      const size_t size = ddsi_serdata_size(data[i]);
      if (size >= 4) ddsi_serdata_to_ser(data[i], 0, 4, header);
      if (!IsXcdr1(header, size)) {
        if ((*refused)++ == 0)
          spdlog::warn("{}: refused a sample whose encapsulation {:02x} {:02x} is not XCDR1 (further ones are "
                       "counted)",
                       topic, header[0], header[1]);
        continue;
      }
      if (storage.empty())
        storage.resize((sample_size + sizeof(std::max_align_t) - 1) / sizeof(std::max_align_t));
      void* sample = storage.data();
      std::memset(sample, 0, sample_size);
      if (!ddsi_serdata_to_sample(data[i], sample, nullptr, nullptr)) {
        ++*refused;
        continue;
      }
      struct Contents {  // frees what deserializing allocated, even if f throws
        void* s;
        const dds_topic_descriptor_t* d;
        ~Contents() { dds_sample_free(s, d, DDS_FREE_CONTENTS); }
      } contents{sample, descriptor};
      f(sample, infos[i]);
      ++taken;
    }
    if (n < 32) break;
  }
  return taken;
}

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }
}  // namespace

bool StopRequested() { return g_stop.load(); }
void RequestStop() { g_stop.store(true); }
StopFlag StopRequestFlag() { return &g_stop; }

void InstallStopHandler() {
  static std::once_flag once;
  std::call_once(once, [] {
    // A handler for any thread that leaves the signals unblocked (one started
    // before this call)...
    struct sigaction sa = {};
    sa.sa_handler = OnSignal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    // ...and, for every thread started after it (DDS's, OpenCV's, the GL
    // driver's inherit this mask), delivery to one thread that waits for
    // nothing else. A signal the kernel hands to a thread parked in a raw
    // futex inside an uninstrumented library is otherwise held back by
    // ThreadSanitizer's deferred delivery until that thread wakes, which may
    // be never.
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) return;  // the handler alone still works
    std::thread([set] {
      for (;;) {
        int sig = 0;
        if (sigwait(&set, &sig) == 0) g_stop.store(true);
      }
    }).detach();
  });
}

}  // namespace hullpipe::dds
