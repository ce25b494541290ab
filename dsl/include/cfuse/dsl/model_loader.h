// Reading models written in the cfuse model DSL (YAML; grammar in docs/dsl.md).
//
//   ConstraintGraph graph = LoadModel("examples/lamp.yaml");
//
// Every problem with the file, from a YAML syntax error to a unit mismatch inside a
// constraint expression, is an InputError naming file:line:column. Included files are read
// recursively; files of other formats (a robot's URDF) are read by an include handler that the
// caller registers by extension, so that this library does not depend on the importers.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <string_view>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/error.h"

namespace cfuse {

// Reads the file at `path` into a graph; `where` is the include that asked for it.
using IncludeHandler =
    std::function<ConstraintGraph(const std::string& path, const SourceLocation& where)>;

struct LoadOptions {
  // By lower-case extension with the dot, e.g. ".urdf". ".yaml" and ".yml" are built in.
  std::map<std::string, IncludeHandler> include_handlers;
};

// Resource bounds on model files, refused with an InputError beyond them.
inline constexpr size_t kMaxModelFileBytes = 16u << 20;
inline constexpr int kMaxIncludeDepth = 16;
inline constexpr int kMaxIncludedFiles = 256;  // in all, counting repeated includes
// Model size limits (components, points, constraints) are ModelBuilder's.

ConstraintGraph LoadModel(const std::string& path, const LoadOptions& options = {});

// The same from text already in memory; `display_name` stands for the file in messages and
// relative includes resolve against `base_directory`.
ConstraintGraph LoadModelFromString(std::string_view text, const std::string& display_name,
                                    const std::string& base_directory,
                                    const LoadOptions& options = {});

}  // namespace cfuse
