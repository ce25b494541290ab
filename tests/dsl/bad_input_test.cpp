// Bad input: every error names file:line:col and what is wrong, as an InputError (the CLI
// prints it and exits with status 2); never a crash, never a silent default.
//
// One file per case under tests/data/bad/ (each says at its top what is wrong); binary, non-UTF-8
// and oversized files are written at run time to a temporary directory.
#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "cfuse/constraints/model_builder.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/error.h"
#include "test_util.h"

namespace {

namespace fs = std::filesystem;
using cfuse::InputError;
using cfuse::LoadModel;
using cfuse::testing::SourcePath;

std::string BadPath(const std::string& name) { return SourcePath("tests/data/bad/" + name); }

// How the loader names a file that `including` includes as `relative`.
std::string IncludedPath(const std::string& including, const std::string& relative) {
  return (fs::path(including).parent_path() / relative).lexically_normal().string();
}

// The InputError that loading `path` throws; fails the test when it loads, or when it throws
// anything else (a crash in disguise).
std::optional<InputError> LoadError(const std::string& path) {
  try {
    LoadModel(path);
  } catch (const InputError& e) {
    return e;
  } catch (const std::exception& e) {
    FAIL_CHECK("not an InputError: " << e.what());
    return std::nullopt;
  } catch (...) {
    FAIL_CHECK("a non-standard exception");
    return std::nullopt;
  }
  FAIL_CHECK("loaded without an error");
  return std::nullopt;
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

struct BadCase {
  const char* file;     // under tests/data/bad/
  const char* in_file;  // where the error is, relative to `file`, when in an included file
  int line;             // 0: the error names the file only
  int column;
  const char* message;  // a part of the message; "%f" stands for the file the error is in
};

// The error as the user sees it: where().file, line and column exact, the message naming the
// problem, and what() in the compiler convention.
void CheckError(const std::string& path, const std::string& error_file, int line, int column,
                const std::string& message) {
  const std::optional<InputError> e = LoadError(path);
  if (!e) return;
  INFO("what(): " << e->what());
  CHECK(e->where().file == error_file);
  CHECK(e->where().line == line);
  CHECK(e->where().column == column);
  CHECK_THAT(e->message(), Catch::Matchers::Contains(Replace(message, "%f", error_file)));
  CHECK(std::string(e->what()) == e->where().ToString() + ": error: " + e->message());
  if (line > 0) {
    CHECK(e->where().ToString() ==
          error_file + ":" + std::to_string(line) + ":" + std::to_string(column));
  }
}

// clang-format off
const BadCase kCases[] = {
  // YAML syntax and shape.
  {"yaml_bad_indent.yaml", nullptr, 5, 4, "YAML syntax error: end of map not found"},
  {"yaml_missing_colon.yaml", nullptr, 4, 3,
   "YAML syntax error: 'a [0, 0, 0]' is not 'key: value': is a ':' missing? (yaml-cpp: illegal "
   "map value at line 5)"},
  {"yaml_tab_indent.yaml", nullptr, 4, 1,
   "YAML syntax error: a tab in the indentation: YAML indents with spaces only"},
  {"yaml_unclosed_bracket.yaml", nullptr, 5, 4, "YAML syntax error: end of sequence flow not found"},
  // yaml-cpp 0.7 loops forever on these (found by fuzz/model_dsl_fuzz.cpp).
  {"yaml_stray_comma.yaml", nullptr, 2, 7, "YAML syntax error: unexpected ','"},
  {"yaml_only_comma.yaml", nullptr, 1, 1, "YAML syntax error: unexpected ','"},
  {"duplicate_key.yaml", nullptr, 5, 1, "duplicate key 'points' in the model"},
  {"multi_document.yaml", nullptr, 5, 1, "a model file holds one YAML document, this is a second one"},
  {"unknown_top_key.yaml", nullptr, 5, 1,
   "unknown key 'contraints' in the model (did you mean 'constraints'?)"},
  {"unknown_component_key.yaml", nullptr, 5, 5,
   "unknown key 'point' in component 'box' (did you mean 'points'?)"},
  {"top_level_list.yaml", nullptr, 2, 1, "a model file is a mapping with keys such as components"},
  {"empty.yaml", nullptr, 0, 0, "file is empty"},
  {"comment_only.yaml", nullptr, 0, 0, "file is empty"},
  // Unknown names.
  {"unknown_point.yaml", nullptr, 6, 18, "unknown point 'p99'"},
  {"reserved_name.yaml", nullptr, 4, 3, "invalid point name 'nominal': it is a reserved word"},
  {"component_null.yaml", nullptr, 3, 3, "component 'plate' has no definition"},
  {"point_null.yaml", nullptr, 3, 3, "point 'p' has no coordinates [x, y, z]"},
  {"unknown_feature_point.yaml", nullptr, 8, 17, "component 'box' has no point 'c9'"},
  {"unknown_component_expr.yaml", nullptr, 8, 17, "unknown component 'bx' (did you mean 'box'?)"},
  {"ambiguous_point.yaml", nullptr, 8, 22,
   "point name 'c1' is ambiguous: it could be box.c1, lid.c1; write component.point"},
  {"joint_unknown_component.yaml", nullptr, 10, 13, "unknown component 'bse' (did you mean 'base'?)"},
  {"fixed_unknown_component.yaml", nullptr, 4, 9, "unknown component 'bose' (did you mean 'base'?)"},
  // Duplicate names.
  {"duplicate_component_point.yaml", nullptr, 7, 3,
   "duplicate component name 'box', first defined (at %f:3:3)"},
  {"duplicate_feature_point.yaml", nullptr, 7, 7, "duplicate key 'c2' in component 'box' points"},
  {"duplicate_joint.yaml", nullptr, 8, 3, "duplicate key 'hinge' in joints"},
  {"duplicate_constraint.yaml", nullptr, 9, 11,
   "duplicate constraint name 'span', first defined (at %f:8:11)"},
  {"constraint_named_like_joint.yaml", nullptr, 8, 11,
   "duplicate constraint name 'hinge', first defined (at %f:6:3)"},
  // Arity and type in expressions.
  {"arity_distance.yaml", nullptr, 7, 5, "distance takes 2 arguments, got 3"},
  {"arity_coplanar.yaml", nullptr, 7, 5, "coplanar takes at least 4 arguments, got 3"},
  {"arity_parallel.yaml", nullptr, 6, 5, "parallel takes 2 arguments, got 1"},
  {"type_scalar_for_point.yaml", nullptr, 6, 17,
   "argument 2 of distance must be a point or vector, got a scalar [m]"},
  {"type_vector_inequality.yaml", nullptr, 6, 11, "an inequality compares scalars, not vectors"},
  {"type_multiply_vectors.yaml", nullptr, 7, 18, "cannot multiply two vectors"},
  // Units.
  {"unit_distance_deg.yaml", nullptr, 6, 23,
   "unit mismatch: the left-hand side is in [m] but the right-hand side is in [rad]"},
  {"unit_length_plus_angle.yaml", nullptr, 7, 20, "unit mismatch: [m] + [rad]"},
  {"unit_unknown.yaml", nullptr, 6, 26, "unknown unit 'furlongs' (units: m, cm, mm, rad, deg)"},
  {"unit_inches.yaml", nullptr, 7, 27,
   "syntax error in constraint: 'in' is not a unit: the units are m, cm, mm, rad and deg (no "
   "inches)"},
  {"unit_missing.yaml", nullptr, 6, 23,
   "the right-hand side is in [1]; a number without a unit is dimensionless, write e.g. '0.3 m'"},
  {"unit_wrong_kind.yaml", nullptr, 2, 17, "'deg' is not a unit of length"},
  {"joint_limits_degrees_in_radians.yaml", nullptr, 11, 13,
   "joint 'elbow': limits [-90, 90] rad are more than two turns from zero: degrees meant?"},
  {"joint_limit_name.yaml", nullptr, 11, 14,
   "invalid lower limit: expected a number with a unit, e.g. '90 deg', found 'lo'"},
  // Expression syntax and misuse.
  {"expr_syntax_unclosed.yaml", nullptr, 6, 19,
   "syntax error in constraint: expected ',' or ')' to close 'distance(' at line 6, column 13, "
   "found '=='"},
  {"expr_syntax_single_equals.yaml", nullptr, 7, 27,
   "syntax error in constraint: unexpected character '=' (use '==' for equality)"},
  {"expr_deep_nesting.yaml", nullptr, 6, 87,
   "expression nested too deeply at '(' (more than 64 levels"},
  {"nominal_lhs.yaml", nullptr, 6, 5,
   "'nominal' stands for the value of the left-hand side at the nominal geometry"},
  {"relation_in_expression.yaml", nullptr, 7, 23, "parallel is a relation, not a value"},
  {"function_alone.yaml", nullptr, 6, 5,
   "distance(...) is a value, not a constraint: compare it, e.g. 'distance(a, b) == nominal'"},
  {"range_nonconstant.yaml", nullptr, 7, 24, "the bounds of a range must be constants"},
  {"range_empty.yaml", nullptr, 6, 24,
   "empty range: the lower bound 0.005 m is not below the upper bound 0.002 m"},
  // Joints.
  {"joint_unknown_type.yaml", nullptr, 7, 11, "unknown joint type 'hinge'; the types are revolute"},
  {"joint_zero_axis.yaml", nullptr, 10, 11, "joint 'shoulder': the axis has zero length"},
  {"joint_limits_inverted.yaml", nullptr, 11, 13,
   "joint 'shoulder': the lower limit is not below the upper limit"},
  {"joint_limits_continuous.yaml", nullptr, 11, 13, "a continuous joint has no limits (use revolute)"},
  {"joint_axis_spherical.yaml", nullptr, 10, 11, "a spherical joint has no axis"},
  {"joint_point_parent.yaml", nullptr, 9, 13,
   "joint 'shoulder': 'pin' is a single-point component; joints connect rigid components"},
  {"joint_cycle.yaml", nullptr, 7, 3, "joint 'ab' is part of a cycle of joints"},
  {"joint_two_parents.yaml", nullptr, 9, 54,
   "joint 'right': component 'arm' is already the child of joint 'left' (at %f:8:3)"},
  // Degenerate at the nominal geometry.
  {"degenerate_distance.yaml", nullptr, 7, 5,
   "constraint 'c1' (distance(a, b) == 0 m) is not differentiable at the nominal geometry"},
  {"degenerate_coplanar.yaml", nullptr, 9, 11,
   "constraint 'flat': coplanar: the points are collinear (or coincide) at the nominal geometry"},
  {"degenerate_parallel.yaml", nullptr, 8, 5,
   "constraint 'c1': parallel: argument 1 has zero length at the nominal geometry"},
  // Includes.
  {"include_cycle_a.yaml", "include_cycle_b.yaml", 5, 5, "include cycle: "},
  {"include_missing.yaml", nullptr, 4, 5, "parts/no_such_part.yaml': no such file"},
  {"include_urdf.yaml", nullptr, 2, 34,
   "cannot include 'parts/robot.urdf': no importer is registered for '.urdf' files"},
  {"include_clash.yaml", nullptr, 5, 11, "defines component 'box'"},
  {"include_inner_error.yaml", "parts/bad_point.yaml", 5, 17, "unknown point 'q' (did you mean 'p'?)"},
  {"include_without_file.yaml", nullptr, 3, 5, "an include needs 'file'"},
  {"include_bad_prefix.yaml", nullptr, 3, 36, "invalid prefix 'left-': letters, digits and '_'"},
  // Components, their poses, edges, frames and markers.
  {"pose_rpy_and_quaternion.yaml", nullptr, 4, 56, "give either rpy or quaternion, not both"},
  {"quaternion_not_unit.yaml", nullptr, 4, 24,
   "quaternion [w, x, y, z] must have unit norm, it has 1.41421"},
  {"edge_not_pair.yaml", nullptr, 6, 11, "an edge is a pair of points [a, b]"},
  {"edge_to_itself.yaml", nullptr, 6, 7, "edge 'e1' joins a point to itself"},
  {"frame_named_like_component.yaml", nullptr, 7, 3,
   "'tool' is already a frame on component 'base' (at %f:5:7)"},
  {"marker_null.yaml", nullptr, 5, 3, "marker 'm1' needs 'link' and 'xyz'"},
  {"marker_without_link.yaml", nullptr, 5, 7, "marker 'm1' needs a 'link'"},
  {"marker_without_xyz.yaml", nullptr, 5, 7, "marker 'm1' needs 'xyz', its position on the link"},
  {"no_components.yaml", nullptr, 0, 0, "the model has no components or points"},
  // More joints.
  {"joint_without_type.yaml", nullptr, 6, 13, "joint 'shoulder' needs a 'type'"},
  {"joint_to_itself.yaml", nullptr, 5, 51, "joint 'shoulder' connects 'base' to itself"},
  {"joint_without_axis.yaml", nullptr, 6, 13, "joint 'shoulder' (revolute) needs an 'axis'"},
  {"joint_limits_not_pair.yaml", nullptr, 6, 81, "limits must be a list [lower, upper]"},
  {"joint_fixed_position.yaml", nullptr, 6, 59, "a fixed joint has no position"},
  {"joint_fixed_mimic.yaml", nullptr, 8, 56, "a fixed joint has no variable to mimic with"},
  {"joint_mimic_without_joint.yaml", nullptr, 8, 77, "joint 'wrist': mimic needs a 'joint'"},
  {"joint_named_like_included.yaml", nullptr, 6, 3,
   "duplicate joint name 'hinge', first defined (at "},
  // Fixed entries.
  {"fixed_neither.yaml", nullptr, 5, 5, "a fixed entry names either a 'component' or a 'point'"},
  {"fixed_point_with_fix.yaml", nullptr, 5, 5, "'fix' applies to components"},
  {"fixed_point_syntax.yaml", nullptr, 5, 18, "expected a member name after 'base.', found '('"},
  {"fixed_point_expression.yaml", nullptr, 5, 13, "'point' names a point, e.g. lid.c3"},
  {"fixed_single_point_component.yaml", nullptr, 5, 17,
   "'p' is a single-point component: fix it with 'point: p'"},
  {"fixed_unknown_fix.yaml", nullptr, 5, 28,
   "unknown fix 'rotation': pose, position or orientation"},
  // More constraints.
  {"constraint_without_expr.yaml", nullptr, 4, 5, "a constraint needs 'expr'"},
  {"constraint_not_string.yaml", nullptr, 4, 5,
   "a constraint is an expression string, e.g. 'distance(a, b) == 30 mm'"},
  {"unknown_function.yaml", nullptr, 4, 5,
   "unknown function 'length'; the functions are distance, angle"},
  {"unknown_relation.yaml", nullptr, 4, 5,
   "unknown relation 'skew'; the relations are parallel, perpendicular"},
  {"range_vector.yaml", nullptr, 4, 11, "a range bounds a scalar, not a vector"},
  {"component_point_as_point.yaml", nullptr, 7, 17,
   "'box' is a rigid component, not a point: name one of its points, e.g. box.c1"},
  {"collinear_coincident.yaml", nullptr, 4, 5,
   "constraint 'c1': collinear: the points coincide at the nominal geometry"},
  {"rigid_coincident.yaml", nullptr, 4, 5,
   "constraint 'c1': rigid: the points coincide at the nominal geometry"},
  {"rigid_points_coincide.yaml", nullptr, 4, 5,
   "constraint 'c1': rigid: points 2 and 3 coincide at the nominal geometry"},
  {"rigid_same_component.yaml", nullptr, 5, 5,
   "constraint 'constraint_1': rigid: the points already belong to one rigid component"},
};
// clang-format on

// A file that exists only for the test's duration.
class TempDir {
 public:
  TempDir() {
    std::random_device rd;
    path_ = fs::temp_directory_path() / ("cfuse_bad_input_" + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string Write(const std::string& name, const std::string& bytes) const {
    const fs::path p = path_ / name;
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    REQUIRE(out.good());
    return p.string();
  }

 private:
  fs::path path_;
};

}  // namespace

TEST_CASE("bad input: every file in the table fails where and how it should", "[dsl][bad]") {
  for (const BadCase& c : kCases) {
    const std::string path = BadPath(c.file);
    const std::string error_file = c.in_file ? IncludedPath(path, c.in_file) : path;
    INFO("case " << c.file);
    CheckError(path, error_file, c.line, c.column, c.message);
  }
}

TEST_CASE("bad input: every bad model file is in the table", "[dsl][bad]") {
  // Files under tests/data/bad/ that are not cases themselves.
  const std::vector<std::string> helpers = {"include_cycle_b.yaml"};
  for (const auto& entry : fs::directory_iterator(SourcePath("tests/data/bad"))) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    INFO("file " << name);
    const bool listed = std::any_of(std::begin(kCases), std::end(kCases),
                                    [&](const BadCase& c) { return name == c.file; }) ||
                        std::find(helpers.begin(), helpers.end(), name) != helpers.end();
    CHECK(listed);
  }
}

TEST_CASE("bad input: include cycle names the chain of files", "[dsl][bad]") {
  const std::string a = BadPath("include_cycle_a.yaml");
  const std::optional<InputError> e = LoadError(a);
  REQUIRE(e);
  const std::string canonical_a = fs::weakly_canonical(a).string();
  const std::string canonical_b = fs::weakly_canonical(BadPath("include_cycle_b.yaml")).string();
  CHECK(e->message() ==
        "include cycle: " + canonical_a + " -> " + canonical_b + " -> " + canonical_a);

  // Entered from the other side, the cycle closes in the other file.
  const std::string b = BadPath("include_cycle_b.yaml");
  CheckError(b, IncludedPath(b, "include_cycle_a.yaml"), 2, 10,
             "include cycle: " + canonical_b + " -> " + canonical_a + " -> " + canonical_b);
}

TEST_CASE("bad input: an include clash names both definitions", "[dsl][bad]") {
  const std::string path = BadPath("include_clash.yaml");
  const std::string part = IncludedPath(path, "parts/box.yaml");
  CheckError(path, path, 5, 11,
             "including '" + part + "' defines component 'box' (at " + part +
                 ":3:3) again, first defined (at " + part + ":3:3)");
}

TEST_CASE("bad input: a missing include names the file it looked for", "[dsl][bad]") {
  const std::string path = BadPath("include_missing.yaml");
  CheckError(path, path, 4, 5,
             "cannot open '" + IncludedPath(path, "parts/no_such_part.yaml") + "': no such file");
}

TEST_CASE("bad input: a missing model file or a directory", "[dsl][bad]") {
  const std::string missing = BadPath("no_such_model.yaml");
  CheckError(missing, missing, 0, 0, "cannot open: no such file");
  const std::string directory = SourcePath("tests/data/bad/parts");
  CheckError(directory, directory, 0, 0, "is a directory, not a model file");
}

TEST_CASE("bad input: binary, non-UTF-8 and oversized files", "[dsl][bad]") {
  const TempDir dir;

  SECTION("a binary file (NUL bytes)") {
    std::string bytes = "points:\n  a: [0, 0, 0]\n";
    bytes += std::string(
        "\x7f"
        "ELF\x02\x01\x01\0\0\0",
        10);
    const std::string path = dir.Write("binary.yaml", bytes);
    CheckError(path, path, 0, 0, "is a binary file, not a YAML model (NUL byte at offset 30)");
  }
  SECTION("a Latin-1 file") {
    const std::string path = dir.Write("latin1.yaml", "# caf\xE9 model\npoints:\n  a: [0, 0, 0]\n");
    CheckError(path, path, 1, 6, "is not UTF-8 text (byte 0xE9)");
  }
  SECTION("an overlong UTF-8 encoding") {
    const std::string path = dir.Write("overlong.yaml", "points:\n  a\xC0\xAF: [0, 0, 0]\n");
    CheckError(path, path, 2, 4, "is not UTF-8 text (byte 0xC0)");
  }
  SECTION("a UTF-8 surrogate") {
    const std::string path = dir.Write("surrogate.yaml", "points:\n  ab\xED\xA0\x80: [0, 0, 0]\n");
    CheckError(path, path, 2, 5, "is not UTF-8 text (byte 0xED)");
  }
  SECTION("a file truncated in the middle of a UTF-8 sequence") {
    const std::string path = dir.Write("truncated.yaml", "points: {a: [0, 0, 0]}\n# \xE2\x82");
    CheckError(path, path, 2, 3, "is not UTF-8 text (byte 0xE2)");
  }
  SECTION("a file over 16 MiB") {
    std::string bytes = "points:\n  a: [0, 0, 0]\n";
    const std::string comment = "# " + std::string(1022, 'x') + "\n";
    while (bytes.size() <= cfuse::kMaxModelFileBytes) bytes += comment;
    const std::string path = dir.Write("huge.yaml", bytes);
    CheckError(path, path, 0, 0, "file is larger than the 16 MiB limit for model files");
  }
  SECTION("an expression over the length limit") {
    std::string expr = "distance(a, b) == 1 m";
    while (expr.size() <= 4096) expr += " + 1 m";
    const std::string path = dir.Write(
        "long.yaml", "points: {a: [0, 0, 0], b: [1, 0, 0]}\nconstraints:\n  - " + expr + "\n");
    CheckError(path, path, 3, 5 + 4096,
               "expression is " + std::to_string(expr.size()) + " bytes long; the limit is 4096");
  }
  SECTION("YAML nested 50000 levels deep") {
    std::string bytes = "points: ";
    for (int i = 0; i < 50000; ++i) bytes += "{a: ";
    const std::string path = dir.Write("deep.yaml", bytes + "\n");
    const std::optional<InputError> e = LoadError(path);
    REQUIRE(e);
    CHECK(e->where().file == path);
    CHECK(e->where().line == 1);
    CHECK(e->where().column > 9);  // inside the nesting, where the parser gave up
    CHECK_THAT(e->message(), Catch::Matchers::StartsWith("YAML syntax error: nested more than"));
  }
  SECTION("includes nested more than 16 deep") {
    const int n = cfuse::kMaxIncludeDepth + 2;
    for (int i = 0; i < n; ++i) {
      dir.Write("level" + std::to_string(i) + ".yaml",
                "include: level" + std::to_string(i + 1) + ".yaml\npoints: {p: [0, 0, 0]}\n");
    }
    dir.Write("level" + std::to_string(n) + ".yaml", "points: {q: [0, 0, 0]}\n");
    const std::string top = dir.Write("top.yaml", "include: level0.yaml\npoints: {r: [0, 0, 0]}\n");
    // top.yaml and level0..level14 are open when level14 asks for a 17th file.
    const std::string deepest =
        (fs::path(top).parent_path() /
         ("level" + std::to_string(cfuse::kMaxIncludeDepth - 2) + ".yaml"))
            .lexically_normal()
            .string();
    CheckError(top, deepest, 1, 10, "includes are nested more than 16 deep");
  }
  SECTION("an include fan-out beyond the file limit") {
    // Each level includes the next four times: 4^5 files if nothing stopped it.
    for (int i = 0; i < 5; ++i) {
      std::string text = "include:\n";
      for (int k = 0; k < 4; ++k) {
        text += "  - {file: fan" + std::to_string(i + 1) + ".yaml, prefix: k" + std::to_string(k) +
                "_}\n";
      }
      dir.Write("fan" + std::to_string(i) + ".yaml", text);
    }
    dir.Write("fan5.yaml", "points: {p: [0, 0, 0]}\n");
    const std::string top = dir.Write("fan_top.yaml", "include: fan0.yaml\n");
    const std::optional<InputError> e = LoadError(top);
    REQUIRE(e);
    CHECK(e->message() == "the model includes more than 256 files in all");
    CHECK(e->where().line > 0);
  }
  SECTION("more components than the model limit") {
    std::string text = "points:\n";
    for (int i = 0; i <= cfuse::ModelBuilder::kMaxComponents; ++i) {
      text += "  p" + std::to_string(i) + ": [0, 0, 0]\n";
    }
    const std::string path = dir.Write("many.yaml", text);
    CheckError(path, path, cfuse::ModelBuilder::kMaxComponents + 2, 3,
               "the model has more than 100000 components");
  }
  SECTION("an empty file included") {
    const std::string empty = dir.Write("empty.yaml", "");
    const std::string path = dir.Write("includes_empty.yaml", "include: empty.yaml\n");
    CheckError(path, fs::path(empty).lexically_normal().string(), 0, 0, "file is empty");
  }
}

TEST_CASE("bad input: a byte-order mark does not shift columns", "[dsl][bad]") {
  const TempDir dir;
  const std::string path = dir.Write(
      "bom.yaml", "\xEF\xBB\xBFpointz: {a: [0, 0, 0]}\nconstraints:\n  - distance(a, bb) == 1 m\n");
  CheckError(path, path, 1, 1, "unknown key 'pointz' in the model (did you mean 'points'?)");
  const std::string path2 = dir.Write("bom2.yaml",
                                      "\xEF\xBB\xBFpoints: {a: [0, 0, 0], b: [1, 0, "
                                      "0]}\nconstraints:\n  - distance(a, bb) == 1 m\n");
  CheckError(path2, path2, 3, 17, "unknown point 'bb' (did you mean 'b'?)");
}
