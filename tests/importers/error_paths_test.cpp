// Error paths of the importers that the other tests leave out (issue 8): every URDF element
// refused at its line, column and element, what urdfdom alone refuses located at the joint it
// names, and a CAO load whose prefixed names clash.
#include <fmt/format.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <string>

#include "cfuse/importers/cao.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/importers/visp.h"
#include "cfuse/kernel/error.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

struct UrdfCase {
  const char* xml;
  int line, column;
  const char* element;
  const char* message;  // the start of the message
};

void ExpectRefused(const UrdfCase& c) {
  INFO(c.xml);
  try {
    ImportUrdfFromString(c.xml, "bad.urdf");
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().file == "bad.urdf");
    CHECK(e.where().line == c.line);
    CHECK(e.where().column == c.column);
    CHECK(e.where().element == c.element);
    CHECK_THAT(e.message(), Catch::Matchers::StartsWith(c.message));
  }
}

#define LINKS_AB "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/>\n"
#define LINKS_ABC "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/><link name=\"c\"/>\n"

// TinyXML parses nested elements by recursion: 10^5 of them (300 KB) overflowed the stack, in
// the URDF importer (and urdfdom's own parse) and the ViSP camera reader alike. Nesting deeper
// than 256 elements is refused at the element that goes too deep (importers/src/xml_document.h);
// this test crashed before.
TEST_CASE("error paths: XML nested too deep for TinyXML is refused, not a crash",
          "[importers][errors]") {
  std::string deep;
  for (int i = 0; i < 100000; ++i) deep += "<link>";
  const std::string urdf = "<robot name=\"r\">\n" + deep;
  try {
    ImportUrdfFromString(urdf, "deep.urdf");
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) ==
          "deep.urdf:2:1531: error: elements nested more than 256 deep");  // the 256th <link>
  }
  const std::string camera = "<?xml version=\"1.0\"?>\n<conf>" + deep;
  CHECK_THROWS_WITH(ReadVispCameraFromString(camera, "deep.xml"),
                    "deep.xml:2:1537: error: elements nested more than 256 deep");
  // Comments, declarations and empty elements do not count; 256 levels are parsed.
  std::string fine = "<?xml version=\"1.0\"?><!-- <a> <b> -->\n<conf>";
  for (int i = 0; i < 255; ++i) fine += "<a x=\"<b>\"/><a>";
  fine += "<camera/>";
  for (int i = 0; i < 255; ++i) fine += "</a>";
  fine += "</conf>\n";
  CHECK_THROWS_WITH(ReadVispCameraFromString(fine, "fine.xml"),
                    Catch::Matchers::Contains("these ViSP tracker settings have no <camera>"));
}

TEST_CASE("error paths: URDF elements refused at their place", "[importers][errors]") {
  const UrdfCase cases[] = {
      {"<?xml version=\"1.0\"?>\n<!-- no element -->\n", 0, 0, "",
       "not a URDF file: no root element"},
      {"<robot name=\"r\">\n<link/></robot>", 2, 1, "", "a <link> needs a 'name'"},
      {LINKS_AB "<joint type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint></robot>", 2,
       1, "", "a <joint> needs a 'name'"},
      {LINKS_ABC
       "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n"
       "<joint name=\"j\" type=\"fixed\"><parent link=\"b\"/><child link=\"c\"/></joint>"
       "</robot>",
       3, 1, "joint 'j'", "duplicate joint name 'j', first defined at line 2"},
      {LINKS_AB "<joint name=\"j\"><parent link=\"a\"/><child link=\"b\"/></joint></robot>", 2, 1,
       "joint 'j'", "a <joint> needs a 'type'"},
      {LINKS_AB "<joint name=\"j\" type=\"fixed\"><child link=\"b\"/></joint></robot>", 2, 1,
       "joint 'j'", "a <joint> needs a <parent>"},
      {LINKS_AB "<joint name=\"j\" type=\"fixed\"><parent/><child link=\"b\"/></joint></robot>", 2,
       30, "joint 'j'", "<parent> needs a 'link'"},
      {LINKS_AB "<joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"a\"/></joint>"
                "</robot>",
       2, 48, "joint 'j'", "joins link 'a' to itself"},
      {LINKS_AB "<joint name=\"j\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>\n"
                "<axis/></joint></robot>",
       3, 1, "joint 'j'", "<axis> needs the attribute 'xyz'"},
      {LINKS_AB "<joint name=\"j\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>\n"
                "<mimic/></joint></robot>",
       3, 1, "joint 'j'", "<mimic> needs a 'joint'"},
      {LINKS_AB "<joint name=\"j\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>\n"
                "<mimic joint=\"j\"/></joint></robot>",
       3, 1, "joint 'j'", "mimics itself"},
      {"<robot name=\"r\"><link name=\"a\">\n<visual><geometry></geometry></visual></link></robot>",
       2, 9, "link 'a'", "<geometry> has no shape"},
      {"<robot name=\"r\"><link name=\"a\">\n<visual><geometry><box size=\"1 -1 1\"/></geometry>"
       "</visual></link></robot>",
       2, 19, "link 'a'", "<box> size is negative"},
      // A locked joint (lower = upper) is merged into its parent: it has no variable to mimic.
      {LINKS_ABC "<joint name=\"j\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/>"
                 "</joint>\n<joint name=\"k\" type=\"revolute\"><parent link=\"b\"/><child "
                 "link=\"c\"/><limit lower=\"0.5\" upper=\"0.5\" effort=\"1\" velocity=\"1\"/>\n"
                 "<mimic joint=\"j\"/></joint></robot>",
       4, 1, "joint 'k'", "a locked (lower = upper) joint cannot mimic: it has no variable"},
      // Fixed joints whose names become the same identifier.
      {LINKS_ABC "<joint name=\"j-1\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/>"
                 "</joint>\n<joint name=\"j_1\" type=\"fixed\"><parent link=\"b\"/><child "
                 "link=\"c\"/></joint></robot>",
       3, 1, "joint 'j_1'", "duplicate joint name 'j_1'"},
      // What only urdfdom refuses: at the joint its message names (it gives no line).
      {LINKS_AB "<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/>\n"
                "<limit lower=\"0\" upper=\"1\"/></joint></robot>",
       2, 1, "joint 'j'", "urdfdom cannot read this URDF: joint limit: no effort"},
      {LINKS_AB "<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/>\n"
                "<limit lower=\"0\" upper=\"1\" effort=\"1\" velocity=\"1\"/><dynamics "
                "damping=\"x\"/></joint></robot>",
       2, 1, "joint 'j'", "urdfdom cannot read this URDF: damping value (x) is not a valid float"},
  };
  for (const UrdfCase& c : cases) ExpectRefused(c);
}

#undef LINKS_AB
#undef LINKS_ABC

TEST_CASE("error paths: a CAO load whose prefixed names clash with another's",
          "[importers][errors]") {
  const fs::path dir = fs::temp_directory_path() / fmt::format("cfuse_cao_errors_{}", ::getpid());
  fs::create_directories(dir);
  std::ifstream cube(testing::SourcePath("tests/data/cao/cube.cao"));
  const std::string text((std::istreambuf_iterator<char>(cube)), std::istreambuf_iterator<char>());
  std::ofstream(dir / "y.cao") << text;
  std::ofstream(dir / "x_y.cao") << text;
  // x.cao loads y.cao, so its points are y_p0...; loaded from main.cao they become x_y_p0...,
  // the names x_y.cao's own points take there.
  std::ofstream(dir / "x.cao") << "V1\nload(\"y.cao\")\n0\n0\n0\n0\n0\n";
  std::ofstream(dir / "main.cao") << "V1\nload(\"x.cao\")\nload(\"x_y.cao\")\n0\n0\n0\n0\n0\n";
  try {
    ImportCao((dir / "main.cao").string());
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(e.where().file == (dir / "main.cao").string());
    CHECK(e.where().line == 3);
    CHECK(e.where().column == 6);
    CHECK_THAT(e.message(),
               Catch::Matchers::StartsWith("the point 'x_y_p0' from '") &&
                   Catch::Matchers::EndsWith("x_y.cao' is already defined: rename the file to "
                                             "change its prefix"));
  }
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace cfuse
