// An object's ViSP CAO model (version 1) as a constraint model (docs/cao.md).
//
//   ConstraintGraph cube = ImportCao("cube.cao");
//
// ViSP's model-based trackers describe the object to track in a `.cao` file: a `V1` header,
// optional `load("part.cao", t=[...], tu=[...])` lines, then six sections, each a count and
// that many rows: 3D points (X Y Z, metres), 3D lines (two point indices), faces from lines (n
// and n line indices), faces from points (n and n point indices), 3D cylinders and 3D circles.
// Rows of lines and faces may end with `name=...`, `useLod=...`, `minLineLengthThreshold=...`
// or `minPolygonAreaThreshold=...` (the level-of-detail settings are read and ignored).
//
// The model is one rigid component at the identity pose, named after the file's stem (made an
// identifier: other characters become '_', a leading digit gets a '_' before it):
//   - points `p0`, `p1`, ... in file order;
//   - edges: each 3D line (named by its `name=` if no other line of the file has that name,
//     else `l<i>`, i its row in the section), then every side of a face that is not a line yet,
//     named after its points (`p3_p7`); an edge is kept once, whichever its direction;
//   - faces from lines `f0`, `f1`, ..., then faces from points continuing the numbering (or
//     their `name=`). A face given by lines is one closed loop: its points are ordered by
//     walking its lines, starting with its first line in that line's direction.
// ViSP orders a face's points counter-clockwise seen from outside (its visibility test takes
// Newell's normal of the points in file order as the outward normal), which is cfuse's
// convention (graph.h, Face): loops are kept in file order.
//
// `load(...)` merges another CAO file (relative to the including file) into the same
// component, its points mapped by x_including = Exp(tu) x_loaded + t (t in metres, tu a rotation
// vector θu in radians, or degrees with `deg`); its names get the prefix `<stem>_` (a second
// load of the same stem in one file `<stem>_2_`, ...). Loads nest up to kMaxCaoLoadDepth files;
// a cycle is an error. Cylinders and circles are refused unless their count is 0.
//
// Every problem is an InputError at FILE:LINE:COLUMN (docs/cao.md has the list).
#pragma once

#include <string>
#include <string_view>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/error.h"

namespace cfuse {

inline constexpr size_t kMaxCaoFileBytes = 16u << 20;
// Points, edges and faces of the whole model, loads counted in; a section's count and a face's
// size are bounded by the same numbers. A closed triangle mesh of V points has about 2V faces
// and 3V edges. Import time is linear in the size (0.7 s for 20 000 points, lines and faces).
inline constexpr int kMaxCaoPoints = 20000;
inline constexpr int kMaxCaoEdges = 60000;
inline constexpr int kMaxCaoFaces = 40000;
inline constexpr int kMaxCaoLoadDepth = 16;   // files open at once, counting the top file
inline constexpr int kMaxCaoFilesRead = 256;  // in all, counting repeated loads

// Reads the CAO file at `path`; `included_from` is the include that asked for it, if any (for a
// missing file).
ConstraintGraph ImportCao(const std::string& path, const SourceLocation& included_from = {});

// The same from text in memory; `display_name` stands for the file in messages (and names the
// model), `base_directory` resolves relative loads.
ConstraintGraph ImportCaoFromString(std::string_view text, const std::string& display_name,
                                    const std::string& base_directory = ".");

}  // namespace cfuse
