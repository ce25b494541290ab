#include "units.h"

#include <array>
#include <cmath>

namespace cfuse {
namespace {
const std::array<Unit, 5> kUnits = {{
    {"m", 1.0, Quantity::Length()},
    {"cm", 0.01, Quantity::Length()},
    {"mm", 0.001, Quantity::Length()},
    {"rad", 1.0, Quantity::Angle()},
    {"deg", M_PI / 180.0, Quantity::Angle()},
}};
}  // namespace

const Unit* FindUnit(std::string_view name) {
  for (const Unit& u : kUnits) {
    if (name == u.name) return &u;
  }
  return nullptr;
}

const char* KnownUnits() { return "m, cm, mm, rad, deg"; }

}  // namespace cfuse
