#include "hullpipe/dds/dds.h"

#include <csignal>

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

Qos::Qos(const QosSpec& s) : qos_(dds_create_qos()) {
  dds_qset_reliability(qos_, s.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_durability(qos_, s.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos_, DDS_HISTORY_KEEP_LAST, s.depth);
}

Qos::~Qos() { dds_delete_qos(qos_); }

Participant::Participant(uint32_t domain_id)
    : Entity(Check(dds_create_participant(dds_domainid_t(domain_id), nullptr, nullptr),
                   "dds_create_participant")) {}

WaitSet::WaitSet(const Participant& p)
    : Entity(Check(dds_create_waitset(p.handle()), "dds_create_waitset")) {}

int WaitSet::Wait(double timeout_s) const {
  dds_attach_t xs[16];
  return int(Check(dds_waitset_wait(handle(), xs, 16, timeout_s > 0 ? dds_duration_t(timeout_s * 1e9) : 0),
                   "dds_waitset_wait"));
}

namespace {
std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop.store(true); }
}  // namespace

bool StopRequested() { return g_stop.load(); }
void RequestStop() { g_stop.store(true); }
StopFlag StopRequestFlag() { return &g_stop; }

void InstallStopHandler() {
  struct sigaction sa = {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

}  // namespace hullpipe::dds
