// A robot's URDF as a constraint model (docs/urdf.md).
//
//   ConstraintGraph robot = ImportUrdf("panda.urdf");
//
// urdfdom reads the robot; a first pass over the XML with TinyXML (the parser urdfdom itself
// uses) checks what urdfdom would refuse without saying where, and what it accepts but a model
// cannot hold, so that every problem is an InputError at FILE:LINE:COLUMN naming the element:
// XML errors, unknown links, two roots or a cycle, a zero-length axis, inverted limits, a mimic
// joint naming no joint.
//
// The model:
//   - Links joined by fixed joints are one rigid body: one component, named after the link
//     nearest the root, whose frame is that link's frame. The other links become frames on it
//     (ComponentFrame), so forward kinematics and results still report their poses. A joint
//     whose limits are equal (lower = upper) is locked there and merged the same way.
//   - Feature points of a link: `origin` (its frame's origin) and, from its visual and
//     collision geometry, the corners of each box (`box<k>_c<i>`, i = 0..7 with bit 0, 1, 2 of
//     i choosing -/+ half the size along x, y, z) and its six faces (`box<k>_nx`, `_px`, `_ny`,
//     `_py`, `_nz`, `_pz`, outward normals along -x, +x, ...: the edges a tracker matches),
//     the cap centres of each cylinder
//     (`cyl<k>_top` at +length/2 along its z, `cyl<k>_bottom`) and the centre of each sphere
//     (`sphere<k>`); k counts that kind in the link, visual before collision, and a geometry
//     whose points repeat an earlier one's is skipped. Meshes are referenced, not loaded: they
//     give no points. A merged link's points are named `<link>_<point>` on its component.
//   - Joints: revolute, continuous, prismatic (limits as range inequalities), planar, floating
//     (no constraint), mimic (an equality between the two joint variables).
//   - The root link's component sits at the identity.
// Names that are not identifiers ([A-Za-z_][A-Za-z0-9_]*) have every other character replaced
// by '_' (ur5's joint `base_link-base_fixed_joint`).
#pragma once

#include <string>
#include <string_view>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/error.h"

namespace cfuse {

inline constexpr size_t kMaxUrdfFileBytes = 16u << 20;

// Reads the URDF at `path`; `where` is the include that asked for it, if any (for a missing
// file).
ConstraintGraph ImportUrdf(const std::string& path, const SourceLocation& where = {});

// The same from text in memory; `display_name` stands for the file in messages.
ConstraintGraph ImportUrdfFromString(std::string_view xml, const std::string& display_name);

}  // namespace cfuse
