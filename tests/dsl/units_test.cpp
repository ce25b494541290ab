// The DSL's units: each name with its factor to metres or radians and its quantity, the list
// the messages give naming exactly those, and names matched exactly.
#include "units.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <sstream>
#include <string>

namespace cfuse {
namespace {

TEST_CASE("units: factors to SI and quantities", "[dsl]") {
  const struct {
    const char* name;
    double factor;
    Quantity quantity;
  } expected[] = {{"m", 1, Quantity::Length()},
                  {"cm", 0.01, Quantity::Length()},
                  {"mm", 0.001, Quantity::Length()},
                  {"rad", 1, Quantity::Angle()},
                  {"deg", M_PI / 180, Quantity::Angle()}};
  for (const auto& e : expected) {
    INFO(e.name);
    const Unit* u = FindUnit(e.name);
    REQUIRE(u != nullptr);
    CHECK(std::string(u->name) == e.name);
    CHECK(u->factor == e.factor);
    CHECK(u->quantity == e.quantity);
  }
  CHECK(FindUnit("deg")->factor * 180 == Approx(M_PI));
  for (const char* unknown : {"M", "Deg", "km", "in", "", "mm "})
    CHECK(FindUnit(unknown) == nullptr);
}

TEST_CASE("units: the list in messages is the table", "[dsl]") {
  std::istringstream list(KnownUnits());
  int count = 0;
  for (std::string name; std::getline(list >> std::ws, name, ',');) {
    INFO(name);
    CHECK(FindUnit(name) != nullptr);
    ++count;
  }
  CHECK(count == 5);
}

}  // namespace
}  // namespace cfuse
