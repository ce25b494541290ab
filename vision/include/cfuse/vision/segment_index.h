// An index of image segments for the tracker's queries: "which segments lie near this
// predicted model segment, at about its orientation?" (Lowe 1992: a 3D array over the
// segments' midpoint x, midpoint y and orientation).
//
// Cells are `cell` pixels square and `orientation_bins` bins over [0, π) (a segment has no
// arrow). A query for midpoints within `radius` of a point and orientations within `angle` of
// a direction visits only the cells that window overlaps (the orientation wrapping around π),
// then tests each segment in them exactly. Built in O(n), queried in O(cells touched + segments
// in them).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/vision/segments.h"

namespace cfuse {

class SegmentIndex {
 public:
  SegmentIndex(std::vector<ImageSegment> segments, int width, int height, float cell = 16,
               int orientation_bins = 18);

  // Indices into segments() of those with the midpoint within `radius` px of `centre` (in
  // each coordinate: the window is square) and an orientation within `angle` rad of
  // `orientation` (modulo π), in increasing order. Appends to `out` after clearing it.
  void Query(const Eigen::Vector2f& centre, float radius, float orientation, float angle,
             std::vector<int>* out) const;

  const std::vector<ImageSegment>& segments() const { return segments_; }
  // Cells visited by the last query (for tests and the benchmark).
  int last_cells_visited() const { return last_cells_; }

 private:
  int CellX(float x) const;
  int CellY(float y) const;
  int Bin(float orientation) const;

  std::vector<ImageSegment> segments_;
  std::vector<float> orientation_;  // per segment, in [0, π)
  std::vector<Eigen::Vector2f> midpoint_;
  float cell_;
  int nx_, ny_, nbins_;
  // Compressed rows: the segments of cell (cx, cy, bin) are ids_[start_[c] .. start_[c + 1]).
  std::vector<int> start_, ids_;
  mutable int last_cells_ = 0;
};

}  // namespace cfuse
