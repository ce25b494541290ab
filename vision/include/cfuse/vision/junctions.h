// Junctions: where two detected segments end at a common corner, the image of a model's vertex
// where two of its edges meet (an L-junction). They seed the detection of an object with no pose
// given: a junction and the far ends of its two arms are three image points to match with a
// vertex and its two neighbours along the model's edges.
//
// Two segments form a junction when their lines cross at a point `max_gap` px or less from one
// end of each, at an angle of at least `min_angle`, and the crossing lies beyond or near those
// ends rather than well inside either segment (a segment ending on the middle of another is a
// T-junction: one edge passing behind another, no vertex).
//
// Coordinates: pixels, as for segments.h.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/vision/edge_orientations.h"
#include "cfuse/vision/segments.h"

namespace cfuse {

struct JunctionOptions {
  double max_gap = 6;           // px from the crossing to each segment's end
  double min_angle = 0.35;      // rad between the two segments (20 degrees)
  double min_arm_length = 12;   // px: shorter segments make no arm
};

struct Junction {
  Eigen::Vector2d corner;  // where the two lines cross
  // Per arm: the segment (index into the detected segments), the end of it at the corner (0: a,
  // 1: b), its far end, and the unit direction from the corner towards that far end.
  int segment[2] = {-1, -1};
  int end[2] = {0, 0};
  Eigen::Vector2d far[2];
  Eigen::Vector2d direction[2];
  double strength = 0;  // the lesser of the two segments' contrasts times the shorter arm, px
};

// Every junction of `segments`, strongest first.
std::vector<Junction> FindJunctions(const std::vector<ImageSegment>& segments,
                                    const JunctionOptions& options = {});

// Where arm `arm` of junction `j` may end at the next vertex: its segment's far end, and the
// corners of other junctions that lie on the arm's line beyond it (within `max_gap` px across it,
// at least min_arm_length px along) with an arm pointing back (within min_angle / 2): an edge
// whose segment broke on texture, a highlight or an occluder still joins its two corners. At most
// `max_ends` points, the segment's far end first, then the nearest corners.
std::vector<Eigen::Vector2d> ArmEnds(const std::vector<Junction>& junctions, int j, int arm,
                                     const JunctionOptions& options = {}, int max_ends = 3);

// Where arm `arm` of `junction` ends along the image's steps: from its segment's far end on
// along the arm's line, 1 px at a time, to the last point with a step of the arm's own
// orientation bin (EdgeOrientations, within its spread) no more than `max_gap` px past the one
// before. Its segment's far end when the steps go on for 4 px or less. A segment broken by
// texture, a highlight or a dark patch on an edge ends well short of the edge's far corner, while
// the edge's steps go on: P3P from a junction needs that corner, not where a segment broke.
Eigen::Vector2d TracedEnd(const Junction& junction, int arm, const EdgeOrientations& steps,
                          double max_gap);

}  // namespace cfuse
