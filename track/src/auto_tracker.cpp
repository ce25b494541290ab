#include "cfuse/track/auto_tracker.h"

#include <chrono>

namespace cfuse {

AutoTracker::AutoTracker(const ConstraintGraph& graph, const Camera& camera,
                         std::optional<Values> initial, AutoTrackerOptions options)
    : graph_(graph), camera_(camera), options_(std::move(options)) {
  if (initial) tracker_.emplace(graph_, camera_, *initial, options_.tracker);
}

void AutoTracker::Skip() {
  if (tracker_) tracker_->Skip();
}

TrackedFrame AutoTracker::TrackWith(Tracker& tracker, const GrayView& image,
                                    const DepthFrame* depth) {
  return depth ? tracker.Track(image, *depth) : tracker.Track(image);
}

bool AutoTracker::Detect(const GrayView& image, const DepthFrame* depth, TrackedFrame* out) {
  const auto start = std::chrono::steady_clock::now();
  ++detections_;
  const Detection d = cfuse::Detect(graph_, camera_, image, options_.detector);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (d.found.empty()) {
    out->verification.why = "not detected: " + d.why;
    out->times.detection += ms;
    return false;
  }
  ++detections_found_;
  // A fresh tracker from the detected pose, on this frame: tracked and settled as a first frame,
  // kept only when the frame is verified.
  Tracker fresh(graph_, camera_, d.found[0].estimate.mean, options_.tracker);
  TrackedFrame f = TrackWith(fresh, image, depth);
  f.times.detection += ms;
  if (!f.verified) {
    out->verification = f.verification;
    out->verification.why = "detected, but not verified when tracked: " + f.verification.why;
    out->times = f.times;
    return false;
  }
  tracker_.emplace(std::move(fresh));
  f.detected = true;
  *out = std::move(f);
  return true;
}

TrackedFrame AutoTracker::Track(const GrayView& image) { return TrackFrame(image, nullptr); }

TrackedFrame AutoTracker::Track(const GrayView& image, const DepthFrame& depth) {
  return TrackFrame(image, &depth);
}

TrackedFrame AutoTracker::TrackFrame(const GrayView& image, const DepthFrame* depth) {
  TrackedFrame out;
  if (!tracker_) {
    out.estimate.mean = graph_.nominal;
    if (Detect(image, depth, &out)) lost_ = 0;
    return out;
  }
  out = TrackWith(*tracker_, image, depth);
  if (out.verified) {
    lost_ = 0;
    return out;
  }
  if (++lost_ < options_.redetect_after) return out;
  TrackedFrame detected;
  if (Detect(image, depth, &detected)) {
    lost_ = 0;
    detected.times += out.times;
    return detected;
  }
  // Not found: the lost frame as the tracker saw it, with detection's time and reason added.
  out.times.detection += detected.times.detection;
  if (!detected.verification.why.empty()) {
    out.verification.why += "; " + detected.verification.why;
  }
  return out;
}

}  // namespace cfuse
