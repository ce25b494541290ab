// The CAO reader's sections (importers/src/cao_sections.cpp): the names given to lines and
// faces (explicit when unique, else numbered by row, moved aside from names taken), the edges
// a face from points adds for its new sides, faces walked from lines in their first line's
// direction, the area a face needs at its thresholds, and the sections that may end a file.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "cfuse/importers/cao.h"

namespace cfuse {
namespace {

template <typename Item>
std::vector<std::string> Names(const std::vector<Item>& items) {
  std::vector<std::string> out;
  for (const Item& item : items) out.push_back(item.name);
  return out;
}

Component Read(const std::string& text) {
  const ConstraintGraph g = ImportCaoFromString(text, "s.cao");
  REQUIRE(g.components.size() == 1);
  return g.components[0];
}

std::string Error(const std::string& text) {
  try {
    ImportCaoFromString(text, "s.cao");
  } catch (const InputError& e) {
    return std::to_string(e.where().line) + ":" + std::to_string(e.where().column) + ": " +
           e.message();
  }
  return "accepted";
}

// A unit square in z = 0, points 0 to 3 counter-clockwise (lines 1 to 6).
const std::string kSquare = "V1\n4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n";

TEST_CASE("cao sections: names of lines and faces", "[importers][cao]") {
  // Line 2 repeats line 0 (reversed): dropped, yet counted in the numbers. Two lines claim
  // 'rim': neither gets it. Line 3's name is unique.
  const Component c = Read(kSquare +
                           "5\n0 1 name=rim\n1 2 name=rim\n1 0\n2 3 name=top\n3 0\n"
                           "2\n4 0 1 3 4 name=square\n4 0 1 3 4 name=square\n"
                           "1\n3 0 1 2 name=l1\n");
  CHECK(Names(c.edges) == std::vector<std::string>{"l0", "l1", "top", "l4", "p2_p0"});
  // The faces from lines keep their walk; the duplicate names fall back to numbers, and the
  // face from points taking 'l1' is a face's name, apart from the edges'.
  CHECK(Names(c.faces) == std::vector<std::string>{"f0", "f1", "l1"});
  CHECK(c.faces[0].loop == std::vector<int>{0, 1, 2, 3});
  CHECK(c.faces[2].loop == std::vector<int>{0, 1, 2});
}

TEST_CASE("cao sections: a face from points adds its sides that are no edges yet",
          "[importers][cao]") {
  // A line already named like the side p0-p1 would be: that side's edge moves aside.
  const Component c = Read(kSquare + "1\n2 3 name=p0_p1\n0\n2\n4 0 1 2 3\n3 3 2 1\n");
  CHECK(Names(c.edges) == std::vector<std::string>{"p0_p1", "p0_p1_2", "p1_p2", "p3_p0", "p1_p3"});
  CHECK(c.edges[1].a == 0);
  CHECK(c.edges[1].b == 1);
  CHECK(c.edges[0].a == 2);  // the line itself, whatever its name says
  // Sides 3-2 and 2-1 are edges already, whichever their direction; 1-3 is new.
  CHECK(c.edges[4].a == 1);
  CHECK(c.edges[4].b == 3);
  CHECK(c.edges[4].where.line == 12);
}

TEST_CASE("cao sections: a face from lines is walked from its first line", "[importers][cao]") {
  // Lines 0: 1-0, 1: 1-2, 2: 3-2, 3: 3-0; walked from line 0 in its direction: 1, 0, 3, 2.
  const Component c = Read(kSquare + "4\n1 0\n1 2\n3 2\n3 0\n1\n4 0 3 2 1\n0\n");
  REQUIRE(c.faces.size() == 1);
  CHECK(c.faces[0].loop == std::vector<int>{1, 0, 3, 2});
  const Component d = Read(kSquare + "4\n1 0\n1 2\n3 2\n3 0\n1\n4 2 1 0 3\n0\n");
  CHECK(d.faces[0].loop == std::vector<int>{3, 2, 1, 0});
}

TEST_CASE("cao sections: a face needs an area", "[importers][cao]") {
  // Newell's normal against 1e-9 of the face's size squared: a sliver 1e-8 thick passes, one
  // 1e-10 thick has no area.
  const std::string thin = "V1\n3\n0 0 0\n1 0 0\n0.5 1e-8 0\n0\n0\n1\n3 0 1 2\n";
  CHECK(Read(thin).faces.size() == 1);
  CHECK(Error("V1\n3\n0 0 0\n1 0 0\n0.5 1e-10 0\n0\n0\n1\n3 0 1 2\n") ==
        "9:1: degenerate face: its points are collinear (no area)");
  // Neighbours closer than 1e-12 of the size coincide.
  CHECK(Error("V1\n4\n0 0 0\n1 0 0\n1 1e-13 0\n0 1 0\n0\n0\n1\n4 0 1 2 3\n") ==
        "10:1: degenerate face: points 1 and 2 coincide");
}

TEST_CASE("cao sections: the sections that may end a file", "[importers][cao]") {
  const std::string faces = kSquare + "0\n0\n1\n4 0 1 2 3\n";
  CHECK(Read(faces).faces.size() == 1);          // before ViSP had cylinders
  CHECK(Read(faces + "0\n").faces.size() == 1);  // or circles
  CHECK(Read(faces + "0\n0\n\n# end\n").faces.size() == 1);
  CHECK(Error(kSquare + "0\n") ==
        "8:1: the file ends before the faces from 3D lines section: expected the number of faces");
}

}  // namespace
}  // namespace cfuse
