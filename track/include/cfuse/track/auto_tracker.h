// A tracker that finds the object by itself: with no start, detection (detector.h) on each frame
// until the object is found, then Lowe's tracking from there (tracker.h); after the tracker has
// lost it for `redetect_after` frames (its own re-acquisition, rings about the last pose seen,
// having found nothing), detection over the whole image on each frame until it is found again.
//
// A detected pose starts a fresh tracker on the same frame: the frame is tracked and settled
// from it as a first frame is, and only a verified frame counts as found.
#pragma once

#include <optional>

#include "cfuse/track/detector.h"
#include "cfuse/track/tracker.h"

namespace cfuse {

struct AutoTrackerOptions {
  TrackerOptions tracker;
  DetectorOptions detector;
  // Frames lost in a row before detection runs (the tracker's own re-acquisition first).
  int redetect_after = 2;
};

class AutoTracker {
 public:
  // `initial`: every component's pose at the first frame, or nothing: the first frame is
  // detected. Throws InputError as Tracker does for a camera without a size.
  AutoTracker(const ConstraintGraph& graph, const Camera& camera,
              std::optional<Values> initial = std::nullopt, AutoTrackerOptions options = {});

  // A lost frame's estimate is the tracker's prediction, or the model's nominal configuration
  // before the object was ever found; its verification says why it was not found.
  TrackedFrame Track(const GrayView& image);
  // The same with a range sensor's frame (Tracker::Track's).
  TrackedFrame Track(const GrayView& image, const DepthFrame& depth);
  // A frame with no image: the prediction spans it.
  void Skip();

  // Detections run, and those that found the object.
  int detections() const { return detections_; }
  int detections_found() const { return detections_found_; }

 private:
  // Detection on `image`; a found pose restarts the tracker on this frame. True when the frame
  // was then verified (written to *out).
  bool Detect(const GrayView& image, const DepthFrame* depth, TrackedFrame* out);
  TrackedFrame TrackFrame(const GrayView& image, const DepthFrame* depth);
  // The tracker's frame, with the depth frame when there is one.
  static TrackedFrame TrackWith(Tracker& tracker, const GrayView& image, const DepthFrame* depth);

  const ConstraintGraph& graph_;
  Camera camera_;
  AutoTrackerOptions options_;
  std::optional<Tracker> tracker_;
  int lost_ = 0;  // frames lost in a row
  int detections_ = 0, detections_found_ = 0;
};

}  // namespace cfuse
