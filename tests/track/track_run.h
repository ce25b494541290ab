// Tracking a rendered sequence with known truth, shared by the tracker's tests: the share of
// frames verified and the errors of the verified ones.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "cfuse/interp/joint_estimates.h"
#include "cfuse/track/tracker.h"
#include "cfuse/vision/sequence.h"

namespace cfuse::testing {

inline GrayView View(const Rendering& r) { return {r.pixels.data(), r.width, r.height, r.width}; }

// A 4 x 4 camera_from_object matrix, row by row, as Castle-simu's CameraPose/ files hold it.
inline Rigid3d ReadPoseMatrix(const std::string& path) {
  std::ifstream in(path);
  double m[16];
  for (double& x : m) in >> x;
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = m[4 * i + j];
  return Rigid3d(Eigen::Quaterniond(r).normalized(), Eigen::Vector3d(m[3], m[7], m[11]));
}

struct Errors {
  int frames = 0, verified = 0;
  std::vector<double> translation_mm, rotation_deg, joint_deg;  // of the verified frames
  std::vector<TrackedFrame> track;

  // Verified frames with the first joint more than `degrees` off.
  long JointOff(double degrees) const {
    return std::count_if(joint_deg.begin(), joint_deg.end(), [&](double d) { return d > degrees; });
  }

  static double Quantile(std::vector<double> v, double q) {
    if (v.empty()) return 0;
    std::sort(v.begin(), v.end());
    return v[static_cast<size_t>(q * static_cast<double>(v.size() - 1))];
  }
};

// The root's (component 0's) error, and the first joint's, on every verified frame.
inline Errors Run(const ConstraintGraph& graph, const std::vector<SequenceFrame>& frames,
                  const Values& initial, TrackerOptions options = {}) {
  Tracker tracker(graph, StandardCamera(), initial, options);
  Errors out;
  for (const SequenceFrame& frame : frames) {
    TrackedFrame f = tracker.Track(View(frame.rendering));
    ++out.frames;
    if (f.verified) {
      ++out.verified;
      const Rigid3d& estimate = f.estimate.mean.poses[0];
      const Rigid3d& truth = frame.truth.poses[0];
      out.translation_mm.push_back(1000 * (estimate.translation - truth.translation).norm());
      out.rotation_deg.push_back(estimate.rotation.angularDistance(truth.rotation) * 180 / M_PI);
      if (!graph.joints.empty()) {
        out.joint_deg.push_back(
            std::abs(JointValues(graph, f.estimate.mean)[0] - JointValues(graph, frame.truth)[0]) *
            180 / M_PI);
      }
    }
    out.track.push_back(std::move(f));
  }
  return out;
}

}  // namespace cfuse::testing
