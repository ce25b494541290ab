// The tracker's places other than the prediction (tracker.h): the rings of re-acquisition, and
// the settling of a frame verified after a loss from places about its estimate, along the line
// of sight and across each joint's range, and about the pose last verified.
#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <string>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/track/tracker.h"

namespace cfuse {

namespace {

// `values` with every pose and point moved by `shift` (camera frame).
Values Shifted(Values values, const Eigen::Vector3d& shift) {
  for (Rigid3d& pose : values.poses) pose.translation += shift;
  for (Eigen::Vector3d& point : values.points) point += shift;
  return values;
}

}  // namespace

Eigen::Vector3d Tracker::RootOrigin(const Values& values) const {
  const Block& root = graph_.blocks[graph_.components[0].block];
  return root.kind == BlockKind::kPose ? values.poses[root.index].translation
                                       : values.points[root.index];
}

double Tracker::PixelsPerMetre(double depth) const {
  return camera_.model == Camera::Model::kOrthographic
             ? camera_.scale
             : 0.5 * (camera_.fx + camera_.fy) / std::max(0.05, depth);
}

Values Tracker::RingPlace(const Values& centre, int ring, double angle) const {
  // Rings 2 ranges apart: each place's search (twice the usual range) reaches its neighbours.
  const double radius =
      2 * options_.search_pixels * ring / PixelsPerMetre(RootOrigin(centre).z());
  return Shifted(centre, Eigen::Vector3d(radius * std::cos(angle), radius * std::sin(angle), 0));
}

bool Tracker::Reacquire(const GrayView& image, const Values& centre, TrackedFrame* out) {
  // The better of two frames: verified, then the more of the outline supported.
  auto better = [](const TrackedFrame& a, const TrackedFrame& b) {
    if (a.verified != b.verified) return a.verified;
    return a.verification.supported > b.verification.supported;
  };
  bool found = false;
  auto try_all = [&](const std::vector<Values>& places) {
    for (const Values& place : places) {
      TrackedFrame attempt = TryPlace(image, place);
      FrameTimes spent = out->times;
      spent += attempt.times;
      const int branches = out->branches + attempt.branches;
      if (attempt.verified && better(attempt, *out)) {
        attempt.doublings = out->doublings;
        *out = std::move(attempt);
        found = true;
      }
      out->times = spent;
      out->branches = branches;
    }
  };
  // Rings about the last place seen, a ring further out each frame, round again once they
  // leave the image; the best of the first ring that finds the object is kept. (Each joint
  // across its range as well was tried: a lid searched over its whole range finds clutter and
  // the box's rim to match more often than its image, and was verified wrong in 4 % of the
  // realistic renders' frames; docs/benchmarks.md.)
  const double last_ring = std::max(camera_.width, camera_.height) / (2 * options_.search_pixels);
  int ring = reacquisition_ring_, tried = 0;
  while (tried < options_.reacquisition_places && !found) {
    ++ring;
    if (ring > last_ring) {
      if (ring == 1) break;  // (an image smaller than a ring)
      ring = 0;
      continue;
    }
    std::vector<Values> places;
    for (int k = 0; k < 6 * ring && tried < options_.reacquisition_places; ++k, ++tried) {
      places.push_back(RingPlace(centre, ring, 2 * M_PI * k / (6 * ring)));
    }
    try_all(places);
  }
  reacquisition_ring_ = ring;
  return found;
}

bool Tracker::ReacquireLost(const GrayView& image, TrackedFrame* out) {
  const int ring = reacquisition_ring_;
  if (Reacquire(image, history_.back().second, out)) return true;
  if (!options_.reacquire_about_last_verified) return false;
  const bool strayed = history_.back().first != last_verified_ &&
                       Apart(history_.back().second, last_seen_) > options_.search_pixels;
  if (!strayed) return false;
  // The same rings about the verified pose; the next frame goes on from the further of the two.
  const int reached = reacquisition_ring_;
  reacquisition_ring_ = ring;
  const bool found = Reacquire(image, last_seen_, out);
  reacquisition_ring_ = std::max(reached, reacquisition_ring_);
  return found;
}

Values Tracker::DepthPlace(const Values& centre, int k) const {
  const Eigen::Vector3d at = RootOrigin(centre);
  if (camera_.model == Camera::Model::kOrthographic || at.z() <= 0) return centre;
  // Along the line of sight through the root's origin, so that the outline keeps its centre,
  // each step moving its points at the RMS radius 2 x search_pixels (as a ring does).
  const double outline =
      std::max(radius_[graph_.components[0].block], 1e-3) * PixelsPerMetre(at.z());
  const double step = std::min(0.2, 2 * options_.search_pixels / outline);
  return Shifted(centre, step * (k / 2 + 1) * (k % 2 == 0 ? 1 : -1) * at);
}

Values Tracker::TiltPlace(const Values& centre, int k) const {
  const Eigen::Vector3d at = RootOrigin(centre);
  if (at.z() <= 0) return centre;
  // Turned about the image's x (k = 0, 1) or y axis (k = 2, 3) through the root's origin, each
  // way in turn: the outline's points at the RMS radius move 2 x search_pixels (as a ring's),
  // and its far side moves in depth as its near side comes out. A pose tilted so against the
  // truth and moved in depth to make up for it lines up many of a castle's edges with others
  // parallel to them.
  const double outline =
      std::max(radius_[graph_.components[0].block], 1e-3) * PixelsPerMetre(at.z());
  const double angle = std::min(0.35, 2 * options_.search_pixels / outline);
  const Eigen::Vector3d axis = k < 2 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(k % 2 == 0 ? angle : -angle, axis));
  Values out = centre;
  for (Rigid3d& pose : out.poses) {
    pose.rotation = turn * pose.rotation;
    pose.translation = at + turn * (pose.translation - at);
  }
  for (Eigen::Vector3d& point : out.points) point = at + turn * (point - at);
  return out;
}

double Tracker::Apart(const Values& a, const Values& b) const {
  double worst = 0;
  for (const Component& c : graph_.components) {
    if (!c.rigid || c.points.empty()) continue;
    const Block& block = graph_.blocks[c.block];
    const Rigid3d& pa = a.poses[block.index];
    const Rigid3d& pb = b.poses[block.index];
    double sum = 0;
    for (const auto& p : c.points) sum += ((pa * p.position) - (pb * p.position)).squaredNorm();
    const double rms = std::sqrt(sum / static_cast<double>(c.points.size()));
    worst = std::max(worst, rms * PixelsPerMetre(pa.translation.z()));
  }
  return worst;
}

bool Tracker::Settleable(const Joint& joint) const {
  return HasJointVariable(joint.type) && !joint.mimic && graph_.components[joint.parent].rigid &&
         graph_.components[joint.child].rigid;
}

double Tracker::JointValue(const Joint& joint, const Values& values) const {
  const Rigid3d& world_from_parent =
      values.poses[graph_.blocks[graph_.components[joint.parent].block].index];
  const Rigid3d& world_from_child =
      values.poses[graph_.blocks[graph_.components[joint.child].block].index];
  // The joint's motion: its angle about, or its shift along, the axis.
  const Rigid3d motion = joint.parent_from_joint.Inverse() * world_from_parent.Inverse() *
                         world_from_child * joint.child_from_joint;
  return ModelOf(joint.type).Variable(joint.axis, motion);
}

double Tracker::JointPixels(const Joint& joint, const Values& values) const {
  const Component& child = graph_.components[joint.child];
  const double pixels =
      PixelsPerMetre(values.poses[graph_.blocks[child.block].index].translation.z());
  return ModelOf(joint.type).VariableIsLength() ? pixels
                                             : pixels * std::max(radius_[child.block], 1e-3);
}

bool Tracker::PushedToLimit(const Values& estimate, const Values& predicted) const {
  for (const Joint& joint : graph_.joints) {
    if (!Settleable(joint) || !joint.limits) continue;
    const double pixels = JointPixels(joint, estimate);
    const double now = JointValue(joint, estimate);
    const double was = JointValue(joint, predicted);
    for (const double limit : {joint.limits->first, joint.limits->second}) {
      if (std::abs(now - limit) * pixels < 1 &&
          std::abs(was - limit) * pixels > options_.search_pixels) {
        return true;
      }
    }
  }
  return false;
}

std::vector<Values> Tracker::JointPlaces(const Values& centre) const {
  std::vector<Values> out;
  for (const Joint& joint : graph_.joints) {
    if (!Settleable(joint)) continue;
    const Rigid3d& world_from_parent =
        centre.poses[graph_.blocks[graph_.components[joint.parent].block].index];
    const Rigid3d& world_from_child =
        centre.poses[graph_.blocks[graph_.components[joint.child].block].index];
    const bool prismatic = ModelOf(joint.type).VariableIsLength();
    const double now = JointValue(joint, centre);
    std::vector<double> values;
    if (joint.limits) {
      const auto [lower, upper] = *joint.limits;
      for (int k = 0; k < options_.settle_joint_values; ++k) {
        values.push_back(lower + (k + 0.5) * (upper - lower) / options_.settle_joint_values);
      }
    } else if (!prismatic) {
      for (int k = 1; k <= options_.settle_joint_values; ++k) {
        values.push_back(now + 2 * M_PI * k / (options_.settle_joint_values + 1));
      }
    }
    // The child's subtree moves with it.
    std::vector<bool> moved(graph_.components.size(), false);
    moved[joint.child] = true;
    for (bool grew = true; grew;) {
      grew = false;
      for (const Joint& j : graph_.joints) {
        if (moved[j.parent] && !moved[j.child]) moved[j.child] = grew = true;
      }
    }
    for (double q : values) {
      const Rigid3d placed = world_from_parent * joint.parent_from_joint *
                             JointMotion(joint.type, joint.axis, q) *
                             joint.child_from_joint.Inverse();
      const Rigid3d delta = placed * world_from_child.Inverse();
      Values v = centre;
      for (size_t c = 0; c < graph_.components.size(); ++c) {
        if (!moved[c]) continue;
        const Block& b = graph_.blocks[graph_.components[c].block];
        if (b.kind == BlockKind::kPose) {
          v.poses[b.index] = delta * v.poses[b.index];
        } else {
          v.points[b.index] = delta * v.points[b.index];
        }
      }
      MatchSlacks(graph_, &v);
      out.push_back(std::move(v));
    }
  }
  return out;
}

void Tracker::Settle(const GrayView& image, TrackedFrame* out) {
  std::vector<Values> places;
  // A track's first frame supported along most of its outline is not a pose slid, tilted or set
  // on a window: those line up half to two thirds of it. (A frame after a loss is settled from
  // every place: the object may have moved anywhere while it was lost.)
  const bool plain =
      verified_frames_ == 0 && out->verification.share >= options_.settle_places_below_share;
  for (int k = 0; !plain && k < options_.settle_places; ++k) {
    places.push_back(RingPlace(out->estimate.mean, 1, 2 * M_PI * k / options_.settle_places));
  }
  // A range sensor's points on the faces fix the depth and the tilt that edges leave loose:
  // places along the line of sight and tilted ones are for edges alone.
  const bool depth_fused = depth_ != nullptr && out->depth_points > 0;
  for (int k = 0; !plain && !depth_fused && k < options_.settle_depths; ++k) {
    places.push_back(DepthPlace(out->estimate.mean, k));
  }
  // (At a track's first frame only: after a loss the frames before held the object's
  // attitude, and tilted places there found clutter more often than the object. And only on a
  // weakly supported one: a tilted minimum lines up about half the outline.)
  const bool tilt = verified_frames_ == 0 && !depth_fused &&
                    out->verification.share < options_.settle_tilts_below_share;
  const size_t tilts_from = places.size();
  for (int k = 0; tilt && k < options_.settle_tilts; ++k) {
    places.push_back(TiltPlace(out->estimate.mean, k));
  }
  const size_t tilts_to = places.size();
  for (Values& v : JointPlaces(out->estimate.mean)) places.push_back(std::move(v));
  // After a loss, where the object was last seen too (TrackerOptions::settle_from_last_seen).
  if (options_.settle_from_last_seen && verified_frames_ > 0) {
    places.push_back(last_seen_);
    for (Values& v : JointPlaces(last_seen_)) places.push_back(std::move(v));
  }

  FrameTimes spent = out->times;
  int branches = out->branches;
  std::optional<TrackedFrame> best;
  const double searched_outline = best_outline_;
  const std::optional<GaussianState> searched_undetermined = undetermined_;
  std::string ambiguous;  // a joint verified as well at a value far from the frame's
  const double frame_evidence = ExplainedEvidence(out->verification);
  for (size_t index = 0; index < places.size(); ++index) {
    TrackedFrame attempt = TryPlace(image, places[index]);
    spent += attempt.times;
    branches += attempt.branches;
    if (!attempt.verified) continue;
    const double evidence = ExplainedEvidence(attempt.verification);
    const bool tilted = index >= tilts_from && index < tilts_to;
    // A tilted place only replaces the frame, when it explains far more: on a real close-up
    // (castel) places tilted a few degrees find poses about as well supported, 10 mm from the
    // reference with depth, and at the usual decisive share they replaced or refused right
    // frames.
    if (tilted) {
      if (evidence >= options_.settle_tilts_decisive_share * frame_evidence &&
          (!best || evidence > ExplainedEvidence(best->verification))) {
        best = std::move(attempt);
      }
      continue;
    }
    if (evidence >= options_.decisive_share * frame_evidence) {
      if (!best || evidence > ExplainedEvidence(best->verification)) {
        best = std::move(attempt);
      }
      continue;
    }
    if (!ambiguous.empty() ||
        options_.decisive_share * evidence < frame_evidence) {
      continue;
    }
    // Not decisively worse: the same answer, unless a joint differs by more than the search
    // reaches (its child's points moved search_pixels in the image).
    for (const Joint& joint : graph_.joints) {
      if (!Settleable(joint)) continue;
      const double here = JointValue(joint, out->estimate.mean);
      const double there = JointValue(joint, attempt.estimate.mean);
      const double apart = ModelOf(joint.type).VariableIsLength()
                               ? std::abs(there - here)
                               : std::abs(std::remainder(there - here, 2 * M_PI));
      if (apart * JointPixels(joint, out->estimate.mean) > options_.search_pixels) {
        const bool prismatic = ModelOf(joint.type).VariableIsLength();
        ambiguous = fmt::format(
            "'{}' at {:.{}f} {} and at {:.{}f} {} explain the image alike ({:.0f} and {:.0f} "
            "samples of their outlines supported beyond chance)",
            joint.name, prismatic ? 1000 * here : here * 180 / M_PI, prismatic ? 1 : 0,
            prismatic ? "mm" : "deg", prismatic ? 1000 * there : there * 180 / M_PI,
            prismatic ? 1 : 0, prismatic ? "mm" : "deg", frame_evidence, evidence);
        break;
      }
    }
    // ... or a part elsewhere: Castle-simu from 30-60 mm off, a pose 5-20 px from the truth
    // verified on half its outline while a place found the truth about as well supported.
    if (ambiguous.empty() && options_.refuse_ambiguous_places) {
      const double apart = Apart(out->estimate.mean, attempt.estimate.mean);
      if (apart > options_.search_pixels) {
        ambiguous = fmt::format(
            "a pose {:.0f} px away explains the image alike ({:.0f} and {:.0f} samples of their "
            "outlines supported beyond chance)",
            apart, frame_evidence, evidence);
      }
    }
  }
  // (The places' own sets are other searches: a better-supported one they left undetermined
  // says nothing of the sets found about the prediction, and is not the frame's estimate.)
  best_outline_ = searched_outline;
  undetermined_ = searched_undetermined;
  if (best) {
    best->doublings = out->doublings;
    best->reacquired = out->reacquired;
    *out = std::move(*best);
  } else if (!ambiguous.empty()) {
    out->verified = false;
    out->verification.verified = false;
    out->verification.refusal = Refusal::kAmbiguous;
    out->verification.why = std::move(ambiguous);
  }
  out->times = spent;
  out->branches = branches;
}

}  // namespace cfuse
