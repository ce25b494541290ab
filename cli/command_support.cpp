#include "cli/command_support.h"

#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "dsl/measurement_reader.h"
#include "dsl/model_loader.h"
#include "importers/cao.h"
#include "importers/urdf.h"
#include "kernel/check.h"
#include "kernel/error.h"
#include "vision/camera_file.h"

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

dsl::LoadOptions ModelLoadOptions() {
  dsl::LoadOptions options;
  options.include_handlers[".urdf"] = [](const std::string& path, const SourceLocation& where) {
    return importers::ImportUrdf(path, where);
  };
  options.include_handlers[".cao"] = [](const std::string& path, const SourceLocation& where) {
    return importers::ImportCao(path, where);
  };
  return options;
}

ConstraintGraph LoadAnyModel(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".urdf") return importers::ImportUrdf(path);
  if (ext == ".cao") return importers::ImportCao(path);
  if (ext != ".yaml" && ext != ".yml") {
    throw InputError(SourceLocation(path),
                     fmt::format("unsupported model format '{}': model files are .yaml, .yml, "
                                 ".urdf or .cao",
                                 ext.empty() ? "(no extension)" : ext));
  }
  return dsl::LoadModel(path, ModelLoadOptions());
}

Camera LoadAnyCamera(const std::string& path) {
  if (vision::IsOpenCvStorage(path)) return vision::ReadOpenCvCamera(path);
  return dsl::ReadCameraFile(path);
}

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(SourceLocation(path),
                     fmt::format("cannot write: directory '{}' does not exist", dir.string()));
  }
  if (fs::is_directory(target, ec)) {
    throw InputError(SourceLocation(path), "cannot write: it is a directory");
  }
  const fs::path temp = dir / fmt::format(".{}.tmp{}", target.filename().string(), ::getpid());
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << content;
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      throw InputError(SourceLocation(path), "cannot write the file");
    }
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw InputError(SourceLocation(path), fmt::format("cannot write: {}", ec.message()));
  }
}

}  // namespace cfuse::cli
