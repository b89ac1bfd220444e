// Reading a lab's CAD model (paper §5: the engine whose oil filter a user
// reaches, the payload's PMT from subcontractors) through Assimp, into parts
// hullpipe can collide with and draw. A part is one node of the file's node
// tree that holds meshes: its meshes' triangles with the transforms down the
// tree applied, named by the node. Units stay the file's here (model_scene.h
// scales them); vertices are in the file's root frame.
//
// Files come from outside: Assimp can be made to crash, loop or allocate
// gigabytes by a crafted file, so ImportModel runs the importer in a child
// process under a memory, CPU-time and wall-clock bound and reads its result
// back through a pipe, bounded again (docs/models.md, "Bad files").
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "hullpipe/util/interrupt.h"

namespace hullpipe {

/// A model file that cannot be used: the message names the file (and the node
/// or mesh where it applies) and what is wrong, one line.
class ModelError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bounds on one import (docs/models.md lists them beside the scene keys).
struct ImportLimits {
  int64_t max_file_bytes = int64_t(256) << 20;  ///< Larger files are refused unread (256 MiB).
  int64_t max_triangles = 5'000'000;            ///< Triangles kept, all parts together.
  int64_t max_memory_bytes = int64_t(4) << 30;  ///< The importer's address space (4 GiB).
  double max_seconds = 60;                      ///< The importer's CPU time and wall clock.
  /// Parts (nodes with meshes), all a model's: each is a BVH, a wire sample
  /// and a row of reports every frameset, so 200,000 one-triangle parts (a
  /// 4-MB glTF under every other cap) cost sim_node 4 GB and 19 s a step.
  int64_t max_parts = 4096;
  /// ImportModel ends the importer and throws Interrupted within 0.2 s of this
  /// flag being set (the node's SIGINT flag); nullptr: never.
  StopFlag stop = nullptr;
  /// Throws std::invalid_argument naming the bad field.
  void Check() const;
};

/// One part of a model (one node with meshes), in the file's units and root frame.
struct ImportedPart {
  std::string name;                         ///< The node's name (made unique: "name#2").
  std::vector<Eigen::Vector3f> vertices;    ///< File units, root frame.
  std::vector<Eigen::Vector3i> triangles;   ///< Indices into vertices, CCW seen from outside.
  cv::Vec3b colour{180, 180, 180};          ///< BGR: the base colour of its largest mesh's material.
};

/// What was left out of a file, counted (docs/models.md, "What real files hold").
struct ImportCounts {
  int64_t meshes = 0;                ///< Meshes placed by nodes (a mesh placed twice counts twice).
  int64_t lines_and_points = 0;      ///< Line and point primitives: not surfaces, skipped.
  int64_t degenerate_triangles = 0;  ///< Zero-area triangles, skipped.
  int64_t empty_nodes = 0;           ///< Nodes whose meshes gave no triangle.
};

/// A model as imported.
struct ImportedModel {
  std::string path;
  std::vector<ImportedPart> parts;  ///< In node-tree order (depth first).
  ImportCounts counts;
  int64_t triangles() const;
};

/// A model file's extension, lower case, without the dot ("glb"); "" when it
/// has none. Assimp picks the reader by it; scenes pick default units and up.
std::string ModelFileExtension(const std::string& path);

/// Imports `path` in this process (the child's work in ImportModel; tests and
/// the fuzzer). Throws ModelError naming the file: unreadable, over
/// max_file_bytes, a format Assimp does not read, a file Assimp refuses (its
/// message), indices out of range or non-finite vertices (naming node and
/// mesh), a node tree deeper than 256 or revisiting a node, no triangle at
/// all, more than max_triangles.
ImportedModel ImportModelInProcess(const std::string& path, const ImportLimits& limits = {});

/// The same from bytes in memory; `extension` ("glb", "stl") tells Assimp the
/// format. `name` is used in messages in place of a path.
ImportedModel ImportModelFromMemory(const void* data, size_t size, const std::string& extension,
                                    const std::string& name, const ImportLimits& limits = {});

/// Imports `path` in a child process bounded by `limits` (memory as address
/// space, CPU time, wall clock; the result's size by max_triangles). Call it
/// while this process has one thread (a scene is loaded before DDS starts).
/// Throws ModelError naming the file and, when a bound stops the importer,
/// which bound ("exceeded the 4 GiB memory bound"), or the signal that ended it.
ImportedModel ImportModel(const std::string& path, const ImportLimits& limits = {});

/// Whether ImportModel bounds the child's memory: false in sanitizer builds,
/// whose shadow memory leaves no room for an address-space limit (the CPU
/// time and wall clock bounds still hold).
bool ImportBoundsMemory();

/// The child's result on the pipe: a versioned binary layout.
std::string SerializeModel(const ImportedModel& model);
/// Reads SerializeModel's bytes back. Throws ModelError (naming `name`) on any
/// inconsistency: truncated, counts past the bytes or past max_triangles,
/// indices out of range, non-finite vertices.
ImportedModel DeserializeModel(const std::string& bytes, const std::string& name, const ImportLimits& limits = {});

}  // namespace hullpipe
