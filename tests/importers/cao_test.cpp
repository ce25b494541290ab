// The CAO importer on the project's own small models (tests/data/cao): points, edges and faces
// with their names, outward face normals, loops walked from lines, loads with their transforms
// (nested, cyclic, too deep), a DSL model including a CAO file, and every malformed input refused
// at its line and column.
#include "cfuse/importers/cao.h"

#include <fmt/format.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "cfuse/constraints/dof.h"
#include "cfuse/dsl/model_loader.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

ConstraintGraph Data(const std::string& name) {
  return ImportCao(testing::SourcePath("tests/data/cao/" + name));
}

const Component& Only(const ConstraintGraph& g) {
  REQUIRE(g.components.size() == 1);
  return g.components[0];
}

Eigen::Vector3d PointOf(const Component& c, const std::string& point) {
  const int p = c.FindPoint(point);
  REQUIRE(p >= 0);
  return c.points[p].position;
}

template <typename Item>
std::vector<std::string> Names(const std::vector<Item>& items) {
  std::vector<std::string> out;
  for (const Item& item : items) out.push_back(item.name);
  return out;
}

const Edge& EdgeNamed(const Component& c, const std::string& name) {
  for (const Edge& e : c.edges) {
    if (e.name == name) return e;
  }
  FAIL("no edge " << name);
  return c.edges.front();
}

const Face& FaceNamed(const Component& c, const std::string& name) {
  for (const Face& f : c.faces) {
    if (f.name == name) return f;
  }
  FAIL("no face " << name);
  return c.faces.front();
}

// Newell's normal of a face's loop: the right-hand rule's, |n| twice the area.
Eigen::Vector3d Normal(const Component& c, const Face& f) {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < f.loop.size(); ++k) {
    n += c.points[f.loop[k]].position.cross(c.points[f.loop[(k + 1) % f.loop.size()]].position);
  }
  return n;
}

// Every face of a convex object (its points `first`..`first + count`) faces away from its
// centre.
void CheckOutward(const Component& c, const std::string& prefix, int first, int count) {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int p = first; p < first + count; ++p) centre += c.points[p].position;
  centre /= count;
  int checked = 0;
  for (const Face& f : c.faces) {
    if (f.name.rfind(prefix, 0) != 0 || f.loop[0] < first || f.loop[0] >= first + count) continue;
    Eigen::Vector3d middle = Eigen::Vector3d::Zero();
    for (int p : f.loop) middle += c.points[p].position;
    middle /= static_cast<double>(f.loop.size());
    INFO("face " << f.name);
    CHECK(Normal(c, f).normalized().dot((middle - centre).normalized()) > 0.5);
    ++checked;
  }
  CHECK(checked > 0);
}

// Every side of every face is an edge, and no two edges join the same two points.
void CheckEdgesCoverFaces(const Component& c) {
  std::set<std::pair<int, int>> edges;
  for (const Edge& e : c.edges) {
    CHECK(edges.insert({std::min(e.a, e.b), std::max(e.a, e.b)}).second);
  }
  for (const Face& f : c.faces) {
    for (size_t k = 0; k < f.loop.size(); ++k) {
      const int a = f.loop[k], b = f.loop[(k + 1) % f.loop.size()];
      INFO("face " << f.name << " side " << a << "-" << b);
      CHECK(edges.count({std::min(a, b), std::max(a, b)}) == 1);
    }
  }
}

// A fresh directory for one test's files.
fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("cfuse_cao_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

std::string Text(const std::string& data_file) {
  std::ifstream in(testing::SourcePath("tests/data/cao/" + data_file), std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// The InputError importing `path` throws.
InputError ErrorOf(const std::string& path) {
  try {
    ImportCao(path);
  } catch (const InputError& e) {
    return e;
  }
  FAIL("accepted: " << path);
  return InputError(SourceLocation(), "");
}

TEST_CASE("cao: a cube by faces from points", "[importers][cao]") {
  const ConstraintGraph g = Data("cube.cao");
  CHECK(g.name == "cube");
  const Component& c = Only(g);
  CHECK(c.name == "cube");
  CHECK(c.rigid);
  CHECK(c.pose_given);
  const Rigid3d& pose = g.nominal.poses[g.blocks[c.block].index];
  CHECK(pose.translation.norm() == 0);
  CHECK(pose.rotation.angularDistance(Eigen::Quaterniond::Identity()) == 0);

  CHECK(Names(c.points) ==
        std::vector<std::string>{"p0", "p1", "p2", "p3", "p4", "p5", "p6", "p7"});
  CHECK(PointOf(c, "p0") == Eigen::Vector3d(0, 0, 0));
  CHECK(PointOf(c, "p6") == Eigen::Vector3d(0.1, 0.1, 0.1));
  CHECK(c.points[6].where.line == 12);
  CHECK(c.points[6].where.column == 1);

  // No 3D lines: the edges are the faces' sides, each once, named after their points in the
  // order the first face that has them walks them.
  CHECK(c.edges.size() == 12);
  CHECK(Names(c.edges) == std::vector<std::string>{"p0_p3", "p3_p2", "p2_p1", "p1_p0", "p4_p5",
                                                   "p5_p6", "p6_p7", "p7_p4", "p1_p5", "p4_p0",
                                                   "p3_p7", "p6_p2"});
  CheckEdgesCoverFaces(c);

  CHECK(Names(c.faces) == std::vector<std::string>{"f0", "top", "f2", "f3", "f4", "f5"});
  CHECK(FaceNamed(c, "f0").loop == std::vector<int>{0, 3, 2, 1});  // as in the file
  CHECK(FaceNamed(c, "top").where.line == 21);
  // ViSP's faces run counter-clockwise seen from outside, as cfuse's: normals point out.
  CheckOutward(c, "", 0, 8);
  CHECK(Normal(c, FaceNamed(c, "top")).normalized().isApprox(Eigen::Vector3d::UnitZ()));

  const DofReport dof = AnalyzeDof(g, g.nominal);
  CHECK(dof.dof == 6);
  CHECK(dof.rigid_body == 6);
  CHECK(dof.internal == 0);
}

TEST_CASE("cao: 3D lines, faces walked from lines, faces from points", "[importers][cao]") {
  const ConstraintGraph g = Data("wedge.cao");
  const Component& c = Only(g);
  CHECK(c.points.size() == 6);
  // Line 9 repeats line 6: dropped. Lines 1 and 2 share the name 'dup': both numbered. A quoted
  // name becomes an identifier. The faces' sides are all lines already.
  CHECK(Names(c.edges) == std::vector<std::string>{"front_bottom", "l1", "l2", "l3", "l4", "l5",
                                                   "left_front", "l7", "l8"});
  CHECK(EdgeNamed(c, "left_front").a == 0);
  CHECK(EdgeNamed(c, "left_front").b == 3);
  CHECK(EdgeNamed(c, "l7").where.line == 20);
  CheckEdgesCoverFaces(c);
  // Faces from lines first (f0, f1), then from points (f2, ...).
  CHECK(Names(c.faces) == std::vector<std::string>{"top", "f1", "f2", "hypotenuse", "left"});
  // Walked from each face's first line, in its direction: lines 3 (3-4), 5 (5-3), 4 (4-5) make
  // 3-4-5; lines 0 (0-1), 3 (3-4), 7 (1-4), 6 (0-3) make 0-1-4-3.
  CHECK(FaceNamed(c, "top").loop == std::vector<int>{3, 4, 5});
  CHECK(FaceNamed(c, "f1").loop == std::vector<int>{0, 1, 4, 3});
  CHECK(FaceNamed(c, "hypotenuse").loop == std::vector<int>{1, 2, 5, 4});
  CheckOutward(c, "", 0, 6);
  CHECK(AnalyzeDof(g, g.nominal).dof == 6);
}

TEST_CASE("cao: load() merges other files, moved by t and turned by tu", "[importers][cao]") {
  const ConstraintGraph g = Data("assembly.cao");
  CHECK(g.name == "assembly");
  const Component& c = Only(g);
  CHECK(c.name == "assembly");
  // Loaded parts first, in load order, prefixed by their stem; a stem loaded again gets _2.
  REQUIRE(c.points.size() == 8 + 8 + 6 + 1);
  CHECK(c.points[0].name == "cube_p0");
  CHECK(c.points[8].name == "cube_2_p0");
  CHECK(c.points[16].name == "wedge_p0");
  CHECK(c.points[22].name == "p0");
  const ConstraintGraph cube = Data("cube.cao");
  const ConstraintGraph wedge = Data("wedge.cao");
  // The second cube: a quarter turn about z (tu in degrees), then t.
  const Eigen::Matrix3d quarter =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  for (int k = 0; k < 8; ++k) {
    INFO("point " << k);
    const Eigen::Vector3d p = cube.components[0].points[k].position;
    CHECK((c.points[k].position - p).norm() == 0);
    CHECK((c.points[8 + k].position - (quarter * p + Eigen::Vector3d(0.5, 0.1, -0.2))).norm() <
          1e-12);
  }
  CHECK((PointOf(c, "cube_2_p1") - Eigen::Vector3d(0.5, 0.2, -0.2)).norm() < 1e-12);
  // The wedge: tu = θu in radians, numbers separated by commas.
  const Eigen::Vector3d tu(0.3, -0.2, 0.1);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(tu.norm(), tu.normalized()).toRotationMatrix();
  for (int k = 0; k < 6; ++k) {
    INFO("point " << k);
    const Eigen::Vector3d expected =
        R * wedge.components[0].points[k].position + Eigen::Vector3d(-0.3, 0, 0.25);
    CHECK((c.points[16 + k].position - expected).norm() < 1e-12);
  }
  // Edges and faces keep their points, renumbered.
  CHECK(c.edges.size() == 12 + 12 + 9);
  const Edge& e = EdgeNamed(c, "cube_2_p0_p3");
  CHECK(c.points[e.a].name == "cube_2_p0");
  CHECK(c.points[e.b].name == "cube_2_p3");
  CHECK(EdgeNamed(c, "wedge_front_bottom").a == 16);
  CHECK(c.faces.size() == 6 + 6 + 5);
  CHECK(FaceNamed(c, "cube_2_top").loop == std::vector<int>{12, 13, 14, 15});
  CHECK(FaceNamed(c, "wedge_f1").loop == std::vector<int>{16, 17, 20, 19});
  // Locations stay in the file that defined the item, named as resolved from the including one.
  CHECK(FaceNamed(c, "cube_2_top").where.file ==
        fs::path(testing::SourcePath("tests/data/cao/cube.cao")).lexically_normal().string());
  CHECK(FaceNamed(c, "cube_2_top").where.line == 21);
  CheckEdgesCoverFaces(c);
  // Rotations keep the faces outward.
  CheckOutward(c, "cube_2_", 8, 8);
  CheckOutward(c, "wedge_", 16, 6);
  const DofReport dof = AnalyzeDof(g, g.nominal);
  CHECK(dof.dof == 6);
  CHECK(dof.rigid_body == 6);
}

TEST_CASE("cao: nested loads, assemblies of loads only, ViSP's older files", "[importers][cao]") {
  const fs::path dir = TempDir("nested");
  Write(dir / "sub" / "part.cao", Text("cube.cao"));
  Write(dir / "sub" / "mid.cao",
        "V1\nload(\"part.cao\", t=[1; 0; 0])  # relative to sub/\n1\n0 0 0\n0\n0\n0\n");
  Write(dir / "top.cao", "V1\nload(\"sub/mid.cao\", tu=[0; 0; 90deg])\n");
  const ConstraintGraph g = ImportCao((dir / "top.cao").string());
  const Component& c = Only(g);
  CHECK(c.name == "top");
  REQUIRE(c.points.size() == 9);
  CHECK(c.points[0].name == "mid_part_p0");
  CHECK(c.points[8].name == "mid_p0");
  // top_from_mid (a quarter turn) * mid_from_part (1 m along x).
  CHECK((PointOf(c, "mid_part_p1") - Eigen::Vector3d(0, 1.1, 0)).norm() < 1e-12);
  CHECK((PointOf(c, "mid_p0") - Eigen::Vector3d(0, 0, 0)).norm() < 1e-12);
  CHECK(c.faces.size() == 6);
  CHECK(FaceNamed(c, "mid_part_top").where.file == (dir / "sub" / "part.cao").string());

  // Files that stop after the faces from points (before ViSP had cylinders), or after the
  // cylinders; a stem that is not an identifier.
  const std::string old = "V1\n3\n0 0 0\n1 0 0\n0 1 0\n0\n0\n1\n3 0 1 2\n";
  CHECK(Only(ImportCaoFromString(old, "2x4-brick.cao")).name == "_2x4_brick");
  CHECK(ImportCaoFromString(old, "2x4-brick.cao").name == "2x4-brick");
  CHECK(Only(ImportCaoFromString(old + "0\n\n", "in.cao")).name == "in_");
  // Numbers: signs, exponents, leading and trailing points; comments after '#' and '//'.
  const ConstraintGraph numbers = ImportCaoFromString(
      "\xEF\xBB\xBFV1 # a header\n3\n1.5e-3 -2 +3E2\n.5 5. -0.25e+1 // ViSP's own comments\n"
      "  # an indented comment\n\n1 0 0\n0\n0\n1\n3 0 1 2\n0\n0\n",
      "numbers.cao");
  CHECK(Only(numbers).points[0].position == Eigen::Vector3d(1.5e-3, -2, 300));
  CHECK(Only(numbers).points[1].position == Eigen::Vector3d(0.5, 5, -2.5));
  // An automatic name another row took explicitly moves aside.
  const ConstraintGraph named = ImportCaoFromString(
      "V1\n3\n0 0 0\n1 0 0\n0 1 0\n2\n0 1\n1 2 name=l0\n0\n0\n", "named.cao");
  CHECK(Names(Only(named).edges) == std::vector<std::string>{"l0_2", "l0"});
}

TEST_CASE("cao: a model file includes a CAO object and adds to it", "[importers][cao]") {
  const fs::path dir = TempDir("include");
  Write(dir / "cube.cao", Text("cube.cao"));
  Write(dir / "model.yaml", R"(name: cube on a table
units: {length: mm, angle: deg}
include: cube.cao
components:
  table: {pose: {xyz: [0, 0, -10]}, points: {corner: [0, 0, 0], far: [1000, 500, 0]}}
markers:
  m_top: {link: cube, xyz: [50, 50, 100]}
fixed:
  - table
constraints:
  - distance(cube.p0, table.corner) == nominal
)");
  LoadOptions options;
  options.include_handlers[".cao"] = [](const std::string& path, const SourceLocation& where) {
    return ImportCao(path, where);
  };
  const ConstraintGraph g = LoadModel((dir / "model.yaml").string(), options);
  const int cube = g.FindComponent("cube");
  REQUIRE(cube >= 0);
  const Component& c = g.components[cube];
  CHECK(c.points.size() == 9);
  CHECK((PointOf(c, "m_top") - Eigen::Vector3d(0.05, 0.05, 0.1)).norm() < 1e-15);
  CHECK(c.faces.size() == 6);
  // The table fixed, the cube held at one distance: 6 - 1.
  CHECK(AnalyzeDof(g, g.nominal).dof == 5);

  // An error in the included file is reported there.
  Write(dir / "broken.cao", "V1\n1\n0 0\n");
  Write(dir / "bad.yaml", "include: broken.cao\n");
  try {
    LoadModel((dir / "bad.yaml").string(), options);
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().file == (dir / "broken.cao").string());
    CHECK(e.where().line == 3);
    CHECK(e.where().column == 4);
  }
}

TEST_CASE("cao: load cycles, depth, count and missing files are refused at the load",
          "[importers][cao]") {
  const fs::path dir = TempDir("loads");
  const std::string d = dir.string();
  Write(dir / "a.cao", "V1\nload(\"b.cao\")\n");
  Write(dir / "b.cao", "V1\nload(\"a.cao\")\n");
  InputError e = ErrorOf(d + "/a.cao");
  CHECK(e.where().file == d + "/b.cao");
  CHECK(e.where().line == 2);
  CHECK(e.where().column == 6);
  CHECK(e.message() == "load cycle: " + d + "/a.cao -> " + d + "/b.cao -> " + d + "/a.cao");

  Write(dir / "self.cao", "V1\n# loads itself\nload( \"./self.cao\" )\n");
  e = ErrorOf(d + "/self.cao");
  CHECK(e.where().line == 3);
  CHECK(e.where().column == 7);
  CHECK(e.message() == "load cycle: " + d + "/self.cao -> " + d + "/self.cao");

  // 16 files open at once are fine, 17 are not.
  for (int k = 0; k <= 16; ++k) {
    Write(dir / fmt::format("d{}.cao", k),
          k == 16 ? Text("cube.cao") : fmt::format("V1\nload(\"d{}.cao\")\n", k + 1));
  }
  e = ErrorOf(d + "/d0.cao");
  CHECK(e.where().file == d + "/d15.cao");
  CHECK(e.where().line == 2);
  CHECK_THAT(e.message(), Catch::Matchers::StartsWith("loads nest more than 16 files deep"));
  const ConstraintGraph deep = ImportCao(d + "/d1.cao");
  CHECK(Only(deep).FindPoint("d2_d3_d4_d5_d6_d7_d8_d9_d10_d11_d12_d13_d14_d15_d16_p7") >= 0);

  std::string many = "V1\n";
  for (int k = 0; k < 256; ++k) many += "load(\"d16.cao\")\n";
  Write(dir / "many.cao", many);
  e = ErrorOf(d + "/many.cao");
  CHECK(e.where().line == 257);
  CHECK(e.message() == "the model loads more than 256 files in all");

  Write(dir / "missing.cao", "V1\nload(\"nope.cao\", t=[0; 0; 1])\n");
  e = ErrorOf(d + "/missing.cao");
  CHECK(e.where().line == 2);
  CHECK(e.where().column == 6);
  CHECK(e.message() == "cannot open '" + d + "/nope.cao': no such file");

  // More points than the model may hold, counting the loaded ones.
  std::string half = fmt::format("V1\n{}\n", kMaxCaoPoints / 2 + 1);
  for (int k = 0; k <= kMaxCaoPoints / 2; ++k) half += fmt::format("{} 0 0\n", k);
  Write(dir / "half.cao", half + "0\n0\n0\n");
  Write(dir / "twice.cao", "V1\nload(\"half.cao\")\nload(\"half.cao\")\n");
  e = ErrorOf(d + "/twice.cao");
  CHECK(e.where().line == 3);
  CHECK(e.message() == fmt::format("with '{}/half.cao' loaded, the model has more than {} points",
                                   d, kMaxCaoPoints));
}

TEST_CASE("cao: files that cannot be read", "[importers][cao]") {
  const fs::path dir = TempDir("files");
  const std::string missing = (dir / "missing.cao").string();
  InputError e = ErrorOf(missing);
  CHECK(e.where().file == missing);
  CHECK(e.where().line == 0);
  CHECK(e.message() == "cannot open: no such file");
  try {
    ImportCao(missing, SourceLocation("model.yaml", 3, 10));
    FAIL("accepted");
  } catch (const InputError& ie) {
    CHECK(ie.where().ToString() == "model.yaml:3:10");
    CHECK(ie.message() == "cannot open '" + missing + "': no such file");
  }
  CHECK(ErrorOf(dir.string()).message() == "is a directory, not a CAO file");
  Write(dir / "binary.cao", std::string("V1\n\0\n", 5));
  CHECK(ErrorOf((dir / "binary.cao").string()).message() == "not a CAO file: it holds binary data");
  Write(dir / "large.cao", "V1\n#" + std::string(kMaxCaoFileBytes, 'x') + "\n");
  CHECK(ErrorOf((dir / "large.cao").string()).message() ==
        "file is larger than the 16 MiB limit for CAO files");
  fs::remove(dir / "large.cao");
  Write(dir / "locked.cao", Text("cube.cao"));
  fs::permissions(dir / "locked.cao", fs::perms::none);
  if (!std::ifstream(dir / "locked.cao")) {  // root reads it anyway
    CHECK(ErrorOf((dir / "locked.cao").string()).message() == "cannot open: Permission denied");
  }
  fs::permissions(dir / "locked.cao", fs::perms::owner_all);
}

// Every malformed text: refused at LINE:COLUMN with a message starting so.
TEST_CASE("cao: malformed files are refused at the line and column", "[importers][cao]") {
  // Four points in the plane z = 0 and no lines: a base for the faces from points.
  const std::string square = "V1\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0\n0\n";  // lines 1-8
  // A triangle by three lines: a base for the faces from lines.
  const std::string triangle = "V1\n3\n0 0 0\n1 0 0\n0 1 0\n3\n0 1\n1 2\n2 0\n";  // lines 1-9
  const std::string cases[] = {
      // The header.
      "", "# only a comment\n", "V2\n8\n", "  cube\n", "V1 extra\n",
      "V0000000000000000000010000000000000000000\n",  // the fuzzer's: no overflow
      // Counts.
      "V1\n-1\n", "V1\n2.5\n", "V1\n20001\n", "V1\n100000000000000000000000\n", "V1\n8 points\n",
      "V1\n0\n0\n0\n0\n",
      // Points.
      "V1\n1\n0 0\n", "V1\n1\n0 x 0\n", "V1\n1\n0 0 1e999\n", "V1\n1\n0 0 0 7\n", "V1\n1\n0 0 0,\n",
      // Truncated files.
      "V1\n3\n0 0 0\n1 0 0\n", "V1\n3\n0 0 0\n1 0 0\n0 1 0", "V1\n", "V1\n1\n0 0 0\n0\n0\n",
      square + "2\n3 0 1 2\n",
      // Lines.
      "V1\n2\n0 0 0\n1 0 0\n1\n0 2\n", "V1\n2\n0 0 0\n1 0 0\n1\n0\n",
      "V1\n2\n0 0 0\n1 0 0\n1\n1 1\n", "V1\n2\n0 0 0\n1 0 0\n1\n0 1 colour=red\n",
      "V1\n2\n0 0 0\n1 0 0\n1\n0 1 junk\n", "V1\n2\n0 0 0\n1 0 0\n1\n0 1 useLod=maybe\n",
      "V1\n2\n0 0 0\n1 0 0\n1\n0 1 name=a name=b\n", "V1\n2\n0 0 0\n1 0 0\n1\n0 1 name=\"a\n",
      "V1\n2\n0 0 0\n1 0 0\n1\n0 -1\n", "V1\n2\n0 0 0\n1 0 0\n1\n0 1 minLineLengthThreshold=x\n",
      "V1\n2\n0 0 0\n1 0 0\n1\n0 1 name=\"\"\n",
      // Faces from lines.
      triangle + "1\n3 0 1 3\n", triangle + "1\n2 0 1\n", triangle + "1\n3 0 1\n",
      triangle + "1\n3 0 1 1\n",
      "V1\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3\n0 1\n1 2\n2 3\n1\n3 0 1 2\n",
      "V1\n6\n0 0 0\n1 0 0\n0 1 0\n5 0 0\n6 0 0\n5 1 0\n6\n0 1\n1 2\n2 0\n3 4\n4 5\n5 3\n"
      "1\n6 0 1 2 3 4 5\n",
      "V1\n4\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n4\n0 1\n1 2\n2 0\n1 3\n1\n4 0 1 2 3\n",
      "V1\n3\n0 0 0\n1 0 0\n2 0 0\n3\n0 1\n1 2\n2 0\n1\n3 0 1 2\n",
      // Faces from points.
      square + "1\n3 0 1 4\n", square + "1\n2 0 1\n", square + "1\n4 0 1 2\n",
      square + "1\n3 0 1 0\n", "V1\n3\n0 0 0\n1 0 0\n2 0 0\n0\n0\n1\n3 0 1 2\n",
      "V1\n3\n1000 1000 1000\n1000.1 1000 1000\n1000.2 1000 1000\n0\n0\n1\n3 0 1 2\n",
      "V1\n4\n0 0 0\n1 0 0\n1 0 0\n0 1 0\n0\n0\n1\n4 0 1 2 3\n", square + "1\n3 0 1 2 5\n",
      square + "1\nx 0 1 2\n", square + "1\n3 0 1 2 name=a=b useLod=0 useLod=1\n",
      // Cylinders, circles, what follows them; a load out of place.
      square + "0\n2\n0 1 0.1\n", square + "0\n0\n1\n", square + "0\n0\n0\nextra\n",
      "V1\n1\n0 0 0\nload(\"x.cao\")\n",
      // load(...).
      "V1\nload \"x.cao\"\n", "V1\nload(x.cao)\n", "V1\nload(\"\")\n",
      "V1\nload(\"x.cao\", s=[1; 2; 3])\n", "V1\nload(\"x.cao\", t=[1; 2])\n",
      "V1\nload(\"x.cao\", t=[1; 2; 3 deg])\n", "V1\nload(\"x.cao\", tu=[0; 0; 1]) junk\n",
      "V1\nload(\"x.cao\", t=[1; 2; 3], t=[1; 2; 3])\n", "V1\nload(\"x.cao\"\n",
      "V1\nload(\"x.cao\", t=[1; 2; 3; 4])\n", "V1\nload(\"no-such.cao\")\n",
      "V1\nload(\"x.cao\", tu=[0; 0; 450 deg])\n", "V1\nload(\"x.cao\", tu=[1e308; 1; 1])\n"};
  const testing::BadCase expected[] = {
      {"", 1, 1, "not a CAO file: it is empty; expected the header 'V1'"},
      {"", 1, 1, "not a CAO file: it is empty"},
      {"", 1, 1, "unsupported CAO version 'V2': cfuse reads version 1 ('V1')"},
      {"", 1, 3, "not a CAO file: expected the header 'V1', found 'cube'"},
      {"", 1, 4, "unexpected 'extra' after the header 'V1'"},
      {"", 1, 1, "unsupported CAO version 'V000000000000000000001000000000000000...'"},
      {"", 2, 1, "the number of 3D points must be a non-negative integer, found '-1'"},
      {"", 2, 1, "the number of 3D points must be a non-negative integer, found '2.5'"},
      {"", 2, 1, "the number of 3D points, 20001, exceeds the limit of 20000"},
      {"", 2, 1, "the number of 3D points, 100000000000000000000000, exceeds the limit of 20000"},
      {"", 2, 3, "unexpected 'points' after the number of 3D points"},
      {"", 2, 1, "the model has no points: the number of 3D points is 0 and nothing is loaded"},
      {"", 3, 4, "a 3D point needs 3 numbers (X Y Z), found 2"},
      {"", 3, 3, "expected a number, found 'x'"},
      {"", 3, 5, "number '1e999' is out of range"},
      {"", 3, 7, "unexpected '7' after the 3 coordinates of the point"},
      {"", 3, 5, "expected a number, found '0,'"},
      {"", 5, 1, "the file ends in the 3D points section: 3 points expected, 2 found"},
      {"", 5, 6, "the file ends before the 3D lines section: expected the number of 3D lines"},
      {"", 2, 1, "the file ends before the 3D points section"},
      {"", 6, 1, "the file ends before the faces from 3D points section"},
      {"", 11, 1, "the file ends in the faces from 3D points section: 2 faces expected, 1 found"},
      {"", 6, 3, "point index 2 is out of range: the file has 2 points (0 to 1)"},
      {"", 6, 2, "a 3D line needs 2 point indices, found 1"},
      {"", 6, 3, "a 3D line joins two different points, found point 1 twice"},
      {"", 6, 5, "unknown parameter 'colour': the parameters are name, useLod, "},
      {"", 6, 5, "unexpected 'junk' after the 2 point indices of the line: only name=, "},
      {"", 6, 5, "useLod is true or false, found 'maybe'"},
      {"", 6, 12, "parameter 'name' given twice"},
      {"", 6, 10, "unterminated quoted string"},
      {"", 6, 3, "a point index must be a non-negative integer, found '-1'"},
      {"", 6, 5, "minLineLengthThreshold is a number, found 'x'"},
      {"", 6, 5, "the name is empty"},
      {"", 11, 7, "line index 3 is out of range: the file has 3 lines (0 to 2)"},
      {"", 11, 1, "a face needs at least 3 lines, found 2"},
      {"", 11, 6, "a face of 3 lines needs 3 line indices, found 2"},
      {"", 11, 7, "line 1 appears twice in the face"},
      {"", 12, 3,
       "the face's lines do not form one closed loop: point 0 ends line 0 and no other line of "
       "the face"},
      {"", 17, 9, "the face's lines do not form one closed loop: line 3 is not on the loop"},
      {"", 13, 3, "the face's lines do not form one closed loop: point 1 is on 3 of its lines"},
      {"", 11, 1, "degenerate face: its points are collinear (no area)"},
      {"", 10, 7, "point index 4 is out of range: the file has 4 points (0 to 3)"},
      {"", 10, 1, "a face needs at least 3 points, found 2"},
      {"", 10, 8, "a face of 4 points needs 4 point indices, found 3"},
      {"", 10, 7, "point 0 appears twice in the face"},
      {"", 9, 1, "degenerate face: its points are collinear (no area)"},
      {"", 9, 1, "degenerate face: its points are collinear (no area)"},  // far from the origin
      {"", 10, 1, "degenerate face: points 1 and 2 coincide"},
      {"", 10, 9, "unexpected '5' after the point indices of the face"},
      {"", 10, 1, "the number of points of a face must be a non-negative integer, found 'x'"},
      {"", 10, 27, "parameter 'useLod' given twice"},
      {"", 10, 1, "cylinders are not supported: this file declares 2; cfuse reads points, "},
      {"", 11, 1, "circles are not supported: this file declares 1"},
      {"", 12, 1, "unexpected 'extra' after the last section (3D circles)"},
      {"", 4, 1, "load(...) must come right after the header 'V1', before the 3D points"},
      {"", 2, 6, "expected '(' after 'load', found '\"x.cao\"'"},
      {"", 2, 6, "expected the file name in double quotes, found 'x.cao)'"},
      {"", 2, 6, "the file name is empty"},
      {"", 2, 15, "unknown load parameter 's': load takes t=[x; y; z] (metres) and tu="},
      {"", 2, 22, "t=[...] needs 3 numbers separated by ';', found ']"},
      {"", 2, 26, "t is in metres: it takes no unit"},
      {"", 2, 29, "unexpected 'junk' after load(...)"},
      {"", 2, 28, "'t' given twice"},
      {"", 2, 13, "expected ',' or ')' in load(...), found the end of the line"},
      {"", 2, 25, "expected ']' after the 3 numbers of t=[...], found ';"},
      {"", 2, 6, "cannot open 'no-such.cao': no such file"},
      {"", 2, 15, "tu=[...] turns by 7.85398 rad, more than a whole turn (2π)"},
      {"", 2, 15, "tu=[...] turns by inf rad, more than a whole turn (2π)"},
  };
  REQUIRE(std::size(cases) == std::size(expected));
  std::vector<testing::BadCase> bad(std::begin(expected), std::end(expected));
  for (size_t k = 0; k < bad.size(); ++k) bad[k].text = cases[k].c_str();
  testing::ExpectRefused(
      bad.data(), bad.data() + bad.size(),
      [](const char* text, const char* name) { ImportCaoFromString(text, name); });
}

}  // namespace
}  // namespace cfuse
