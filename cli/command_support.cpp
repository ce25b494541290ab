#include "cli/command_support.h"

#include <fmt/format.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/importers/cao.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/importers/visp.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/camera_file.h"

namespace cfuse::cli {

namespace fs = std::filesystem;

// Runs a command, turning the error tiers into messages and exit statuses.
int Guarded(std::ostream& err, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    err << e.what() << "\n";
    return 2;
  } catch (const InternalError& e) {
    err << "cfuse: " << e.what() << "\n";
    return 3;
  } catch (const std::bad_alloc&) {
    err << "cfuse: error: out of memory\n";
    return 3;
  } catch (const std::exception& e) {
    err << "cfuse: internal error: " << e.what() << "\n";
    return 3;
  }
}

void RequireEdges(const ConstraintGraph& graph, const std::string& model_file,
                  const std::string& purpose) {
  if (ModelEdges(graph).empty()) {
    throw InputError(SourceLocation(model_file),
                     fmt::format("model '{}' has no edges to {} (give its components edges, or "
                                 "faces whose sides become edges)",
                                 graph.name, purpose));
  }
}

LoadOptions ModelLoadOptions() {
  LoadOptions options;
  options.include_handlers[".urdf"] = [](const std::string& path, const SourceLocation& where) {
    return ImportUrdf(path, where);
  };
  options.include_handlers[".cao"] = [](const std::string& path, const SourceLocation& where) {
    return ImportCao(path, where);
  };
  return options;
}

ConstraintGraph LoadAnyModel(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // Said first: a directory's name has no model extension, and "unsupported format" misleads.
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(SourceLocation(path), "is a directory, not a model file");
  }
  if (ext == ".urdf") return ImportUrdf(path);
  if (ext == ".cao") return ImportCao(path);
  if (ext != ".yaml" && ext != ".yml") {
    throw InputError(SourceLocation(path),
                     fmt::format("unsupported model format '{}': model files are .yaml, .yml, "
                                 ".urdf or .cao",
                                 ext.empty() ? "(no extension)" : ext));
  }
  return LoadModel(path, ModelLoadOptions());
}

namespace {

// Whether the file's first character, after a byte order mark and white space, is '<'.
bool LooksLikeXml(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(256, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  if (head.starts_with("\xEF\xBB\xBF")) head.erase(0, 3);
  const size_t start = head.find_first_not_of(" \t\r\n");
  return start != std::string::npos && head[start] == '<';
}

}  // namespace

Camera LoadAnyCamera(const std::string& path) {
  // ViSP's XML first: its roots (<conf>, <root>) are not OpenCV's <opencv_storage>.
  if (IsVispCameraFile(path)) return ReadVispCamera(path);
  if (IsOpenCvStorage(path)) return ReadOpenCvCamera(path);
  // Other XML: refused by the ViSP reader, which names the roots of the XML cameras cfuse reads
  // (the YAML reader would call it a malformed mapping).
  std::error_code ec;
  if (fs::is_regular_file(path, ec) && LooksLikeXml(path)) return ReadVispCamera(path);
  return ReadCameraFile(path);
}

void RequireWritable(const std::string& path) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(
        SourceLocation(path),
        fs::exists(dir, ec)
            ? fmt::format("cannot write: '{}' is not a directory", dir.string())
            : fmt::format("cannot write: directory '{}' does not exist", dir.string()));
  }
  if (fs::is_directory(target, ec)) {
    throw InputError(SourceLocation(path), "cannot write: it is a directory");
  }
}

OutputFiles::~OutputFiles() {
  std::error_code ec;
  for (const auto& [temp, target] : staged_) fs::remove(temp, ec);
}

void OutputFiles::Stage(const std::string& path, const std::string& content) {
  RequireWritable(path);
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  const fs::path temp =
      dir / fmt::format(".{}.tmp{}.{}", target.filename().string(), ::getpid(), staged_.size());
  std::ofstream out(temp, std::ios::binary | std::ios::trunc);
  // errno from the failed open says why (permission, read-only file system, ...).
  const int open_errno = out.is_open() ? 0 : errno;
  out << content;
  out.close();
  if (!out) {
    std::error_code ec;
    fs::remove(temp, ec);
    throw InputError(SourceLocation(path),
                     open_errno != 0 ? fmt::format("cannot write: {}", std::strerror(open_errno))
                                     : std::string("cannot write the file (is the disk full?)"));
  }
  staged_.emplace_back(temp.string(), path);
}

void OutputFiles::Commit() {
  for (size_t i = 0; i < staged_.size(); ++i) {
    std::error_code ec;
    fs::rename(staged_[i].first, staged_[i].second, ec);
    if (ec) {
      const std::string target = staged_[i].second;
      staged_.erase(staged_.begin(), staged_.begin() + static_cast<long>(i));  // renamed
      throw InputError(SourceLocation(target), fmt::format("cannot write: {}", ec.message()));
    }
  }
  staged_.clear();
}

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content) {
  OutputFiles files;
  files.Stage(path, content);
  files.Commit();
}

std::string JsonText(const nlohmann::json& json, int indent) {
  return json.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace cfuse::cli
