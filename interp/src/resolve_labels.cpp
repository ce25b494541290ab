// Measurement labels resolved to model points: unknown labels refused with the closest names,
// and labelled 3D points in other units than the model's said at the file.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>

#include "cfuse/interp/closed_form_pose.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/schedule.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/did_you_mean.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/kernel/fusion_order.h"
#include "cfuse/kernel/measurements/image_point.h"
#include "cfuse/kernel/measurements/point3.h"
#include "cfuse/kernel/measurements/stacked.h"
#include "solve_internal.h"

namespace cfuse {
namespace {

// Every label a measurement could carry, for "did you mean": component.point, bare point
// names and single-point components.
std::vector<std::string> KnownLabels(const ConstraintGraph& graph) {
  std::vector<std::string> known;
  for (const Component& comp : graph.components) {
    if (!comp.rigid) known.push_back(comp.name);
    if (!comp.rigid) continue;
    for (const FeaturePoint& p : comp.points) {
      known.push_back(comp.name + "." + p.name);
      known.push_back(p.name);
    }
  }
  return known;
}

// Labelled 3D points in other units than the model's (millimetres read as metres) would end in
// thousands of sigmas and outliers; said at the file instead. The measure: the median, over
// pairs of labelled points on one rigid component, of their measured over their model distance.
void RequireModelScale(const ConstraintGraph& graph, const MeasurementSet& set,
                       const std::vector<ResolvedLabel>& labels) {
  std::map<int, std::vector<const ResolvedLabel*>> by_component;
  for (const ResolvedLabel& l : labels) {
    if (l.feature >= 0 && set.points[l.measurement].is_3d) by_component[l.component].push_back(&l);
  }
  std::vector<double> ratios;
  for (const auto& [c, on] : by_component) {
    const Component& comp = graph.components[c];
    for (size_t i = 0; i + 1 < on.size() && ratios.size() < 10000; ++i) {
      for (size_t j = i + 1; j < on.size() && j < i + 8; ++j) {
        const double model =
            (comp.points[on[i]->feature].position - comp.points[on[j]->feature].position).norm();
        const MeasuredPoint& a = set.points[on[i]->measurement];
        const MeasuredPoint& b = set.points[on[j]->measurement];
        const double noise = std::sqrt(a.cov3.trace() + b.cov3.trace());
        const double measured = (a.xyz - b.xyz).norm();
        if (measured > 10 * noise && model > 0) ratios.push_back(measured / model);
      }
    }
  }
  if (ratios.size() < 3) return;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double ratio = ratios[ratios.size() / 2];
  if (ratio < 20 && ratio > 1.0 / 20) return;
  const char* guess = ratio > 500 && ratio < 2000 ? ": millimetres? measurement files take metres"
                      : ratio > 50 && ratio < 200 ? ": centimetres? measurement files take metres"
                      : ratio > 20 && ratio < 50  ? ": inches? measurement files take metres"
                                                  : "";
  const double step = std::pow(10.0, std::floor(std::log10(ratio)) - 1);  // two digits shown
  throw InputError(SourceLocation(set.source),
                   fmt::format("the labelled points are about {:g} times as far apart as the "
                               "model points they name (median over {} pairs){}",
                               std::round(ratio / step) * step, ratios.size(), guess));
}

}  // namespace

std::vector<ResolvedLabel> ResolveLabels(const ConstraintGraph& graph, const MeasurementSet& set) {
  std::vector<ResolvedLabel> labels;
  auto unknown = [&](const MeasuredPoint& m) {
    return InputError(m.where, fmt::format("unknown label '{}': no such model point{}", m.label,
                                           DidYouMean(m.label, KnownLabels(graph))));
  };
  for (size_t i = 0; i < set.points.size(); ++i) {
    const MeasuredPoint& m = set.points[i];
    if (m.label.empty()) continue;
    ResolvedLabel r;
    r.measurement = static_cast<int>(i);
    if (m.label.find('.') != std::string::npos) {
      // component.point, split at whichever dot names a model point: a URDF link's own name
      // may hold dots.
      r.component = -1;
      for (size_t dot = m.label.find('.'); dot != std::string::npos && r.component < 0;
           dot = m.label.find('.', dot + 1)) {
        const int c = graph.FindComponent(std::string_view(m.label).substr(0, dot));
        if (c < 0 || !graph.components[c].rigid) continue;
        const int f = graph.components[c].FindPoint(std::string_view(m.label).substr(dot + 1));
        if (f >= 0) {
          r.component = c;
          r.feature = f;
        }
      }
      if (r.component < 0) throw unknown(m);
    } else {
      int matches = 0;
      for (size_t c = 0; c < graph.components.size(); ++c) {
        const Component& comp = graph.components[c];
        if (!comp.rigid && comp.name == m.label) {
          r.component = static_cast<int>(c);
          r.feature = -1;
          ++matches;
        }
        const int f = comp.rigid ? comp.FindPoint(m.label) : -1;
        if (f >= 0) {
          r.component = static_cast<int>(c);
          r.feature = f;
          ++matches;
        }
      }
      if (matches == 0) throw unknown(m);
      if (matches > 1) {
        throw InputError(m.where,
                         fmt::format("label '{}' is ambiguous: write component.point", m.label));
      }
    }
    labels.push_back(r);
  }
  RequireModelScale(graph, set, labels);
  return labels;
}

}  // namespace cfuse
