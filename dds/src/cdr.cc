#include "hullpipe/dds/cdr.h"

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>
#include <unistd.h>

#include <algorithm>
#include <stdexcept>
#include <thread>

#include "hullpipe/dds/topics.h"
#include "hullpipe_idl_text.h"

namespace hullpipe::dds {
namespace {

template <typename T>
void ZeroStrings(T&) {}
// Top-level strings must not be null on the wire.
void ZeroStrings(hullpipe_msg_NodeStats& s) { s.node_name = const_cast<char*>(""); }

template <typename T>
KnownType Make() {
  KnownType k;
  k.topic_name = TopicTraits<T>::kName;
  k.descriptor = TopicTraits<T>::Descriptor();
  k.type_name = k.descriptor->m_typename;
  k.qos = TopicTraits<T>::kQos;
  k.keyed = k.descriptor->m_nkeys > 0;
  k.write_probe = [](dds_entity_t writer) {
    T sample{};
    ZeroStrings(sample);
    Check(dds_write(writer, &sample), "dds_write (sertype probe)");
  };
  return k;
}

std::vector<KnownType> MakeKnownTypes() {
  std::vector<KnownType> types = {Make<hullpipe_msg_CameraInfo>(),      Make<hullpipe_msg_ObjectPixelMap>(),
                                  Make<hullpipe_msg_CameraImage>(),     Make<hullpipe_msg_ViewPose>(),
                                  Make<hullpipe_msg_HullView>(),        Make<hullpipe_msg_VirtualObjectState>(),
                                  Make<hullpipe_msg_CollisionReport>(), Make<hullpipe_msg_NodeStats>(),
                                  Make<hullpipe_msg_VirtualMesh>(),     Make<hullpipe_msg_SceneCommand>(),
                                  Make<hullpipe_msg_HeadPose>(),        Make<hullpipe_msg_ModelPart>(),
                                  Make<hullpipe_msg_ModelState>(),      Make<hullpipe_msg_CompositedView>(),
                                  Make<hullpipe_msg_CameraPose>(),      Make<hullpipe_msg_EyeViews>()};
  // Fields appended since the first recordings (idl/hullpipe.idl): the hull
  // velocity of CollisionReport, uint8 + 7 bytes of alignment + 2 doubles.
  // VirtualObjectState's box (7 bytes of alignment after its boolean, a Vec3)
  // and VirtualMesh's element key (a string). ViewPose's and CompositedView's
  // eye (a uint8 after a uint64: the serialized length then padded to 4).
  // CameraImage's region (four uint32s after its data's bytes).
  for (KnownType& t : types) {
    if (t.type_name == "hullpipe::msg::CollisionReport") t.appended_bytes = 24;
    if (t.type_name == "hullpipe::msg::VirtualObjectState") t.appended_bytes = 31;
    if (t.type_name == "hullpipe::msg::ViewPose" || t.type_name == "hullpipe::msg::CompositedView")
      t.appended_bytes = 1;
    if (t.type_name == "hullpipe::msg::VirtualMesh") t.appended_empty_string = true;
    if (t.type_name == "hullpipe::msg::CameraImage") {
      t.appended_bytes = 16;  // x, y, full_width, full_height: no region
      t.appended_alignment = 4;
    }
  }
  return types;
}

}  // namespace

const std::vector<KnownType>& KnownTypes() {
  static const std::vector<KnownType> types = MakeKnownTypes();
  return types;
}

const char* IdlText() { return kHullpipeIdlText; }

const KnownType* FindKnownType(const std::string& type_name) {
  for (const auto& k : KnownTypes())
    if (k.type_name == type_name) return &k;
  return nullptr;
}

CdrReader::CdrReader(const Participant& p, const KnownType& type, const QosSpec& qos)
    : topic_(Check(dds_create_topic(p.handle(), type.descriptor, type.topic_name.c_str(), nullptr, nullptr),
                   "dds_create_topic")) {
  Entity reader(Check(dds_create_reader(p.handle(), topic_.handle(), Qos(qos).get(), nullptr), "dds_create_reader"));
  static_cast<Entity&>(*this) = std::move(reader);
  condition_ = Entity(Check(dds_create_readcondition(handle(), DDS_ANY_STATE), "dds_create_readcondition"));
}

size_t CdrReader::TakeEach(const std::function<void(const std::vector<uint8_t>&, int64_t)>& f) const {
  size_t taken = 0;
  std::vector<uint8_t> bytes;
  for (;;) {
    struct ddsi_serdata* buf[32] = {nullptr};
    dds_sample_info_t si[32];
    const int32_t n = Check(dds_takecdr(handle(), buf, 32, si, DDS_ANY_STATE), "dds_takecdr");
    struct Unref {  // releases the serdata even if f throws
      struct ddsi_serdata** b;
      int32_t n;
      ~Unref() {
        for (int32_t i = 0; i < n; ++i) ddsi_serdata_unref(b[i]);
      }
    } unref{buf, n};
    for (int32_t i = 0; i < n; ++i) {
      if (!si[i].valid_data) continue;
      const uint32_t size = ddsi_serdata_size(buf[i]);
      bytes.resize(size);
      ddsi_serdata_to_ser(buf[i], 0, size, bytes.data());
      f(bytes, si[i].source_timestamp);
      ++taken;
    }
    if (n < 32) break;
  }
  return taken;
}

uint64_t CdrReader::Lost() const {
  dds_sample_lost_status_t lost;
  dds_sample_rejected_status_t rejected;
  Check(dds_get_sample_lost_status(handle(), &lost), "dds_get_sample_lost_status");
  Check(dds_get_sample_rejected_status(handle(), &rejected), "dds_get_sample_rejected_status");
  return uint64_t(lost.total_count) + uint64_t(rejected.total_count);
}

CdrWriter::CdrWriter(const Participant& p, const KnownType& type, const QosSpec& qos, Scope scope)
    : topic_(Check(dds_create_topic(p.handle(), type.descriptor, type.topic_name.c_str(), nullptr, nullptr),
                   "dds_create_topic")),
      appended_bytes_(type.appended_bytes),
      appended_alignment_(std::max<size_t>(1, type.appended_alignment)),
      appended_empty_string_(type.appended_empty_string),
      scope_(scope),
      descriptor_(type.descriptor) {
  if (scope == Scope::kPublish) {
    Entity writer(
        Check(dds_create_writer(p.handle(), topic_.handle(), Qos(qos).get(), nullptr), "dds_create_writer"));
    static_cast<Entity&>(*this) = std::move(writer);
  }
  // The sertype probe, on a partition no one else uses.
  const std::string partition = "hullpipe-sertype-probe-" + std::to_string(getpid());
  const char* parts[] = {partition.c_str()};
  dds_qos_t* pq = dds_create_qos();
  dds_qset_partition(pq, 1, parts);
  Entity pub(Check(dds_create_publisher(p.handle(), pq, nullptr), "dds_create_publisher"));
  Entity sub(Check(dds_create_subscriber(p.handle(), pq, nullptr), "dds_create_subscriber"));
  dds_delete_qos(pq);
  Qos probe_qos(QosSpec{true, false, 1});
  Entity pr(Check(dds_create_reader(sub.handle(), topic_.handle(), probe_qos.get(), nullptr), "dds_create_reader"));
  Entity pw(Check(dds_create_writer(pub.handle(), topic_.handle(), probe_qos.get(), nullptr), "dds_create_writer"));
  type.write_probe(pw.handle());
  for (int tries = 0; tries < 200 && !sertype_; ++tries) {
    struct ddsi_serdata* d = nullptr;
    dds_sample_info_t si;
    if (Check(dds_takecdr(pr.handle(), &d, 1, &si, DDS_ANY_STATE), "dds_takecdr") == 1) {
      sertype_ = ddsi_sertype_ref(d->type);
      ddsi_serdata_unref(d);
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  if (!sertype_) throw DdsError("sertype probe for " + type.topic_name, DDS_RETCODE_TIMEOUT);
  // Decode-only: the private publisher (and its probe writer) is all it owns.
  if (scope == Scope::kDecodeOnly) static_cast<Entity&>(*this) = std::move(pub);
}

CdrWriter::~CdrWriter() {
  if (sertype_) ddsi_sertype_unref(sertype_);
}

struct ddsi_serdata* CdrWriter::FromSer(const std::vector<uint8_t>& cdr) const {
  auto from = [&](const std::vector<uint8_t>& bytes) {
    ddsrt_iovec_t iov;
    iov.iov_base = const_cast<uint8_t*>(bytes.data());
    iov.iov_len = static_cast<ddsrt_iov_len_t>(bytes.size());
    return ddsi_serdata_from_ser_iov(sertype_, SDK_DATA, 1, &iov, bytes.size());
  };
  struct ddsi_serdata* d = from(cdr);
  if (d || (appended_bytes_ == 0 && !appended_empty_string_) || cdr.size() < 4) return d;
  // An earlier layout: its body (less the padding its header declares, the low
  // two bits of the options) with the appended fields' zeros after it.
  const size_t padding = cdr[3] & 3u;
  if (cdr.size() < 4 + padding) return nullptr;
  std::vector<uint8_t> completed(cdr.begin(), cdr.end() - std::ptrdiff_t(padding));
  completed[2] = completed[3] = 0;
  // Alignment is counted from the body, after the 4-byte header.
  while ((completed.size() - 4) % appended_alignment_ != 0) completed.push_back(0);
  completed.resize(completed.size() + appended_bytes_, 0);
  if (appended_empty_string_) {
    // Alignment is counted from the body, after the 4-byte header.
    while ((completed.size() - 4) % 4 != 0) completed.push_back(0);
    const bool little = (cdr[1] & 1u) != 0;  // CDR_LE 00 01, CDR_BE 00 00
    const uint8_t one_le[4] = {1, 0, 0, 0}, one_be[4] = {0, 0, 0, 1};
    completed.insert(completed.end(), little ? one_le : one_be, (little ? one_le : one_be) + 4);
    completed.push_back(0);  // the NUL
  }
  // The serialized length is a multiple of 4; the header says how much is padding.
  const size_t pad = (4 - (completed.size() - 4) % 4) % 4;
  completed.resize(completed.size() + pad, 0);
  completed[3] = uint8_t(pad);
  d = from(completed);
  if (!d) return nullptr;
  // Cyclone reads a sample with bytes left over: a current sample cut short
  // would pass, completed by zeros it never had. Only a sample that ends
  // exactly where the appended fields begin is of the earlier layout: its
  // completion serializes back to the same length.
  void* sample = dds_alloc(descriptor_->m_size);
  bool exact = ddsi_serdata_to_sample(d, sample, nullptr, nullptr);
  if (exact) {
    struct ddsi_serdata* again = ddsi_serdata_from_sample(sertype_, SDK_DATA, sample);
    exact = again && ddsi_serdata_size(again) == completed.size();
    if (again) ddsi_serdata_unref(again);
  }
  dds_sample_free(sample, descriptor_, DDS_FREE_ALL);
  if (!exact) {
    ddsi_serdata_unref(d);
    return nullptr;
  }
  return d;
}

void CdrWriter::Write(const std::vector<uint8_t>& cdr) const {
  if (scope_ == Scope::kDecodeOnly) throw std::logic_error("CdrWriter::Write on a decode-only writer");
  if (cdr.size() < 4) throw std::invalid_argument("CDR sample shorter than its header");
  if (!IsXcdr1(cdr.data(), cdr.size()))
    throw std::invalid_argument("CDR sample is not XCDR1 (encapsulation CDR_LE or CDR_BE)");
  struct ddsi_serdata* d = FromSer(cdr);
  if (!d) throw std::invalid_argument("CDR sample does not deserialize as its topic's type");
  Check(dds_writecdr(handle(), d), "dds_writecdr");  // takes the serdata's reference
}

bool CdrWriter::Decode(const std::vector<uint8_t>& cdr, void* sample) const {
  if (!IsXcdr1(cdr.data(), cdr.size())) return false;
  struct ddsi_serdata* d = FromSer(cdr);
  if (!d) return false;
  const bool ok = ddsi_serdata_to_sample(d, sample, nullptr, nullptr);
  ddsi_serdata_unref(d);
  return ok;
}

std::vector<uint8_t> CdrWriter::Encode(const void* sample) const {
  struct ddsi_serdata* d = ddsi_serdata_from_sample(sertype_, SDK_DATA, sample);
  if (!d) throw DdsError("ddsi_serdata_from_sample", DDS_RETCODE_BAD_PARAMETER);
  std::vector<uint8_t> out(ddsi_serdata_size(d));
  ddsi_serdata_to_ser(d, 0, out.size(), out.data());
  ddsi_serdata_unref(d);
  return out;
}

uint32_t CdrWriter::MatchedReaders() const {
  if (scope_ == Scope::kDecodeOnly) return 0;
  dds_publication_matched_status_t st;
  Check(dds_get_publication_matched_status(handle(), &st), "dds_get_publication_matched_status");
  return st.current_count;
}

}  // namespace hullpipe::dds
