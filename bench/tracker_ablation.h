// The benchmarks' `--without` option: the tracker with one or more of its safeguards turned
// off, so that docs/benchmarks.md can show what each one is for, measured in the same run.
//
//   TrackerOptions options;
//   DisableSafeguards("settle,outdone", &options);  // throws std::invalid_argument on a bad name
#pragma once

#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cfuse/track/tracker.h"

namespace cfuse::bench {

inline constexpr const char* kSafeguards =
    "settle (every settling place), settle-tilts (the places turned about the image's axes), "
    "settle-joints (joints across their limits), settle-last-seen (after a loss, the places about "
    "the last verified pose), reacquire-last-verified (the rings about the last verified pose "
    "when the carried estimate strayed), limit-carry (a lost frame's estimate carried with a joint "
    "pushed onto its limit), widen (the prior widened when the estimate leaves it), outdone (a "
    "set outdone by another refused), "
    "own-support (each part's own edges), smeared (blurred edges at their middle), "
    "unknown-motion (the doubled range tried at a track's second frame), ambiguous-places (a "
    "settling place's pose as well supported elsewhere refuses the frame)";

inline void DisableSafeguards(const std::string& list, TrackerOptions* options) {
  std::stringstream in(list);
  std::string name;
  while (std::getline(in, name, ',')) {
    if (name.empty()) continue;
    if (name == "settle") {
      options->settle_places = options->settle_depths = options->settle_joint_values = 0;
      options->settle_tilts = 0;
    } else if (name == "settle-tilts") {
      options->settle_tilts = 0;
    } else if (name == "settle-joints") {
      options->settle_joint_values = 0;
    } else if (name == "settle-last-seen") {
      options->settle_from_last_seen = false;
    } else if (name == "reacquire-last-verified") {
      options->reacquire_about_last_verified = false;
    } else if (name == "limit-carry") {
      options->carry_joints_at_limits = true;
    } else if (name == "widen") {
      options->prior_confidence = 1;
    } else if (name == "outdone") {
      options->min_share_of_best = 0;
    } else if (name == "own-support") {
      // (each part's share is still checked, not its support beyond chance)
      options->verification.component_z = -std::numeric_limits<double>::infinity();
    } else if (name == "smeared") {
      options->evidence_options.search.smeared_width = 1e9;
    } else if (name == "unknown-motion") {
      options->unknown_motion_share = 0;
    } else if (name == "ambiguous-places") {
      options->refuse_ambiguous_places = false;
    } else {
      throw std::invalid_argument("--without: unknown safeguard '" + name + "'; known: " +
                                  kSafeguards);
    }
  }
}

}  // namespace cfuse::bench
