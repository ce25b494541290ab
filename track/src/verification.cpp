#include "cfuse/track/verification.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace cfuse {

const char* RefusalName(Refusal refusal) {
  switch (refusal) {
    case Refusal::kNone:
      return "verified";
    case Refusal::kNoMatches:
      return "no set of matches passed the residual test";
    case Refusal::kNoEdges:
      return "no edge in view";
    case Refusal::kShare:
      return "too little of the outline supported";
    case Refusal::kChance:
      return "no more support on the edges than beside them";
    case Refusal::kDominance:
      return "the strongest steps lie beside the edges";
    case Refusal::kComponent:
      return "a part in view unsupported";
    case Refusal::kParallel:
      return "support on parallel edges only";
    case Refusal::kTypical:
      return "far less agreement than the frames before";
    case Refusal::kUndetermined:
      return "the matches leave the pose undetermined";
    case Refusal::kSpread:
      return "a part no better known than predicted";
    case Refusal::kOutdone:
      return "a better-supported pose left undetermined";
    case Refusal::kAmbiguous:
      return "a joint elsewhere explains the outline as well";
    case Refusal::kDepth:
      return "the faces' depth disagrees with the range sensor's";
  }
  return "?";
}

namespace {

// Whether another part's edge of `model` lies along edge `e` at point p, within `reach` px
// across and 15 degrees in direction.
bool Shared(const std::vector<ModelLine>& model, const EdgeModel& e, const Eigen::Vector2d& p,
            double reach) {
  for (const ModelLine& m : model) {
    if (m.block == e.block) continue;
    const Eigen::Vector2d d = m.b - m.a;
    const double length = d.norm();
    if (!(length > 1)) continue;
    const Eigen::Vector2d u = d / length;
    if (std::abs(u.dot(e.dir)) < std::cos(6 * M_PI / 180)) continue;
    const double along = u.dot(p - m.a);
    if (along < -reach || along > length + reach) continue;
    if (std::abs(u.x() * (p - m.a).y() - u.y() * (p - m.a).x()) <= reach) return true;
  }
  return false;
}

}  // namespace

Verification VerifyOutline(const GrayView& image, const std::vector<EdgeModel>& edges,
                           const NormalSearchOptions& search,
                           const VerificationOptions& options,
                           const std::vector<ModelLine>& model) {
  Verification out;
  struct Count {
    int samples = 0, supported = 0, probed = 0;
    int own = 0;  // supported, and no other part's edge along it there
  };
  std::map<int, Count> by_block;
  constexpr int kDirections = 9;  // 20-degree bins of the edges' directions
  double by_direction[kDirections] = {};
  int probes_supported = 0, dominated = 0, displaced = 0, side = 1;
  double distance_sum = 0, spread_sum = 0;
  std::vector<ProfileHit> found;
  NormalSearchOptions wide = search;
  wide.max_hits = 8;
  for (const EdgeModel& e : edges) {
    const double margin = std::min(2.0, 0.25 * e.length);
    const double span = e.length - 2 * margin;
    const int n = std::max(2, static_cast<int>(std::floor(span / options.step)) + 1);
    const double spacing = span / (n - 1);
    const Eigen::Vector2f normal = e.normal.cast<float>();
    const double direction = std::fmod(e.orientation + 2 * M_PI, M_PI);
    const int bin =
        std::clamp(static_cast<int>(direction / (M_PI / kDirections)), 0, kDirections - 1);
    Count& count = by_block[e.block];
    for (int k = 0; k < n; ++k) {
      const double s = margin + k * spacing;
      const double u = s / e.length;
      const double t = e.t0 + u * (e.t1 - e.t0);
      const double reach =
          std::clamp(2.5 * std::hypot(e.SigmaAt(u), e.noise), options.min_reach, options.max_reach);
      const double wide_reach = std::max(options.wide_reach, 3 * reach);
      found.clear();
      SearchAlongNormal(image, (e.a + s * e.dir).cast<float>(), normal,
                                static_cast<float>(wide_reach), wide, &found);
      // The strongest step, the nearest within the reach, and whether the probe off the edge
      // (either side in turn, just beyond the reach) has one.
      side = -side;
      const double probe = side * (wide_reach - reach);
      const ProfileHit* strongest = nullptr;
      const ProfileHit* nearest = nullptr;
      bool probed = false;
      for (const ProfileHit& h : found) {  // strongest first
        if (!strongest) strongest = &h;
        if (std::abs(h.offset) <= reach &&
            (!nearest || std::abs(h.offset) < std::abs(nearest->offset))) {
          nearest = &h;
        }
        probed = probed || std::abs(h.offset - probe) <= reach;
      }
      ++out.samples;
      ++count.samples;
      probes_supported += probed;
      count.probed += probed;
      dominated += strongest && std::abs(strongest->offset) <= reach;
      if (!nearest) {
        displaced += strongest != nullptr;
        continue;
      }
      out.steps.push_back({e.edge, t, nearest->contrast});
      ++out.supported;
      ++count.supported;
      count.own += model.empty() || !Shared(model, e, e.a + s * e.dir, reach);
      by_direction[bin] += 1;
      distance_sum += std::abs(nearest->offset);
      spread_sum += std::abs(nearest->offset) / reach;
    }
  }
  if (out.samples == 0) {
    out.why = "no edge in view";
    out.refusal = Refusal::kNoEdges;
    return out;
  }
  out.share = static_cast<double>(out.supported) / out.samples;
  out.chance = static_cast<double>(probes_supported) / out.samples;
  out.dominant_share = static_cast<double>(dominated) / out.samples;
  out.agreement =
      out.supported > 0 ? static_cast<double>(out.supported) / (out.supported + displaced) : 0.0;
  out.mean_distance = out.supported > 0 ? distance_sum / out.supported : 0;
  out.spread = out.supported > 0 ? spread_sum / out.supported : 0;
  // Each part seen on its own: its share, and its support beyond chance beside its own edges (a
  // lid lying over clutter finds steps as often on its edges as beside them).
  int unseen = 0;
  double unseen_share = 0, unseen_chance = 0;
  for (const auto& [block, c] : by_block) {
    (void)block;
    if (c.samples < options.min_component_samples) continue;
    const double share = static_cast<double>(c.own) / c.samples;
    out.least_component = std::min(out.least_component, share);
    const double p = static_cast<double>(c.probed) / c.samples;
    if (c.own <= c.probed + options.component_z * std::sqrt(2 * c.samples * p * (1 - p) + 1)) {
      ++unseen;
      unseen_share = share;
      unseen_chance = p;
    }
  }
  // The best-supported direction with its neighbours (within 20 degrees either way).
  for (int d = 0; d < kDirections && out.supported > 0; ++d) {
    const double near = by_direction[d] + by_direction[(d + 1) % kDirections] +
                        by_direction[(d + kDirections - 1) % kDirections];
    out.parallel_share = std::max(out.parallel_share, near / out.supported);
  }
  // Supported on the edges against off them: the difference of two binomial counts.
  const double p0 = out.chance;
  const double beyond_chance =
      probes_supported + options.z * std::sqrt(2 * out.samples * p0 * (1 - p0) + 1);
  if (out.share < options.min_share) {
    out.refusal = Refusal::kShare;
    out.why = fmt::format("{:.0f} % of the outline supported, {:.0f} % needed", 100 * out.share,
                          100 * options.min_share);
  } else if (out.supported <= beyond_chance) {
    out.refusal = Refusal::kChance;
    out.why = fmt::format("{} of {} samples supported, {} a few pixels off the edges",
                          out.supported, out.samples, probes_supported);
  } else if (out.dominant_share < options.min_dominant) {
    out.refusal = Refusal::kDominance;
    out.why = fmt::format(
        "the strongest step lies on the edge at {:.0f} % of the outline, {:.0f} "
        "% needed",
        100 * out.dominant_share, 100 * options.min_dominant);
  } else if (out.least_component < options.min_component_share) {
    out.refusal = Refusal::kComponent;
    out.why = fmt::format("a part in view has {:.0f} % of its outline supported on its own",
                          100 * out.least_component);
  } else if (unseen > 0) {
    out.refusal = Refusal::kComponent;
    out.why = fmt::format(
        "a part in view has {:.0f} % of its outline supported on its own, and {:.0f} % a few "
        "pixels off it",
        100 * unseen_share, 100 * unseen_chance);
  } else if (out.parallel_share > options.max_parallel_share) {
    out.refusal = Refusal::kParallel;
    out.why = "the support lies on parallel edges only";
  } else {
    out.verified = true;
  }
  return out;
}

void Remember(const Verification& verification, EdgeAppearance* appearance) {
  for (const Verification::Step& s : verification.steps) {
    appearance->Record(s.edge, s.t, s.contrast);
  }
  appearance->Commit();
}

double ExplainedEvidence(const Verification& v) { return v.supported - v.chance * v.samples; }

}  // namespace cfuse
