// The CAO reader's sections: points, lines, faces from lines and from points (named, each face
// checked for one closed loop and an area), then the refused cylinders and circles.
#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "cao_internal.h"
#include "cfuse/importers/cao.h"

namespace cfuse::internal {
namespace {

// The sections after the header and the loads, in file order.
constexpr Section kPoints{"3D points", "points"};
constexpr Section kLines{"3D lines", "lines"};
constexpr Section kFacesFromLines{"faces from 3D lines", "faces"};
constexpr Section kFacesFromPoints{"faces from 3D points", "faces"};
constexpr Section kCylinders{"3D cylinders", "cylinders"};
constexpr Section kCircles{"3D circles", "circles"};

// An edge key that ignores direction.
uint64_t Key(int a, int b) {
  return (static_cast<uint64_t>(std::min(a, b)) << 32) | static_cast<uint32_t>(std::max(a, b));
}

// `preferred` if free, else preferred_2, preferred_3, ...; taken into `used`.
std::string Unique(const std::string& preferred, std::unordered_set<std::string>* used) {
  std::string name = preferred;
  for (int k = 2; !used->insert(name).second; ++k) name = fmt::format("{}_{}", preferred, k);
  return name;
}

// Each row's explicit name if no other row of the section has it and nothing loaded took
// it, else `<automatic><number>`.
std::vector<std::string> Names(const std::vector<std::optional<std::string>>& given,
                               const std::vector<int>& numbers, const char* automatic,
                               std::unordered_set<std::string>* used) {
  std::unordered_map<std::string, int> count;
  for (const auto& name : given) {
    if (name) ++count[*name];
  }
  std::vector<std::string> names(given.size());
  for (size_t k = 0; k < given.size(); ++k) {
    if (given[k] && count[*given[k]] == 1 && used->insert(*given[k]).second) {
      names[k] = *given[k];
    }
  }
  for (size_t k = 0; k < given.size(); ++k) {
    if (names[k].empty()) names[k] = Unique(fmt::format("{}{}", automatic, numbers[k]), used);
  }
  return names;
}

}  // namespace

Part CaoReader::Read() {
  const Row* header = Next();
  if (!header) Fail(1, 1, "not a CAO file: it is empty; expected the header 'V1'");
  const Token& v = header->tokens[0];
  if (v.text != "V1") {
    if (v.text.size() > 1 && v.text[0] == 'V' && NonNegativeInteger(v.text.substr(1))) {
      Fail(
          *header, v,
          fmt::format("unsupported CAO version '{}': cfuse reads version 1 ('V1')", Shown(v.text)));
    }
    Fail(*header, v,
         fmt::format("not a CAO file: expected the header 'V1', found '{}'", Shown(v.text)));
  }
  NothingMore(*header, 1, "after the header 'V1'");

  int loads = 0;
  while (Peek() && StartsWith(Peek()->tokens[0].text, "load")) {
    ReadLoad(*Next());
    ++loads;
  }
  if (!Peek() && loads > 0) return std::move(part_);  // an assembly of loaded parts only

  ReadPoints(loads > 0);
  ReadLines();
  ReadFacesFromLines();
  ReadFacesFromPoints();
  // Files written before ViSP knew cylinders and circles end here.
  for (const Section* s : {&kCylinders, &kCircles}) {
    const Row* row = Next();
    if (!row) break;
    if (Count(*row, *s, std::numeric_limits<int64_t>::max()) > 0) {
      Fail(*row, row->tokens[0],
           fmt::format("{} are not supported: this file declares {}; cfuse reads points, lines "
                       "and faces (set the count to 0, or describe the shape with points and "
                       "faces)",
                       s->rows, Shown(row->tokens[0].text)));
    }
  }
  if (const Row* row = Next()) {
    Fail(*row, row->tokens[0],
         fmt::format("unexpected '{}' after the last section ({})", Shown(row->tokens[0].text),
                     kCircles.name));
  }
  return std::move(part_);
}

void CaoReader::RequireModelSize(const SourceLocation& where, const std::string& context) const {
  const std::tuple<const char*, size_t, int> sizes[] = {
      {"points", part_.points.size(), kMaxCaoPoints},
      {"edges", part_.edges.size(), kMaxCaoEdges},
      {"faces", part_.faces.size(), kMaxCaoFaces}};
  for (const auto& [what, size, limit] : sizes) {
    if (size > static_cast<size_t>(limit)) {
      throw InputError(where, fmt::format("{}the model has more than {} {}", context, limit, what));
    }
  }
}

void CaoReader::ReadPoints(bool loaded_some) {
  const Row* count_row = Next();
  if (!count_row) {
    Fail(end_line_, end_column_,
         "the file ends before the 3D points section: expected the number of 3D points");
  }
  const int n = static_cast<int>(Count(*count_row, kPoints, kMaxCaoPoints));
  if (n == 0 && !loaded_some) {
    Fail(*count_row, count_row->tokens[0],
         "the model has no points: the number of 3D points is 0 and nothing is loaded");
  }
  first_point_ = static_cast<int>(part_.points.size());
  for (int k = 0; k < n; ++k) {
    const Row& row = SectionRow(kPoints, n, k);
    if (row.tokens.size() < 3) {
      Fail(row.line, row.tokens.back().end(),
           fmt::format("a 3D point needs 3 numbers (X Y Z), found {}", row.tokens.size()));
    }
    Eigen::Vector3d p;
    for (int j = 0; j < 3; ++j) p[j] = Number(row, row.tokens[j]);
    NothingMore(row, 3, "after the 3 coordinates of the point");
    const std::string name = fmt::format("p{}", k);
    point_names_.insert(name);
    part_.points.push_back({name, p, Where(row)});
  }
  RequireModelSize(Where(*count_row), "");
}

void CaoReader::ReadLines() {
  const Row* count_row = Next();
  if (!count_row) {
    Fail(end_line_, end_column_,
         "the file ends before the 3D lines section: expected the number of 3D lines");
  }
  const int n = static_cast<int>(Count(*count_row, kLines, kMaxCaoEdges));
  std::unordered_set<uint64_t> seen;
  for (int k = 0; k < n; ++k) {
    const Row& row = SectionRow(kLines, n, k);
    if (row.tokens.size() < 2) {
      Fail(row.line, row.tokens.back().end(),
           fmt::format("a 3D line needs 2 point indices, found {}", row.tokens.size()));
    }
    const int a = Index(row, row.tokens[0], "point", OwnPoints());
    const int b = Index(row, row.tokens[1], "point", OwnPoints());
    if (a == b) {
      Fail(row, row.tokens[1],
           fmt::format("a 3D line joins two different points, found point {} twice", a));
    }
    LineRow line;
    line.a = first_point_ + a;
    line.b = first_point_ + b;
    line.name = Parameters(row, 2, "after the 2 point indices of the line");
    line.where = Where(row);
    line.duplicate = !seen.insert(Key(line.a, line.b)).second;
    lines_.push_back(std::move(line));
  }
  // A line repeating an earlier one's two points adds nothing; l<i> counts every row.
  std::vector<const LineRow*> kept;
  std::vector<std::optional<std::string>> given;
  std::vector<int> numbers;
  for (size_t k = 0; k < lines_.size(); ++k) {
    if (lines_[k].duplicate) continue;
    kept.push_back(&lines_[k]);
    given.push_back(lines_[k].name);
    numbers.push_back(static_cast<int>(k));
  }
  const std::vector<std::string> names = Names(given, numbers, "l", &edge_names_);
  for (size_t k = 0; k < kept.size(); ++k) {
    own_edges_.insert(Key(kept[k]->a, kept[k]->b));
    part_.edges.push_back({names[k], kept[k]->a, kept[k]->b, kept[k]->where});
  }
  RequireModelSize(Where(*count_row), "");
}

// The points of a face given by lines: walking the lines from the first one's start, in its
// direction, through the points they share. Each point must be on exactly two of them.
std::vector<int> CaoReader::Walk(const Row& row, const std::vector<int>& face_lines) const {
  const int n = static_cast<int>(face_lines.size());
  std::unordered_map<int, std::vector<int>> on;  // point -> positions in face_lines
  for (int j = 0; j < n; ++j) {
    on[lines_[face_lines[j]].a].push_back(j);
    on[lines_[face_lines[j]].b].push_back(j);
  }
  const char* kNotLoop = "the face's lines do not form one closed loop: ";
  for (int j = 0; j < n; ++j) {
    for (int p : {lines_[face_lines[j]].a, lines_[face_lines[j]].b}) {
      const size_t lines_on = on[p].size();
      if (lines_on == 1) {
        Fail(row, row.tokens[1 + j],
             fmt::format("{}point {} ends line {} and no other line of the face", kNotLoop,
                         p - first_point_, face_lines[j]));
      }
      if (lines_on > 2) {
        Fail(row, row.tokens[1 + j],
             fmt::format("{}point {} is on {} of its lines", kNotLoop, p - first_point_, lines_on));
      }
    }
  }
  std::vector<bool> used(n, false);
  used[0] = true;
  std::vector<int> loop = {lines_[face_lines[0]].a};
  int at = lines_[face_lines[0]].b, previous = 0;
  while (at != loop[0]) {
    loop.push_back(at);
    const std::vector<int>& two = on[at];
    const int next = two[0] == previous ? two[1] : two[0];
    used[next] = true;
    const LineRow& l = lines_[face_lines[next]];
    at = l.a == at ? l.b : l.a;
    previous = next;
  }
  for (int j = 0; j < n; ++j) {
    if (!used[j]) {
      Fail(row, row.tokens[1 + j],
           fmt::format("{}line {} is not on the loop through line {}", kNotLoop, face_lines[j],
                       face_lines[0]));
    }
  }
  return loop;
}

// Refuses faces without area: coincident neighbours, or every point on one line.
void CaoReader::CheckArea(const Row& row, const std::vector<int>& loop) const {
  Eigen::Vector3d lo = part_.points[loop[0]].position, hi = lo;
  for (int p : loop) {
    lo = lo.cwiseMin(part_.points[p].position);
    hi = hi.cwiseMax(part_.points[p].position);
  }
  const double size = (hi - lo).norm();
  // Relative to the first point, so that a face far from the origin loses no digits.
  const Eigen::Vector3d origin = part_.points[loop[0]].position;
  Eigen::Vector3d newell = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < loop.size(); ++k) {
    const int a = loop[k], b = loop[(k + 1) % loop.size()];
    const Eigen::Vector3d pa = part_.points[a].position - origin;
    const Eigen::Vector3d pb = part_.points[b].position - origin;
    if ((pa - pb).norm() <= 1e-12 * size) {
      Fail(row, row.tokens[0],
           fmt::format("degenerate face: points {} and {} coincide", a - first_point_,
                       b - first_point_));
    }
    newell += pa.cross(pb);
  }
  // |Newell's normal| is twice the area; a sliver thinner than 1e-9 of its size has none.
  if (newell.norm() <= 2e-9 * size * size) {
    Fail(row, row.tokens[0], "degenerate face: its points are collinear (no area)");
  }
}

// A face row's count and its `n` indices.
std::vector<Token> CaoReader::FaceIndices(const Row& row, const char* what) const {
  const Token& t = row.tokens[0];
  const std::optional<int64_t> n = NonNegativeInteger(t.text);
  if (!n) {
    Fail(row, t,
         fmt::format("the number of {}s of a face must be a non-negative integer, found '{}'", what,
                     Shown(t.text)));
  }
  if (*n > kMaxCaoPoints) {
    Fail(row, t,
         fmt::format("the number of {}s of a face, {}, exceeds the limit of {}", what,
                     Shown(t.text), kMaxCaoPoints));
  }
  if (*n < 3) {
    Fail(row, t, fmt::format("a face needs at least 3 {}s, found {}", what, *n));
  }
  if (row.tokens.size() < 1 + static_cast<size_t>(*n)) {
    Fail(row.line, row.tokens.back().end(),
         fmt::format("a face of {} {}s needs {} {} indices, found {}", *n, what, *n, what,
                     row.tokens.size() - 1));
  }
  return std::vector<Token>(row.tokens.begin() + 1, row.tokens.begin() + 1 + *n);
}

void CaoReader::ReadFacesFromLines() {
  const Row* count_row = Next();
  if (!count_row) {
    Fail(end_line_, end_column_,
         "the file ends before the faces from 3D lines section: expected the number of faces");
  }
  const int n = static_cast<int>(Count(*count_row, kFacesFromLines, kMaxCaoFaces));
  for (int k = 0; k < n; ++k) {
    const Row& row = SectionRow(kFacesFromLines, n, k);
    const std::vector<Token> indices = FaceIndices(row, "line");
    std::vector<int> face_lines;
    std::unordered_set<int> seen;
    for (const Token& t : indices) {
      const int l = Index(row, t, "line", static_cast<int>(lines_.size()));
      if (!seen.insert(l).second) {
        Fail(row, t, fmt::format("line {} appears twice in the face", l));
      }
      face_lines.push_back(l);
    }
    FaceRow face;
    face.name = Parameters(row, 1 + indices.size(), "after the line indices of the face");
    face.loop = Walk(row, face_lines);
    CheckArea(row, face.loop);
    face.where = Where(row);
    faces_.push_back(std::move(face));
  }
}

void CaoReader::ReadFacesFromPoints() {
  const Row* count_row = Next();
  if (!count_row) {
    Fail(end_line_, end_column_,
         "the file ends before the faces from 3D points section: expected the number of "
         "faces");
  }
  const int n = static_cast<int>(Count(*count_row, kFacesFromPoints, kMaxCaoFaces));
  for (int k = 0; k < n; ++k) {
    const Row& row = SectionRow(kFacesFromPoints, n, k);
    const std::vector<Token> indices = FaceIndices(row, "point");
    FaceRow face;
    std::unordered_set<int> seen;
    for (const Token& t : indices) {
      const int p = Index(row, t, "point", OwnPoints());
      if (!seen.insert(p).second) {
        Fail(row, t, fmt::format("point {} appears twice in the face", p));
      }
      face.loop.push_back(first_point_ + p);
    }
    face.name = Parameters(row, 1 + indices.size(), "after the point indices of the face");
    CheckArea(row, face.loop);
    face.where = Where(row);
    // Its sides that are not edges yet become edges.
    for (size_t j = 0; j < face.loop.size(); ++j) {
      const int a = face.loop[j], b = face.loop[(j + 1) % face.loop.size()];
      if (!own_edges_.insert(Key(a, b)).second) continue;
      part_.edges.push_back(
          {Unique(part_.points[a].name + "_" + part_.points[b].name, &edge_names_), a, b,
           face.where});
      if (part_.edges.size() > static_cast<size_t>(kMaxCaoEdges)) {
        RequireModelSize(face.where, "");
      }
    }
    faces_.push_back(std::move(face));
  }
  std::vector<std::optional<std::string>> given;
  std::vector<int> numbers;
  for (size_t k = 0; k < faces_.size(); ++k) {
    given.push_back(faces_[k].name);
    numbers.push_back(static_cast<int>(k));
  }
  const std::vector<std::string> names = Names(given, numbers, "f", &face_names_);
  for (size_t k = 0; k < faces_.size(); ++k) {
    part_.faces.push_back({names[k], std::move(faces_[k].loop), faces_[k].where});
  }
  RequireModelSize(Where(*count_row), "");
}

}  // namespace cfuse::internal
