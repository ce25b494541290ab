// What every command shares: the error tiers turned into messages and exit statuses, model
// files of any supported format, and files written whole or not at all.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera.h"

namespace cfuse::cli {

// Runs a command: InputError -> its message, status 2; InternalError and anything unexpected
// -> "cfuse: ..." and status 3; otherwise the body's status.
int Guarded(std::ostream& err, const std::function<int()>& body);

// body(), its InputErrors without a location placed at `file`: a library refuses input that it
// holds in memory (a camera, an image) without knowing the file it came from.
template <typename Body>
auto AtFile(const std::string& file, Body&& body) -> decltype(body()) {
  try {
    return body();
  } catch (const InputError& e) {
    if (e.where().known()) throw;
    throw InputError(SourceLocation(file), e.message());
  }
}

// A model from a file, by its extension: .yaml/.yml (the DSL, whose `include:` reads .urdf
// and .cao files too), .urdf (cfuse/importers/urdf.h) or .cao (cfuse/importers/cao.h).
ConstraintGraph LoadAnyModel(const std::string& path);

// A camera from a file of any supported format (docs/formats.md "Cameras"): ViSP's XML (tracker
// settings or vpXmlParserCamera, cfuse/importers/visp.h, recognised by the root element <conf> or
// <root>), an OpenCV FileStorage calibration (cfuse/vision/camera_file.h, recognised by its first
// bytes), else cfuse's camera object or a ROS camera_info YAML (cfuse/dsl/measurement_reader.h). A
// ViSP camera may have no image size (width and height 0): each command says what it takes
// instead, or refuses it.
Camera LoadAnyCamera(const std::string& path);

// Refuses an output path that cannot be written: its directory missing (or not a directory),
// or the path itself a directory. Commands check every output first, before their work, so that
// a bad second output neither wastes the work nor leaves the first one written.
void RequireWritable(const std::string& path);

// An InputError at `model_file` when the model has no edges: "model 'NAME' has no edges to
// PURPOSE (give its components edges, ...)". The image commands' models need them.
void RequireEdges(const ConstraintGraph& graph, const std::string& model_file,
                  const std::string& purpose);

// A command's output files, written all or none: Stage() writes each to a temporary file beside
// its target, Commit() renames them all into place; whatever is not committed is removed.
class OutputFiles {
 public:
  OutputFiles() = default;
  OutputFiles(const OutputFiles&) = delete;
  OutputFiles& operator=(const OutputFiles&) = delete;
  ~OutputFiles();

  void Stage(const std::string& path, const std::string& content);
  void Commit();

 private:
  std::vector<std::pair<std::string, std::string>> staged_;  // (temporary, target)
};

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content);

// JSON text; a string that is not UTF-8 (a model named after a Latin-1 file name) has its bad
// bytes replaced by U+FFFD instead of making nlohmann::json throw.
std::string JsonText(const nlohmann::json& json, int indent);

}  // namespace cfuse::cli
