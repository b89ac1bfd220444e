#include "hullpipe/models/model_import.h"
#include "hullpipe/util/bounded_child.h"

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <new>
#include <set>

#include <Eigen/Geometry>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "hullpipe/util/sanitized.h"

namespace hullpipe {

void ImportLimits::Check() const {
  if (max_file_bytes < 1) throw std::invalid_argument("ImportLimits.max_file_bytes must be >= 1");
  if (max_triangles < 1) throw std::invalid_argument("ImportLimits.max_triangles must be >= 1");
  if (max_parts < 1) throw std::invalid_argument("ImportLimits.max_parts must be >= 1");
  if (max_memory_bytes < (int64_t(64) << 20))
    throw std::invalid_argument("ImportLimits.max_memory_bytes must be >= 64 MiB");
  if (!(max_seconds >= 0.1 && max_seconds <= 3600))
    throw std::invalid_argument("ImportLimits.max_seconds must be in [0.1, 3600]");
}

int64_t ImportedModel::triangles() const {
  int64_t n = 0;
  for (const auto& p : parts) n += int64_t(p.triangles.size());
  return n;
}

namespace {

constexpr int kMaxDepth = 256;
constexpr unsigned kFlags = aiProcess_Triangulate | aiProcess_ValidateDataStructure;

std::string Mb(int64_t bytes) {
  if (bytes % (int64_t(1) << 30) == 0) return std::to_string(bytes >> 30) + " GiB";
  return std::to_string(bytes >> 20) + " MiB";
}

cv::Vec3b MaterialColour(const aiScene& scene, unsigned material) {
  if (material >= scene.mNumMaterials || !scene.mMaterials[material]) return {180, 180, 180};
  const aiMaterial& m = *scene.mMaterials[material];
  aiColor4D c(0.7f, 0.7f, 0.7f, 1.0f);
  if (m.Get(AI_MATKEY_BASE_COLOR, c) != AI_SUCCESS) m.Get(AI_MATKEY_COLOR_DIFFUSE, c);
  auto byte = [](float v) { return uint8_t(std::lround(255.0 * std::clamp(std::isfinite(v) ? v : 0.7f, 0.0f, 1.0f))); };
  return {byte(c.b), byte(c.g), byte(c.r)};
}

// Walks the node tree depth first, one part per node with triangles.
class PartBuilder {
 public:
  PartBuilder(const aiScene& scene, const std::string& file, const ImportLimits& limits, ImportedModel* out)
      : scene_(scene), file_(file), limits_(limits), out_(out) {}

  void Visit(const aiNode* node, const aiMatrix4x4& parent, int depth) {
    if (!node) return;
    if (depth > kMaxDepth) throw ModelError(file_ + ": node tree deeper than " + std::to_string(kMaxDepth) + " levels");
    if (!visited_.insert(node).second)
      throw ModelError(file_ + ": node '" + std::string(node->mName.C_Str()) + "' appears twice in the node tree");
    const aiMatrix4x4 world = parent * node->mTransformation;
    if (node->mNumMeshes > 0) AddPart(*node, world);
    for (unsigned c = 0; c < node->mNumChildren; ++c) Visit(node->mChildren[c], world, depth + 1);
  }

 private:
  void AddPart(const aiNode& node, const aiMatrix4x4& T) {
    // The node's name; where the file gives none (empty, or Assimp's made-up
    // glTF "nodes[N]"), its first mesh's name if that has one.
    std::string base = node.mName.C_Str();
    const bool made_up = base.empty() || base.rfind("nodes[", 0) == 0;
    if (made_up && node.mMeshes[0] < scene_.mNumMeshes && scene_.mMeshes[node.mMeshes[0]] &&
        scene_.mMeshes[node.mMeshes[0]]->mName.length > 0)
      base = scene_.mMeshes[node.mMeshes[0]]->mName.C_Str();
    if (base.empty()) base = "node" + std::to_string(unnamed_++);
    const int seen = ++names_[base];
    ImportedPart part;
    part.name = seen == 1 ? base : base + "#" + std::to_string(seen);
    size_t largest = 0;
    for (unsigned k = 0; k < node.mNumMeshes; ++k) {
      const unsigned mi = node.mMeshes[k];
      if (mi >= scene_.mNumMeshes || !scene_.mMeshes[mi])
        throw ModelError(file_ + ": node '" + part.name + "' refers to mesh " + std::to_string(mi) + " of " +
                         std::to_string(scene_.mNumMeshes));
      const aiMesh& mesh = *scene_.mMeshes[mi];
      ++out_->counts.meshes;
      const std::string where = file_ + ": node '" + part.name + "', mesh '" + mesh.mName.C_Str() + "'";
      const int base_index = int(part.vertices.size());
      if (int64_t(part.vertices.size()) + mesh.mNumVertices > 3 * limits_.max_triangles + 3)
        throw ModelError(where + ": more vertices than the triangle cap allows (" +
                         std::to_string(limits_.max_triangles) + " triangles)");
      for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D p = T * mesh.mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
          throw ModelError(where + ": vertex " + std::to_string(v) + " is not finite");
        part.vertices.emplace_back(p.x, p.y, p.z);
      }
      size_t kept = 0;
      for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices < 3) {
          ++out_->counts.lines_and_points;
          continue;
        }
        if (face.mNumIndices > 3)
          throw ModelError(where + ": face " + std::to_string(f) + " has " + std::to_string(face.mNumIndices) +
                           " corners after triangulation");
        Eigen::Vector3i t;
        for (int c = 0; c < 3; ++c) {
          if (face.mIndices[c] >= mesh.mNumVertices)
            throw ModelError(where + ": face " + std::to_string(f) + " index " + std::to_string(face.mIndices[c]) +
                             " out of range (" + std::to_string(mesh.mNumVertices) + " vertices)");
          t[c] = base_index + int(face.mIndices[c]);
        }
        const Eigen::Vector3d a = part.vertices[size_t(t[0])].cast<double>(),
                              b = part.vertices[size_t(t[1])].cast<double>(),
                              c = part.vertices[size_t(t[2])].cast<double>();
        const double edge2 = std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
        if (!((b - a).cross(c - a).norm() > 1e-12 * edge2)) {
          ++out_->counts.degenerate_triangles;
          continue;
        }
        if (++triangles_ > limits_.max_triangles)
          throw ModelError(file_ + ": more than " + std::to_string(limits_.max_triangles) +
                           " triangles (the triangle cap, models.max_triangles)");
        part.triangles.push_back(t);
        ++kept;
      }
      if (kept > largest) largest = kept, part.colour = MaterialColour(scene_, mesh.mMaterialIndex);
    }
    if (part.triangles.empty()) {
      ++out_->counts.empty_nodes;
      return;
    }
    // Keep only the vertices the kept triangles use.
    std::vector<int> remap(part.vertices.size(), -1);
    std::vector<Eigen::Vector3f> used;
    for (auto& t : part.triangles)
      for (int c = 0; c < 3; ++c) {
        int& r = remap[size_t(t[c])];
        if (r < 0) r = int(used.size()), used.push_back(part.vertices[size_t(t[c])]);
        t[c] = r;
      }
    part.vertices.swap(used);
    if (int64_t(out_->parts.size()) >= limits_.max_parts)
      throw ModelError(file_ + ": more than " + std::to_string(limits_.max_parts) +
                       " parts (nodes with meshes; the part cap: merge parts in the CAD tool)");
    out_->parts.push_back(std::move(part));
  }

  const aiScene& scene_;
  const std::string& file_;
  const ImportLimits& limits_;
  ImportedModel* out_;
  std::set<const aiNode*> visited_;
  std::map<std::string, int> names_;
  int unnamed_ = 0;
  int64_t triangles_ = 0;
};

// Assimp's warnings during one import. Some importers drop what they cannot
// use with a warning only (glTF faces whose indices are out of range): such a
// file is refused, not loaded with holes. Assimp's logger is global: imports
// in one process take turns.
class ImportWarnings {
 public:
  ImportWarnings() : lock_(Mutex()) {
    if (Assimp::DefaultLogger::isNullLogger()) Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
    stream_ = new Stream(&text_);
    Assimp::DefaultLogger::get()->attachStream(stream_, Assimp::Logger::Warn);
  }
  ~ImportWarnings() {
    Assimp::DefaultLogger::get()->detachStream(stream_, Assimp::Logger::Warn);
    delete stream_;
  }
  ImportWarnings(const ImportWarnings&) = delete;
  ImportWarnings& operator=(const ImportWarnings&) = delete;
  // Throws ModelError when a warning says data was dropped as invalid.
  void Check(const std::string& name) const {
    std::string line;
    for (const char* key : {"out-of-range", "out of range"}) {
      const size_t at = text_.find(key);
      if (at == std::string::npos) continue;
      const size_t begin = text_.rfind('\n', at), end = text_.find('\n', at);
      line = text_.substr(begin == std::string::npos ? 0 : begin + 1,
                          end == std::string::npos ? std::string::npos : end - begin - 1);
      const size_t colon = line.find(": ");
      if (colon != std::string::npos) line = line.substr(colon + 2);
      throw ModelError(name + ": indices out of range (Assimp: " + line + ")");
    }
  }

 private:
  struct Stream : Assimp::LogStream {
    explicit Stream(std::string* text) : text_(text) {}
    void write(const char* message) override {
      if (text_->size() < 65536) *text_ += message;
    }
    std::string* text_;
  };
  static std::mutex& Mutex() {
    static std::mutex m;
    return m;
  }
  std::lock_guard<std::mutex> lock_;
  std::string text_;
  Stream* stream_ = nullptr;
};

ImportedModel FromScene(const aiScene* scene, const Assimp::Importer& importer, const std::string& name,
                        const ImportLimits& limits) {
  if (!scene) {
    std::string why = importer.GetErrorString();
    if (why.empty()) why = "Assimp could not read it";
    throw ModelError(name + ": " + why);
  }
  if (!scene->mRootNode) throw ModelError(name + ": no node tree");
  ImportedModel model;
  model.path = name;
  PartBuilder(*scene, name, limits, &model).Visit(scene->mRootNode, aiMatrix4x4(), 0);
  if (model.parts.empty())
    throw ModelError(name + ": no triangles (" + std::to_string(model.counts.meshes) + " meshes, " +
                     std::to_string(model.counts.lines_and_points) + " line or point primitives, " +
                     std::to_string(model.counts.degenerate_triangles) + " degenerate triangles)");
  return model;
}

}  // namespace

std::string ModelFileExtension(const std::string& path) {
  const size_t dot = path.rfind('.');
  const size_t slash = path.rfind('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot + 1);
  for (char& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

ImportedModel ImportModelInProcess(const std::string& path, const ImportLimits& limits) {
  limits.Check();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw ModelError(path + ": cannot read (" + std::strerror(errno) + ")");
  if (!S_ISREG(st.st_mode)) throw ModelError(path + ": not a regular file");
  if (st.st_size == 0) throw ModelError(path + ": empty file");
  if (st.st_size > limits.max_file_bytes)
    throw ModelError(path + ": " + std::to_string(st.st_size) + " bytes, over the file size cap of " +
                     Mb(limits.max_file_bytes) + " (models.max_file_bytes)");
  Assimp::Importer importer;
  const std::string ext = ModelFileExtension(path);
  if (ext.empty() || !importer.IsExtensionSupported("." + ext))
    throw ModelError(path + ": '" + (ext.empty() ? std::string("(no extension)") : "." + ext) +
                     "' is not a format Assimp reads");
  ImportWarnings warnings;
  const aiScene* scene = importer.ReadFile(path, kFlags);
  warnings.Check(path);
  return FromScene(scene, importer, path, limits);
}

ImportedModel ImportModelFromMemory(const void* data, size_t size, const std::string& extension,
                                    const std::string& name, const ImportLimits& limits) {
  limits.Check();
  if (size == 0) throw ModelError(name + ": empty file");
  if (int64_t(size) > limits.max_file_bytes)
    throw ModelError(name + ": over the file size cap of " + Mb(limits.max_file_bytes));
  Assimp::Importer importer;
  ImportWarnings warnings;
  const aiScene* scene = importer.ReadFileFromMemory(data, size, kFlags, extension.c_str());
  warnings.Check(name);
  return FromScene(scene, importer, name, limits);
}

// ---- The child's result: "HPMODEL1", counts, then per part its name, colour,
// vertices and triangles; little-endian as this machine writes it (parent and
// child are the same binary).

namespace {

constexpr char kMagic[8] = {'H', 'P', 'M', 'O', 'D', 'E', 'L', '1'};

template <typename T>
void Put(std::string* s, const T& v) {
  s->append(reinterpret_cast<const char*>(&v), sizeof(T));
}

class Cursor {
 public:
  Cursor(const std::string& s, const std::string& name) : s_(s), name_(name) {}
  template <typename T>
  T Get() {
    Need(sizeof(T));
    T v;
    std::memcpy(&v, s_.data() + at_, sizeof(T));
    at_ += sizeof(T);
    return v;
  }
  void Need(uint64_t n) const {
    if (n > s_.size() - at_) throw ModelError(name_ + ": importer result cut short");
  }
  const char* Take(size_t n) {
    Need(n);
    const char* p = s_.data() + at_;
    at_ += n;
    return p;
  }
  bool done() const { return at_ == s_.size(); }

 private:
  const std::string& s_;
  const std::string& name_;
  size_t at_ = 0;
};

}  // namespace

std::string SerializeModel(const ImportedModel& m) {
  std::string s(kMagic, sizeof(kMagic));
  Put(&s, m.counts.meshes), Put(&s, m.counts.lines_and_points), Put(&s, m.counts.degenerate_triangles),
      Put(&s, m.counts.empty_nodes);
  Put(&s, uint64_t(m.parts.size()));
  for (const auto& p : m.parts) {
    Put(&s, uint64_t(p.name.size()));
    s += p.name;
    s.append(reinterpret_cast<const char*>(&p.colour[0]), 3);
    Put(&s, uint64_t(p.vertices.size()));
    for (const auto& v : p.vertices) Put(&s, v.x()), Put(&s, v.y()), Put(&s, v.z());
    Put(&s, uint64_t(p.triangles.size()));
    for (const auto& t : p.triangles) Put(&s, int32_t(t[0])), Put(&s, int32_t(t[1])), Put(&s, int32_t(t[2]));
  }
  return s;
}

ImportedModel DeserializeModel(const std::string& bytes, const std::string& name, const ImportLimits& limits) {
  Cursor c(bytes, name);
  if (std::memcmp(c.Take(sizeof(kMagic)), kMagic, sizeof(kMagic)) != 0)
    throw ModelError(name + ": importer result has a bad header");
  ImportedModel m;
  m.path = name;
  m.counts.meshes = c.Get<int64_t>(), m.counts.lines_and_points = c.Get<int64_t>();
  m.counts.degenerate_triangles = c.Get<int64_t>(), m.counts.empty_nodes = c.Get<int64_t>();
  const uint64_t parts = c.Get<uint64_t>();
  c.Need(parts);  // every part takes bytes: a count past them is a lie
  if (parts > uint64_t(limits.max_parts))
    throw ModelError(name + ": more than " + std::to_string(limits.max_parts) + " parts (the part cap)");
  int64_t triangles = 0;
  for (uint64_t k = 0; k < parts; ++k) {
    ImportedPart p;
    const uint64_t len = c.Get<uint64_t>();
    c.Need(len);
    p.name.assign(c.Take(size_t(len)), size_t(len));
    const char* col = c.Take(3);
    p.colour = cv::Vec3b(uint8_t(col[0]), uint8_t(col[1]), uint8_t(col[2]));
    const uint64_t nv = c.Get<uint64_t>();
    if (nv > bytes.size() / 12) throw ModelError(name + ": importer result cut short");
    c.Need(nv * 12);
    p.vertices.resize(size_t(nv));
    for (auto& v : p.vertices) {
      const float x = c.Get<float>(), y = c.Get<float>(), z = c.Get<float>();
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
        throw ModelError(name + ": part '" + p.name + "' has a non-finite vertex");
      v = {x, y, z};
    }
    const uint64_t nt = c.Get<uint64_t>();
    if (nt > bytes.size() / 12) throw ModelError(name + ": importer result cut short");
    c.Need(nt * 12);
    triangles += int64_t(nt);
    if (triangles > limits.max_triangles)
      throw ModelError(name + ": more than " + std::to_string(limits.max_triangles) + " triangles (the triangle cap)");
    p.triangles.resize(size_t(nt));
    for (auto& t : p.triangles) {
      for (int i = 0; i < 3; ++i) {
        const int32_t v = c.Get<int32_t>();
        if (v < 0 || uint64_t(v) >= nv) throw ModelError(name + ": part '" + p.name + "' has an index out of range");
        t[i] = v;
      }
    }
    if (p.triangles.empty()) throw ModelError(name + ": part '" + p.name + "' has no triangles");
    m.parts.push_back(std::move(p));
  }
  if (!c.done()) throw ModelError(name + ": importer result has trailing bytes");
  if (m.parts.empty()) throw ModelError(name + ": no triangles");
  return m;
}

// ---- The bounded child process.

namespace {

void WriteAll(int fd, const std::string& s) {
  size_t at = 0;
  while (at < s.size()) {
    const ssize_t n = ::write(fd, s.data() + at, s.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    at += size_t(n);
  }
}

// The child's work (RunBoundedChild has set its signals, parent death, CPU
// and core bounds): the memory bound, the import, its result on `fd`.
void RunChild(int fd, const std::string& path, const ImportLimits& limits) {
  // Bounds first: a crafted file may ask Assimp for gigabytes or loop.
#ifndef HULLPIPE_SANITIZED
  const rlimit mem{rlim_t(limits.max_memory_bytes), rlim_t(limits.max_memory_bytes)};
  ::setrlimit(RLIMIT_AS, &mem);
#endif
  std::string out;
  try {
    out = "K" + SerializeModel(ImportModelInProcess(path, limits));
  } catch (const ModelError& e) {
    out = std::string("E") + e.what();
  } catch (const std::bad_alloc&) {
    out = "M";
  } catch (const std::exception& e) {
    out = "E" + path + ": " + e.what();
  }
  WriteAll(fd, out);
}

}  // namespace

bool ImportBoundsMemory() {
#ifdef HULLPIPE_SANITIZED
  return false;
#else
  return true;
#endif
}

ImportedModel ImportModel(const std::string& path, const ImportLimits& limits) {
  limits.Check();
  // The result is bounded as the import is: vertices and indices of at most
  // max_triangles triangles, plus names.
  const uint64_t max_bytes = (uint64_t(16) << 20) + uint64_t(limits.max_triangles) * 48;
  BoundedChildResult child;
  try {
    child = RunBoundedChild([&](int fd) { RunChild(fd, path, limits); }, int(std::ceil(limits.max_seconds)),
                            limits.max_seconds + 1.0, max_bytes, limits.stop);
  } catch (const std::runtime_error& e) {
    throw ModelError(path + ": cannot start the importer (" + e.what() + ")");
  }
  if (child.interrupted) throw Interrupted(path + ": import interrupted by a stop request");
  const int status = child.status;
  const std::string& got = child.output;
  if (child.timed_out)
    throw ModelError(path + ": did not finish within the " + std::to_string(int(std::ceil(limits.max_seconds))) +
                     " s time bound (models.max_import_seconds)");
  if (child.output_over)
    throw ModelError(path + ": the importer's result exceeds " + std::to_string(max_bytes >> 20) + " MiB");
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (sig == SIGXCPU || sig == SIGKILL)
      throw ModelError(path + ": the importer exceeded its " + std::to_string(int(std::ceil(limits.max_seconds))) +
                       " s CPU time bound (models.max_import_seconds)");
    throw ModelError(path + ": the importer crashed on this file (signal " + std::to_string(sig) + ", " +
                     strsignal(sig) + ")");
  }
  if (got.empty())
    throw ModelError(path + ": the importer ended without a result (exit " + std::to_string(WEXITSTATUS(status)) + ")");
  if (got[0] == 'M')
    throw ModelError(path + ": the importer exceeded the " + Mb(limits.max_memory_bytes) +
                     " memory bound (models.max_import_memory)");
  if (got[0] == 'E') {
    std::string why = got.substr(1);
    if (why.find("bad_alloc") != std::string::npos)
      throw ModelError(path + ": the importer exceeded the " + Mb(limits.max_memory_bytes) +
                       " memory bound (models.max_import_memory)");
    throw ModelError(why);
  }
  if (got[0] != 'K') throw ModelError(path + ": the importer's result is malformed");
  return DeserializeModel(got.substr(1), path, limits);
}

}  // namespace hullpipe
