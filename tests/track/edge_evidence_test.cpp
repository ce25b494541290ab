// Edge evidence (cfuse/track/edge_evidence.h) on images drawn pixel by pixel, for an edge
// predicted by hand: the polarity remembered only once settled, a candidate's distance,
// probability and overlap as worked out by hand, and the lines found by normal search, by the
// strongest steps (an outlier ignored) and from detected segments.
#include "cfuse/track/edge_evidence.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <functional>

namespace cfuse {
namespace {

// A 640 x 480 image whose grey level is `level(x, y)`.
struct Image {
  explicit Image(const std::function<int(int, int)>& level) : pixels(640 * 480) {
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x) pixels[y * 640 + x] = static_cast<std::uint8_t>(level(x, y));
  }
  GrayView view() const { return {pixels.data(), 640, 480, 640}; }
  std::vector<std::uint8_t> pixels;
};

// Dark above row 204, bright from it: a step at y = 203.5.
int Step(int, int y) { return y < 204 ? 60 : 180; }

// Model edge 0 predicted from (200, 200) to (400, 200), its ends 2 px uncertain across it
// (independently), 0.5 px of noise.
EdgeModel Predicted() {
  EdgeModel e;
  e.edge = 0;
  e.a = Eigen::Vector2d(200, 200);
  e.b = Eigen::Vector2d(400, 200);
  e.length = 200;
  e.dir = Eigen::Vector2d(1, 0);
  e.normal = Eigen::Vector2d(0, 1);
  e.mid = Eigen::Vector2d(300, 200);
  e.var_a = e.var_b = 4;
  e.noise = 0.5;
  e.sigma_x = std::sqrt(0.25 * 8 + 0.25);          // 1.5
  e.sigma_y = std::sqrt(8 + 2 * 0.25) / e.length;  // rad
  return e;
}

EdgeCandidate Line(double ax, double ay, double bx, double by) {
  EdgeCandidate c;
  c.edge = 0;
  c.a = Eigen::Vector2d(ax, ay);
  c.b = Eigen::Vector2d(bx, by);
  return c;
}

TEST_CASE("edge evidence: a polarity counts once three verified frames agree on it", "[track]") {
  EdgeAppearance appearance(2, 4);
  auto frame = [&](float contrast, int steps) {
    for (int k = 0; k < steps; ++k) appearance.Record(0, 0.1, contrast);
    appearance.Commit();
  };
  frame(+20, 2);
  frame(+20, 2);
  CHECK(appearance.Polarity(0, 0.1) == 0);  // two frames: not settled
  frame(+20, 2);
  CHECK(appearance.Polarity(0, 0.1) == 1);
  CHECK(appearance.Polarity(0, 0.2) == 1);  // the same bin (0.25 wide)
  CHECK(appearance.Polarity(0, 0.3) == 0);  // another
  CHECK(appearance.Polarity(1, 0.1) == 0);  // another edge
  appearance.Commit();                      // a frame without steps there keeps it
  CHECK(appearance.Polarity(0, 0.1) == 1);
  frame(+20, 1);  // one step is too few to say
  CHECK(appearance.Polarity(0, 0.1) == 1);
  // Two of four the other way: no sign this frame, the bin unknown again.
  appearance.Record(0, 0.1, 5);
  appearance.Record(0, 0.1, 5);
  frame(-5, 2);
  CHECK(appearance.Polarity(0, 0.1) == 0);
  frame(-5, 3);
  frame(-5, 4);
  frame(-5, 2);
  CHECK(appearance.Polarity(0, 0.1) == -1);
  // t beyond the ends falls in the end bins; edges beyond the table are unknown and ignored.
  for (int k = 0; k < 3; ++k) {
    appearance.Record(1, 1.5, 9);
    appearance.Record(1, 1.5, 9);
    appearance.Commit();
  }
  CHECK(appearance.Polarity(1, 0.9) == 1);
  appearance.Record(7, 0.5, 9);
  CHECK(appearance.Polarity(7, 0.5) == 0);
  appearance.Forget();
  CHECK(appearance.Polarity(0, 0.1) == 0);
  CHECK(appearance.Polarity(1, 0.9) == 0);
}

TEST_CASE("edge evidence: a candidate's distance, probability and overlap by hand", "[track]") {
  const EdgeModel e = Predicted();
  // 3 px across at the middle, parallel: z = 3² / σx², σx = hypot(σ(0.5), noise) = 1.5.
  const EdgeCandidate c = [] {
    EdgeCandidate k = Line(220, 203, 380, 203);
    k.support = 0.8;
    k.clutter = 0.5;
    return k;
  }();
  CHECK(CandidateDistance(e, c) == Approx(9 / 2.25));
  const double z = 9 / 2.25;
  const double density = std::exp(-0.5 * z) / (2 * M_PI * 1.5 * e.sigma_y);
  CHECK(CandidateProbability(e, c, 18.42) == Approx(0.8 * density / (0.8 * density + 0.2 * 0.5)));
  CHECK(CandidateProbability(e, c, 3.9) == 0);  // outside the gate
  // Turned by 2 σy about its middle: 4 more.
  EdgeCandidate turned = c;
  const double angle = 2 * e.sigma_y;
  turned.a = Eigen::Vector2d(300, 203) - 80 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
  turned.b = Eigen::Vector2d(300, 203) + 80 * Eigen::Vector2d(std::cos(angle), std::sin(angle));
  CHECK(CandidateDistance(e, turned) == Approx(z + 4).epsilon(1e-6));
  // Beyond the edge extended by 3 σx at each end, or longer than it: no distance.
  CHECK(std::isinf(CandidateDistance(e, Line(380, 203, 420, 203))));
  CHECK(std::isinf(CandidateDistance(e, Line(190, 203, 411, 203))));
  CHECK(std::isinf(CandidateDistance(e, Line(300, 203, 300, 203))));
  // The length along the piece it covers, either way round.
  CHECK(Overlap(e, Line(150, 210, 260, 210)) == Approx(60));
  CHECK(Overlap(e, Line(260, 190, 150, 190)) == Approx(60));
  CHECK(Overlap(e, Line(410, 200, 500, 200)) == 0);
}

TEST_CASE("edge evidence: normal search finds the step's line, and clutter's", "[track]") {
  const EdgeModel e = Predicted();
  const Image step(Step);
  EvidenceOptions options;
  SearchStatistics stats;
  const std::vector<EdgeCandidate> found =
      NormalSearchCandidates(step.view(), {e}, EdgeAppearance(1), options, &stats);
  // 39 samples 5.1 px apart from x = 203 to 397, each searched 3.5 σ + 1 either way, σ the
  // prediction's there with the noise.
  double searched = 0;
  for (int k = 0; k < 39; ++k) {
    const double u = (3 + k * 194.0 / 38) / 200;
    const double sigma = std::sqrt(4 * (1 - u) * (1 - u) + 4 * u * u);
    searched += 2 * (3.5 * std::hypot(sigma, 0.5) + 1);
  }
  CHECK(stats.samples == 39);
  CHECK(stats.hits == 39);
  CHECK(stats.searched_pixels == Approx(searched).epsilon(1e-6));
  REQUIRE(found.size() == 1);
  const EdgeCandidate& c = found[0];
  CHECK(c.edge == 0);
  CHECK((c.a - Eigen::Vector2d(203, 203.5)).norm() < 1e-3);
  CHECK((c.b - Eigen::Vector2d(397, 203.5)).norm() < 1e-3);
  CHECK(c.support == 1);
  CHECK(c.hits == 39);
  CHECK(c.polarity == 1);  // brighter along the normal
  CHECK(c.strength == Approx(120).margin(0.01));
  CHECK(c.probability == Approx(CandidateProbability(e, c, options.gate)));
  CHECK(c.probability > 0.9);
  // No scatter: the hits' error is min_hit_sigma, and the fit of 39 of them adds little to the
  // edge's own noise at each end.
  CHECK(c.noise(0, 0) > 0.25);
  CHECK(c.noise(0, 0) < 0.25 + 0.0625);
  CHECK(c.noise(0, 1) == Approx(c.noise(1, 0)));
  // Remembered the other way round, its hits are not the edge's.
  EdgeAppearance darker(1);
  for (int frame = 0; frame < 3; ++frame) {
    for (double t = 0.05; t < 1; t += 0.1) {
      darker.Record(0, t, -1);
      darker.Record(0, t, -1);
    }
    darker.Commit();
  }
  CHECK(NormalSearchCandidates(step.view(), {e}, darker, options).empty());
  // A bright stripe, rows 198-202: two lines 5 px apart, of either polarity; a blank image none.
  const Image stripe([](int, int y) { return y >= 198 && y < 203 ? 180 : 60; });
  const std::vector<EdgeCandidate> two =
      NormalSearchCandidates(stripe.view(), {e}, EdgeAppearance(1), options);
  REQUIRE(two.size() == 2);
  CHECK(two[0].polarity == -two[1].polarity);
  CHECK(std::abs(two[0].a.y() - two[1].a.y()) == Approx(5).margin(1e-3));
  CHECK(std::abs(two[0].b.y() - two[1].b.y()) == Approx(5).margin(1e-3));
  CHECK(two[0].clutter > 0);
  const Image blank([](int, int) { return 90; });
  CHECK(NormalSearchCandidates(blank.view(), {e}, EdgeAppearance(1), options).empty());
}

TEST_CASE("edge evidence: the strongest steps' line, an outlying blob ignored", "[track]") {
  const EdgeModel e = Predicted();
  // A bright blob above the edge at x 250-262, its lower side 5 px above it: there the
  // strongest step is the blob's (195 grey levels down, against the edge's 120 up).
  const Image blob(
      [](int x, int y) { return x >= 250 && x <= 262 && y >= 180 && y <= 198 ? 255 : Step(x, y); });
  const std::vector<EdgeCandidate> found =
      StrongestStepCandidates(blob.view(), {e}, EdgeAppearance(1), EvidenceOptions{}, 8);
  REQUIRE(found.size() == 1);
  const EdgeCandidate& c = found[0];
  CHECK(c.a.y() == Approx(203.5).margin(0.01));
  CHECK(c.b.y() == Approx(203.5).margin(0.01));
  CHECK(c.probability == 1);
  CHECK(c.support < 1);  // the blob's samples are not on it
  CHECK(c.support > 0.85);
  CHECK(c.polarity == 0);  // the blob's steps, of both signs, were counted
  // Nothing to fit on a blank image.
  const Image blank([](int, int) { return 90; });
  CHECK(
      StrongestStepCandidates(blank.view(), {e}, EdgeAppearance(1), EvidenceOptions{}, 8).empty());
}

TEST_CASE("edge evidence: detected segments near an edge, oriented as it", "[track]") {
  EdgeModel e = Predicted();
  // The edge predicted the other way round: a segment runs the way its edge does.
  std::swap(e.a, e.b);
  e.dir = -e.dir;
  e.normal = -e.normal;
  e.orientation = M_PI;
  // The step as long as the edge: a line longer than the edge and its uncertainty is no image
  // of it.
  const Image step([](int x, int y) { return x >= 200 && x < 400 ? Step(x, y) : 60; });
  const EvidenceOptions options;
  const std::vector<EdgeCandidate> found =
      SegmentCandidates(step.view(), {e}, SegmentOptions{}, options);
  REQUIRE_FALSE(found.empty());
  for (const EdgeCandidate& c : found) {
    CHECK(std::abs(c.a.y() - 203.5) < 1);
    CHECK(std::abs(c.b.y() - 203.5) < 1);
    CHECK(c.b.x() < c.a.x());
    CHECK(c.support == 0.5);
    CHECK(c.noise == 0.25 * Eigen::Matrix2d::Identity());
    CHECK(c.probability > 0);
  }
  CHECK(SegmentCandidates(step.view(), {}, SegmentOptions{}, options).empty());
}

}  // namespace
}  // namespace cfuse
