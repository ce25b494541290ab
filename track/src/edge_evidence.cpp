#include "cfuse/track/edge_evidence.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "cfuse/vision/segment_index.h"
#include "line_vote.h"

namespace cfuse {

EdgeAppearance::EdgeAppearance(int edges, int bins)
    : bins_(std::max(1, bins)), table_(static_cast<size_t>(std::max(0, edges)) * bins_) {}

int EdgeAppearance::Polarity(int edge, double t) const {
  const int bin = std::clamp(static_cast<int>(t * bins_), 0, bins_ - 1);
  const size_t i = static_cast<size_t>(edge) * bins_ + bin;
  return i < table_.size() && table_[i].streak >= 3 ? table_[i].sign : 0;
}

void EdgeAppearance::Record(int edge, double t, float contrast) {
  const int bin = std::clamp(static_cast<int>(t * bins_), 0, bins_ - 1);
  const size_t i = static_cast<size_t>(edge) * bins_ + bin;
  if (i >= table_.size()) return;
  (contrast > 0 ? table_[i].plus : table_[i].minus) += 1;
}

void EdgeAppearance::Commit() {
  for (Bin& b : table_) {
    const int n = b.plus + b.minus;
    if (n >= 2) {
      // Three in four of at least two steps agreeing: this frame's sign.
      const int sign = 4 * b.plus >= 3 * n ? 1 : 4 * b.minus >= 3 * n ? -1 : 0;
      b.streak = sign != 0 && sign == b.sign ? b.streak + 1 : sign != 0 ? 1 : 0;
      b.sign = sign;
    }
    b.plus = b.minus = 0;
  }
}

void EdgeAppearance::Forget() {
  for (Bin& b : table_) b = Bin{};
}

namespace {

struct Offset {
  double z = std::numeric_limits<double>::infinity();  // squared Mahalanobis distance
  double sigma_x = 1;                                  // px, at the candidate's midpoint
};

Offset Measure(const EdgeModel& e, const EdgeCandidate& c) {
  Offset out;
  const Eigen::Vector2d d = c.b - c.a;
  const double s = d.norm();
  if (s == 0 || e.length == 0) return out;
  const Eigen::Vector2d m = 0.5 * (c.a + c.b);
  // The candidate within the edge extended by its uncertainty.
  const double extended = e.length + 6 * e.sigma_x;
  if (s > extended || std::abs(e.dir.dot(m - e.mid)) > 0.5 * (extended - s)) return out;
  const double u = std::clamp(e.dir.dot(m - e.a) / e.length, 0.0, 1.0);
  out.sigma_x = std::hypot(e.SigmaAt(u), e.noise);
  const double x = e.normal.dot(m - e.a);
  const double angle = std::remainder(std::atan2(d.y(), d.x()) - e.orientation, M_PI);
  out.z = (x * x) / (out.sigma_x * out.sigma_x) + (angle * angle) / (e.sigma_y * e.sigma_y);
  return out;
}

}  // namespace

double CandidateDistance(const EdgeModel& e, const EdgeCandidate& c) { return Measure(e, c).z; }

double CandidateProbability(const EdgeModel& e, const EdgeCandidate& c, double gate) {
  const Offset o = Measure(e, c);
  if (!(o.z <= gate)) return 0;
  const double density = std::exp(-0.5 * o.z) / (2 * M_PI * o.sigma_x * e.sigma_y);
  // The share of the edge behind a line weighs as a likelihood ratio: a line along most of the
  // edge is rarely clutter. Segments come with 0.5: Lowe's p/(p+q) as it is.
  const double f = std::clamp(c.support, 0.05, 0.95);
  return f * density / (f * density + (1 - f) * c.clutter);
}

double Overlap(const EdgeModel& e, const EdgeCandidate& c) {
  double t0 = e.dir.dot(c.a - e.a), t1 = e.dir.dot(c.b - e.a);
  if (t0 > t1) std::swap(t0, t1);
  return std::max(0.0, std::min(t1, e.length) - std::max(t0, 0.0));
}

namespace {

using internal::Hit;
using internal::Line;
using internal::Sample;
using internal::Vote;
using internal::VotePoints;

// px: a hit wider than this at half maximum is smeared by motion (cfuse/vision/normal_search.h:
// real edges are 2 to 4 px wide); its width beyond is counted as the edge's error.
constexpr float kSmearedWidth = 5;

// For every sample, its unused hit nearest the line within `inlier` px, or -1.
void Inliers(const std::vector<Sample>& samples, const std::vector<Hit>& hits, const Line& line,
             double inlier, std::vector<int>* chosen) {
  chosen->assign(samples.size(), -1);
  for (size_t k = 0; k < samples.size(); ++k) {
    const double expected = line.Offset(samples[k].s);
    double best = inlier;
    for (int h = samples[k].first; h < samples[k].first + samples[k].count; ++h) {
      if (hits[h].used) continue;
      const double r = std::abs(hits[h].offset - expected);
      if (r <= best) {
        best = r;
        (*chosen)[k] = h;
      }
    }
  }
}

// Least squares through the chosen hits; false with fewer than three.
bool Fit(const std::vector<Sample>& samples, const std::vector<Hit>& hits,
         const std::vector<int>& chosen, Line* line, double* scatter, int* count, double* sxx) {
  double n = 0, ms = 0, md = 0;
  for (size_t k = 0; k < samples.size(); ++k) {
    if (chosen[k] < 0) continue;
    n += 1;
    ms += samples[k].s;
    md += hits[chosen[k]].offset;
  }
  if (n < 3) return false;
  ms /= n;
  md /= n;
  double xx = 0, xy = 0;
  for (size_t k = 0; k < samples.size(); ++k) {
    if (chosen[k] < 0) continue;
    const double x = samples[k].s - ms;
    xx += x * x;
    xy += x * (hits[chosen[k]].offset - md);
  }
  if (xx <= 0) return false;
  line->centre = ms;
  line->c0 = md;
  line->c1 = xy / xx;
  double rr = 0;
  for (size_t k = 0; k < samples.size(); ++k) {
    if (chosen[k] < 0) continue;
    const double r = hits[chosen[k]].offset - line->Offset(samples[k].s);
    rr += r * r;
  }
  *scatter = std::sqrt(rr / std::max(1.0, n - 2));
  *count = static_cast<int>(n);
  *sxx = xx;
  return true;
}

}  // namespace

std::vector<EdgeCandidate> NormalSearchCandidates(const GrayView& image,
                                                  const std::vector<EdgeModel>& edges,
                                                  const EdgeAppearance& appearance,
                                                  const EvidenceOptions& options,
                                                  SearchStatistics* statistics) {
  std::vector<EdgeCandidate> out;
  std::vector<Sample> samples;
  std::vector<Hit> hits;
  std::vector<ProfileHit> found;
  std::vector<int> chosen;
  VotePoints vote;
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeModel& e = edges[i];
    const double margin = std::min(options.end_margin, 0.25 * e.length);
    const double span = e.length - 2 * margin;
    const int n = std::max(2, static_cast<int>(std::floor(span / options.sample_step)) + 1);
    const double spacing = span / (n - 1);
    samples.clear();
    hits.clear();
    double reach = 0;
    const Eigen::Vector2f normal = e.normal.cast<float>();
    for (int k = 0; k < n; ++k) {
      const double s = margin + k * spacing;
      const double u = s / e.length;
      const double sigma = std::hypot(e.SigmaAt(u), e.noise);
      const double range = std::clamp(3.5 * sigma + 1, options.min_range, options.max_range);
      reach = std::max(reach, range);
      found.clear();
      const Eigen::Vector2f point = (e.a + s * e.dir).cast<float>();
      SearchAlongNormal(image, point, normal, static_cast<float>(range), options.search,
                                &found);
      const int expected = appearance.Polarity(e.edge, e.t0 + u * (e.t1 - e.t0));
      Sample sample{s, static_cast<int>(hits.size()), 0};
      for (const ProfileHit& h : found) {
        if (expected != 0 && (h.contrast > 0 ? 1 : -1) != expected) continue;
        hits.push_back({h.offset, h.contrast, h.width, false});
        ++sample.count;
      }
      samples.push_back(sample);
      if (statistics) {
        statistics->searched_pixels += 2 * range;
        statistics->hits += static_cast<int>(found.size());
        ++statistics->samples;
      }
    }
    const int needed = std::max(3, static_cast<int>(std::ceil(options.min_support * n)));
    const double max_slope = std::min(0.5, 3.5 * e.sigma_y + 2 / e.length);
    const size_t before = out.size();
    for (int line_index = 0; line_index < options.max_lines; ++line_index) {
      Line line;
      if (!Vote(samples, hits, e.length, max_slope, reach, &vote, &line)) break;
      double scatter = 0, sxx = 0;
      int count = 0;
      bool fitted = false;
      // Refined twice: the vote's line is good to a pixel, the fit to a fraction of one.
      for (int round = 0; round < 2; ++round) {
        Inliers(samples, hits, line, options.inlier, &chosen);
        if (!Fit(samples, hits, chosen, &line, &scatter, &count, &sxx)) break;
        fitted = true;
      }
      if (!fitted) break;
      Inliers(samples, hits, line, options.inlier, &chosen);
      double s_min = 1e300, s_max = -1e300;
      int plus = 0, minus = 0, on_line = 0;
      double contrast = 0, smear = 0;
      for (size_t k = 0; k < samples.size(); ++k) {
        if (chosen[k] < 0) continue;
        ++on_line;
        s_min = std::min(s_min, samples[k].s);
        s_max = std::max(s_max, samples[k].s);
        (hits[chosen[k]].contrast > 0 ? plus : minus) += 1;
        contrast += std::abs(hits[chosen[k]].contrast);
        smear += std::max(0.f, hits[chosen[k]].width - kSmearedWidth);
        hits[chosen[k]].used = true;
      }
      if (on_line < needed || s_max - s_min < 1) continue;  // its hits are spent
      EdgeCandidate c;
      c.edge = static_cast<int>(i);
      c.a = e.a + s_min * e.dir + line.Offset(s_min) * e.normal;
      c.b = e.a + s_max * e.dir + line.Offset(s_max) * e.normal;
      // The fit's covariance at the two ends (c0 and c1 independent about the hits' centre),
      // plus what the model and the camera add at each, and a smeared step's width: motion
      // blur moves every hit of the edge alike, so more hits do not average it away.
      const double hit_var = std::pow(std::max(scatter, options.min_hit_sigma), 2);
      Eigen::Matrix2d J;
      J << 1, s_min - line.centre, 1, s_max - line.centre;
      const Eigen::Matrix2d fit =
          J * Eigen::Vector2d(hit_var / count, hit_var / sxx).asDiagonal() * J.transpose();
      const double blur = smear / on_line / std::sqrt(12.0);
      c.noise = fit + (e.noise * e.noise + blur * blur) * Eigen::Matrix2d::Identity();
      c.support = static_cast<double>(on_line) / n;
      c.polarity = minus == 0 ? 1 : plus == 0 ? -1 : 0;
      c.hits = on_line;
      c.strength = contrast / on_line;
      out.push_back(c);
    }
    // Clutter: the lines found per unit of the window searched (offset x angle).
    const double window = (2 * reach) * (2 * std::atan(max_slope));
    const double clutter = static_cast<double>(out.size() - before) / std::max(window, 1e-9);
    for (size_t c = before; c < out.size(); ++c) {
      out[c].clutter = clutter;
      out[c].probability = CandidateProbability(e, out[c], options.gate);
    }
    out.erase(std::remove_if(out.begin() + static_cast<long>(before), out.end(),
                             [](const EdgeCandidate& c) { return c.probability <= 0; }),
              out.end());
  }
  return out;
}

std::vector<EdgeCandidate> StrongestStepCandidates(const GrayView& image,
                                                   const std::vector<EdgeModel>& edges,
                                                   const EdgeAppearance& appearance,
                                                   const EvidenceOptions& options, double reach) {
  std::vector<EdgeCandidate> out;
  std::vector<ProfileHit> found;
  std::vector<double> s, d, w;
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeModel& e = edges[i];
    const double margin = std::min(options.end_margin, 0.25 * e.length);
    const double span = e.length - 2 * margin;
    const int n = std::max(2, static_cast<int>(std::floor(span / options.sample_step)) + 1);
    const double spacing = span / (n - 1);
    s.clear();
    d.clear();
    double contrast = 0;
    int plus = 0, minus = 0;
    for (int k = 0; k < n; ++k) {
      const double at = margin + k * spacing;
      const double u = at / e.length;
      found.clear();
      SearchAlongNormal(image, (e.a + at * e.dir).cast<float>(), e.normal.cast<float>(),
                                static_cast<float>(reach), options.search, &found);
      const int expected = appearance.Polarity(e.edge, e.t0 + u * (e.t1 - e.t0));
      for (const ProfileHit& h : found) {  // strongest first
        if (expected != 0 && (h.contrast > 0 ? 1 : -1) != expected) continue;
        s.push_back(at);
        d.push_back(h.offset);
        contrast += std::abs(h.contrast);
        (h.contrast > 0 ? plus : minus) += 1;
        break;
      }
    }
    const int needed = std::max(3, static_cast<int>(std::ceil(options.min_support * n)));
    if (static_cast<int>(s.size()) < needed) continue;
    // IRLS: a weighted line through (s, d), Tukey's weights from the robust scale.
    w.assign(s.size(), 1.0);
    double c0 = 0, c1 = 0, centre = 0, sxx = 0, sw = 0, scale = 0;
    for (int iteration = 0; iteration < 6; ++iteration) {
      sw = 0;
      double ms = 0, md = 0;
      for (size_t k = 0; k < s.size(); ++k) {
        sw += w[k];
        ms += w[k] * s[k];
        md += w[k] * d[k];
      }
      if (sw < 3) break;
      centre = ms / sw;
      c0 = md / sw;
      double xy = 0;
      sxx = 0;
      for (size_t k = 0; k < s.size(); ++k) {
        sxx += w[k] * (s[k] - centre) * (s[k] - centre);
        xy += w[k] * (s[k] - centre) * (d[k] - c0);
      }
      if (sxx <= 0) break;
      c1 = xy / sxx;
      std::vector<double> r(s.size());
      for (size_t k = 0; k < s.size(); ++k) r[k] = std::abs(d[k] - c0 - c1 * (s[k] - centre));
      std::vector<double> sorted = r;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      scale = std::max(1.4826 * sorted[sorted.size() / 2], options.min_hit_sigma);
      for (size_t k = 0; k < s.size(); ++k) {
        const double x = r[k] / (4.685 * scale);
        w[k] = x < 1 ? (1 - x * x) * (1 - x * x) : 0.0;
      }
    }
    int inliers = 0;
    double s_min = 1e300, s_max = -1e300, rr = 0;
    for (size_t k = 0; k < s.size(); ++k) {
      if (w[k] <= 0) continue;
      ++inliers;
      s_min = std::min(s_min, s[k]);
      s_max = std::max(s_max, s[k]);
      const double r = d[k] - c0 - c1 * (s[k] - centre);
      rr += w[k] * r * r;
    }
    if (inliers < needed || s_max - s_min < 1 || sxx <= 0 || sw < 3) continue;
    EdgeCandidate c;
    c.edge = static_cast<int>(i);
    c.a = e.a + s_min * e.dir + (c0 + c1 * (s_min - centre)) * e.normal;
    c.b = e.a + s_max * e.dir + (c0 + c1 * (s_max - centre)) * e.normal;
    const double hit_var = std::max(rr / std::max(1.0, sw - 2), std::pow(options.min_hit_sigma, 2));
    Eigen::Matrix2d J;
    J << 1, s_min - centre, 1, s_max - centre;
    c.noise = J * Eigen::Vector2d(hit_var / sw, hit_var / sxx).asDiagonal() * J.transpose() +
              e.noise * e.noise * Eigen::Matrix2d::Identity();
    c.support = static_cast<double>(inliers) / n;
    c.polarity = minus == 0 ? 1 : plus == 0 ? -1 : 0;
    c.hits = inliers;
    c.strength = contrast / static_cast<double>(s.size());
    c.probability = 1;
    out.push_back(c);
  }
  return out;
}

std::vector<EdgeCandidate> SegmentCandidates(const GrayView& image,
                                             const std::vector<EdgeModel>& edges,
                                             const SegmentOptions& segment_options,
                                             const EvidenceOptions& options) {
  if (edges.empty()) return {};
  // Segments where the edges can be seen: their box, widened by 3 sigma and a margin.
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const EdgeModel& e : edges) {
    const double margin = 3 * std::sqrt(std::max(e.var_a, e.var_b)) + 3 * e.noise + 8;
    lo = lo.cwiseMin(e.a.cwiseMin(e.b) - Eigen::Vector2d::Constant(margin));
    hi = hi.cwiseMax(e.a.cwiseMax(e.b) + Eigen::Vector2d::Constant(margin));
  }
  const int x0 = std::clamp(static_cast<int>(std::floor(lo.x())), 0, image.width - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(lo.y())), 0, image.height - 1);
  const int x1 = std::clamp(static_cast<int>(std::ceil(hi.x())) + 1, x0 + 1, image.width);
  const int y1 = std::clamp(static_cast<int>(std::ceil(hi.y())) + 1, y0 + 1, image.height);
  SegmentOptions so = segment_options;
  so.roi = PixelRect{x0, y0, x1 - x0, y1 - y0};
  const std::vector<ImageSegment> segments = DetectSegments(image, so);
  const SegmentIndex index(segments, image.width, image.height);
  const double background =
      static_cast<double>(segments.size()) / (M_PI * static_cast<double>(x1 - x0) * (y1 - y0));
  std::vector<EdgeCandidate> out;
  std::vector<int> found;
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeModel& e = edges[i];
    index.Query(e.mid.cast<float>(), static_cast<float>(0.5 * e.length + 3 * e.sigma_x + 2),
                static_cast<float>(e.orientation),
                static_cast<float>(std::min(M_PI / 2, 3 * e.sigma_y + 0.02)), &found);
    for (int s : found) {
      EdgeCandidate c;
      c.edge = static_cast<int>(i);
      c.a = segments[s].a.cast<double>();
      c.b = segments[s].b.cast<double>();
      // Oriented as the edge, so that a -> b runs the same way.
      if (e.dir.dot(c.b - c.a) < 0) std::swap(c.a, c.b);
      c.noise = e.noise * e.noise * Eigen::Matrix2d::Identity();
      c.support = 0.5;
      c.strength = segments[s].strength;
      const double extended = e.length + 6 * e.sigma_x;
      c.clutter = background * std::max(extended - (c.b - c.a).norm(), 1.0);
      c.probability = CandidateProbability(e, c, options.gate);
      if (c.probability > 0) out.push_back(c);
    }
  }
  return out;
}

}  // namespace cfuse
