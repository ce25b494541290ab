// Units of the model DSL. Lengths are stored in metres and angles in radians; a file's
// bare numbers (point coordinates, origins, limits) are in the file's `units:`.
#pragma once

#include <optional>
#include <string_view>

#include "cfuse/constraints/functions.h"

namespace cfuse {

struct Unit {
  const char* name;
  double factor;  // to SI (m, rad)
  Quantity quantity;
};

// nullptr if unknown.
const Unit* FindUnit(std::string_view name);
// "m, cm, mm, rad, deg"
const char* KnownUnits();

}  // namespace cfuse
