// The CAO reader's entry points, its loads (another file read, mapped and merged with its names
// prefixed) and the model built from what was read; the rows and sections are in cao_tokens.cpp
// and cao_sections.cpp.
#include "cfuse/importers/cao.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <optional>
#include <unordered_set>
#include <vector>

#include "cao_internal.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/so3.h"
#include "read_file.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

void RequireText(std::string_view text, const std::string& file) {
  if (text.find('\0') != std::string_view::npos) {
    throw InputError(SourceLocation(file), "not a CAO file: it holds binary data");
  }
  // Names go into model files and JSON, which are UTF-8.
  cfuse::RequireText(file, text, "CAO file");
}

std::string ReadCaoFile(const std::string& path, const SourceLocation& included_from) {
  return ReadImportedFile(path, included_from, "CAO", kMaxCaoFileBytes);
}

}  // namespace

namespace internal {

// `load("FILE", t=[x; y; z], tu=[x; y; z])`: ViSP separates the numbers with ';' (',' is
// accepted too) and lets each of tu's end with `deg` or `rad`.
void CaoReader::ReadLoad(const Row& row) {
  const std::string_view s = row.raw;
  size_t i = static_cast<size_t>(row.tokens[0].column - 1) + 4;  // after "load"
  auto fail = [&](size_t at, const std::string& message) {
    Fail(row.line, static_cast<int>(at) + 1, message);
  };
  auto skip = [&] {
    while (i < s.size() && IsBlank(s[i])) ++i;
  };
  auto found = [&]() -> std::string {
    if (i >= s.size()) return "the end of the line";
    size_t stop = i + 1;
    while (stop < s.size() && !IsBlank(s[stop])) ++stop;
    return "'" + Shown(s.substr(i, stop - i)) + "'";
  };
  skip();
  if (i >= s.size() || s[i] != '(') {
    fail(i, fmt::format("expected '(' after 'load', found {}: load(\"FILE.cao\", t=[x; y; z], "
                        "tu=[x; y; z])",
                        found()));
  }
  ++i;
  skip();
  if (i >= s.size() || s[i] != '"') {
    fail(i, fmt::format("expected the file name in double quotes, found {}", found()));
  }
  const size_t path_at = i;
  const size_t close = s.find('"', i + 1);
  if (close == std::string_view::npos) fail(i, "unterminated file name: no closing '\"'");
  const std::string relative(s.substr(i + 1, close - i - 1));
  if (relative.empty()) fail(i, "the file name is empty");
  i = close + 1;
  skip();

  Eigen::Vector3d t = Eigen::Vector3d::Zero(), tu = Eigen::Vector3d::Zero();
  std::unordered_set<std::string> seen;
  while (i < s.size() && s[i] == ',') {
    ++i;
    skip();
    const size_t key_at = i;
    while (i < s.size() && std::isalpha(static_cast<unsigned char>(s[i]))) ++i;
    const std::string key(s.substr(key_at, i - key_at));
    if (key != "t" && key != "tu") {
      i = key_at;
      fail(key_at, fmt::format("unknown load parameter {}: load takes t=[x; y; z] (metres) "
                               "and tu=[x; y; z] (a rotation vector, radians or deg)",
                               key.empty() ? found() : "'" + key + "'"));
    }
    if (!seen.insert(key).second) fail(key_at, fmt::format("'{}' given twice", key));
    skip();
    if (i >= s.size() || s[i] != '=') fail(i, fmt::format("expected '=' after '{}'", key));
    ++i;
    skip();
    if (i >= s.size() || s[i] != '[') fail(i, fmt::format("expected '[' after '{}='", key));
    ++i;
    Eigen::Vector3d& v = key == "t" ? t : tu;
    for (int k = 0; k < 3; ++k) {
      skip();
      const size_t length = NumberLength(s.substr(i));
      if (length == 0) {
        fail(i, fmt::format("expected a number in {}=[...], found {}", key, found()));
      }
      const std::optional<double> value = NumberValue(s.substr(i, length));
      if (!value) fail(i, fmt::format("number '{}' is out of range", s.substr(i, length)));
      v[k] = *value;
      i += length;
      skip();
      for (const char* unit : {"deg", "rad"}) {
        if (!StartsWith(s.substr(i), unit)) continue;
        if (key == "t") fail(i, "t is in metres: it takes no unit");
        if (unit[0] == 'd') v[k] *= M_PI / 180.0;
        i += 3;
        skip();
      }
      if (k < 2) {
        if (i >= s.size() || (s[i] != ';' && s[i] != ',')) {
          fail(i, fmt::format("{}=[...] needs 3 numbers separated by ';', found {}", key, found()));
        }
        ++i;
      }
    }
    if (i >= s.size() || s[i] != ']') {
      fail(i, fmt::format("expected ']' after the 3 numbers of {}=[...], found {}", key, found()));
    }
    // More than a whole turn is no rotation a writer means, and a norm that overflows none at
    // all (Exp would give NaN points).
    if (key == "tu" && !(tu.norm() <= 2 * M_PI + 1e-9)) {
      fail(key_at, fmt::format("tu=[...] turns by {:g} rad, more than a whole turn (2π): a "
                               "rotation vector's angle is at most 2π ('deg' marks degrees)",
                               tu.norm()));
    }
    ++i;
    skip();
  }
  if (i >= s.size() || s[i] != ')') {
    fail(i, fmt::format("expected ',' or ')' in load(...), found {}", found()));
  }
  ++i;
  skip();
  if (i < s.size() && s[i] != '#' && !StartsWith(s.substr(i), "//")) {
    fail(i, fmt::format("unexpected {} after load(...)", found()));
  }

  const SourceLocation where(file_, row.line, static_cast<int>(path_at) + 1);
  const std::string display = fs::path(relative).is_absolute()
                                  ? relative
                                  : (fs::path(base_dir_) / relative).lexically_normal().string();
  if (static_cast<int>(context_->open_canonical.size()) >= kMaxCaoLoadDepth) {
    throw InputError(where, fmt::format("loads nest more than {} files deep", kMaxCaoLoadDepth));
  }
  if (++context_->files_read > kMaxCaoFilesRead) {
    throw InputError(where,
                     fmt::format("the model loads more than {} files in all", kMaxCaoFilesRead));
  }
  std::error_code ec;
  const std::string canonical = fs::weakly_canonical(display, ec).string();
  for (size_t k = 0; k < context_->open_canonical.size(); ++k) {
    if (context_->open_canonical[k] != canonical) continue;
    std::string chain;
    for (size_t j = k; j < context_->open_display.size(); ++j) {
      chain += context_->open_display[j] + " -> ";
    }
    throw InputError(where, fmt::format("load cycle: {}{}", chain, display));
  }
  const std::string text = ReadCaoFile(display, where);
  context_->open_canonical.push_back(canonical);
  context_->open_display.push_back(display);
  Part loaded = CaoReader(context_, display, text, fs::path(display).parent_path().string()).Read();
  context_->open_canonical.pop_back();
  context_->open_display.pop_back();
  Merge(std::move(loaded), display, Rigid3d(Eigen::Matrix3d(ExpSO3<double>(tu)), t), where);
}

// Adds a loaded file's part, mapped into this file's frame, its names prefixed.
void CaoReader::Merge(Part loaded, const std::string& display, const Rigid3d& including_from_loaded,
                      const SourceLocation& where) {
  const std::string stem = fs::path(display).stem().string();
  std::string prefix = Identifier(stem) + "_";
  for (int k = 2; !prefixes_.insert(prefix).second; ++k) {
    prefix = fmt::format("{}_{}_", Identifier(stem), k);
  }
  auto clash = [&](const char* what, const std::string& name) {
    throw InputError(where, fmt::format("the {} '{}' from '{}' is already defined: rename the "
                                        "file to change its prefix",
                                        what, name, display));
  };
  const int offset = static_cast<int>(part_.points.size());
  for (FeaturePoint& p : loaded.points) {
    p.name = prefix + p.name;
    if (!point_names_.insert(p.name).second) clash("point", p.name);
    p.position = including_from_loaded * p.position;
    part_.points.push_back(std::move(p));
  }
  for (Edge& e : loaded.edges) {
    e.name = prefix + e.name;
    if (!edge_names_.insert(e.name).second) clash("edge", e.name);
    e.a += offset;
    e.b += offset;
    part_.edges.push_back(std::move(e));
  }
  for (Face& f : loaded.faces) {
    f.name = prefix + f.name;
    if (!face_names_.insert(f.name).second) clash("face", f.name);
    for (int& p : f.loop) p += offset;
    part_.faces.push_back(std::move(f));
  }
  RequireModelSize(where, fmt::format("with '{}' loaded, ", display));
}

}  // namespace internal

namespace {

ConstraintGraph Build(internal::Part part, const std::string& display_name) {
  const std::string stem = fs::path(display_name).stem().string();
  ModelBuilder builder(stem, display_name);
  const int c = builder.AddRigidComponent(internal::Identifier(stem), Rigid3d(),
                                          SourceLocation(display_name, 1, 1));
  for (const FeaturePoint& p : part.points) builder.AddFeaturePoint(c, p.name, p.position, p.where);
  for (const Edge& e : part.edges) builder.AddEdge(c, e.name, e.a, e.b, e.where);
  for (Face& f : part.faces) builder.AddFace(c, f.name, std::move(f.loop), f.where);
  return std::move(builder).Build();
}

}  // namespace

ConstraintGraph ImportCaoFromString(std::string_view text, const std::string& display_name,
                                    const std::string& base_directory) {
  RequireText(text, display_name);
  internal::LoadContext context;
  std::error_code ec;
  context.open_canonical.push_back(fs::weakly_canonical(display_name, ec).string());
  context.open_display.push_back(display_name);
  return Build(internal::CaoReader(&context, display_name, text, base_directory).Read(),
               display_name);
}

ConstraintGraph ImportCao(const std::string& path, const SourceLocation& included_from) {
  const std::string text = ReadCaoFile(path, included_from);
  return ImportCaoFromString(text, path, fs::path(path).parent_path().string());
}

}  // namespace cfuse
