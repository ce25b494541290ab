// Lowe's best-first search over match sets (cfuse/track/match_search.h) on a rigid box whose
// edges' true images are given as candidate lines: a set of true lines solves to the truth and
// passes the residual test, one line knocked aside fails it, the search stops at the first set
// judged confident, tries no set twice, and gives up on candidates below the least probability.
#include "cfuse/track/match_search.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <iterator>

#include "cfuse/importers/cao.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"

namespace cfuse {
namespace {

struct Scene {
  ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  Camera camera = StandardCamera();
  Values truth = SequencePose(graph, StandardSequence(graph, "steady", 2), 0);
  FramePrior prior;
  std::vector<Factor> constraints;
  std::vector<EdgeModel> edges;
  std::vector<EdgeCandidate> lines;  // each edge's true image

  Scene() {
    // Predicted 5 mm and 0.01 rad off the truth, the prior reaching well past that.
    Values predicted = truth;
    predicted.poses[0] =
        Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY())),
                Eigen::Vector3d(0.005, -0.003, 0.004)) *
        truth.poses[0];
    const GaussianState state = MakePrior(graph.blocks, predicted, {0.01, 0.03, 1});
    prior = {state, state};
    for (const Constraint& c : graph.constraints) {
      constraints.push_back({c.residual, c.blocks, {}, c.name});
    }
    edges =
        PredictEdges(graph, ModelEdges(graph), state, camera, Visibility{0.17, 6, true}, 0.5, 12);
    for (size_t i = 0; i < edges.size(); ++i) {
      EdgeCandidate c;
      c.edge = static_cast<int>(i);
      c.a = camera.Project<double>(truth.poses[0] * edges[i].A);
      c.b = camera.Project<double>(truth.poses[0] * edges[i].B);
      c.noise = 0.25 * Eigen::Matrix2d::Identity();
      c.probability = 0.9;
      lines.push_back(c);
    }
  }

  Factor Match(const EdgeCandidate& c) const {
    return EdgeFactor(camera, edges[c.edge], c.a, c.b, c.noise);
  }
  double Off(const GaussianState& state) const {
    return (state.mean.poses[0].translation - truth.poses[0].translation).norm();
  }
};

TEST_CASE("match search: true lines solve to the truth; a line knocked aside fails the test",
          "[track]") {
  const Scene s;
  REQUIRE(s.edges.size() >= 5);
  std::vector<Factor> factors;
  for (const EdgeCandidate& c : s.lines) factors.push_back(s.Match(c));
  MatchedSet set;
  REQUIRE(SolveMatches(s.constraints, s.prior.free, factors, s.graph.blocks, 6, 0.999, &set));
  // To the truth but for the prior's pull, 15 mm off with 10 mm of spread: a third of a
  // millimetre, a few hundredths of a pixel.
  CHECK(s.Off(set.state) < 1e-3);
  CHECK(set.state.mean.poses[0].rotation.angularDistance(s.truth.poses[0].rotation) < 2e-3);
  CHECK(set.rows == 2 * static_cast<int>(factors.size()));
  CHECK(set.chi2 < 0.1);
  CHECK(set.residual_sigma < 0.05);
  // One line 20 px across its edge: no pose fits it with the rest, at 0.5 px.
  EdgeCandidate knocked = s.lines[0];
  knocked.a += 20 * s.edges[0].normal;
  knocked.b += 20 * s.edges[0].normal;
  factors[0] = s.Match(knocked);
  CHECK_FALSE(SolveMatches(s.constraints, s.prior.free, factors, s.graph.blocks, 6, 0.999, &set));
  CHECK(set.chi2 > 100);
}

TEST_CASE("match search: the first set judged confident ends the search, extended by the rest",
          "[track]") {
  const Scene s;
  int judged = 0;
  const MatchSearchResult result = SearchMatchSets(
      s.graph, s.camera, s.constraints, s.prior, s.edges, s.lines, 6, {}, [&](MatchedSet* set) {
        ++judged;
        return Judgement{s.Off(set->state) < 1e-3, 1, true};
      });
  CHECK(judged == 1);
  CHECK(result.branches == 1);
  REQUIRE(result.best);
  // Each line taken tightens the prediction, on which the others are near certain: one set of
  // every line.
  CHECK(result.best->set.size() == s.lines.size());
  CHECK(s.Off(result.best->state) < 1e-3);
  for (size_t k = 0; k < result.best->lines.size(); ++k) {
    const EdgeCandidate& c = s.lines[result.best->set[k]];
    CHECK(result.best->lines[k].edge == s.edges[c.edge].edge);
    CHECK(result.best->lines[k].a == c.a);
  }
}

TEST_CASE("match search: sets not verified are tried once each, within the branch budget",
          "[track]") {
  const Scene s;
  REQUIRE(s.lines.size() >= 6);
  // Probabilities as given (not conditioned on the set), and none the tightened prediction
  // would add to a set (clutter everywhere): each set judged is the one the search took.
  std::vector<EdgeCandidate> lines = s.lines;
  for (EdgeCandidate& c : lines) {
    c.support = 0.5;
    c.clutter = 1e9;
  }
  MatchSearchOptions options;
  options.conditional_sets = false;
  options.max_branches = 4;
  std::vector<std::vector<int>> judged;
  const MatchSearchResult result = SearchMatchSets(
      s.graph, s.camera, s.constraints, s.prior, s.edges, lines, 6, options, [&](MatchedSet* set) {
        std::vector<int> sorted = set->set;
        std::sort(sorted.begin(), sorted.end());
        judged.push_back(sorted);
        return Judgement{};
      });
  CHECK(result.branches == 4);
  CHECK_FALSE(result.best);
  REQUIRE(judged.size() == 4);
  // Three lines at 0.9 each (a fourth would take the product below 0.9); a refused set's lines
  // drop to 0.6, so the next three are others; later sets take lines of refused sets again,
  // never all of one of them.
  for (size_t i = 0; i < judged.size(); ++i) {
    CHECK(judged[i].size() == 3);
    for (size_t j = 0; j < i; ++j) {
      CHECK_FALSE(
          std::includes(judged[i].begin(), judged[i].end(), judged[j].begin(), judged[j].end()));
      if (i < 2) {
        std::vector<int> common;
        std::set_intersection(judged[i].begin(), judged[i].end(), judged[j].begin(),
                              judged[j].end(), std::back_inserter(common));
        CHECK(common.empty());
      }
    }
  }
  // Candidates all below the least probability: no set at all.
  std::vector<EdgeCandidate> faint = s.lines;
  for (EdgeCandidate& c : faint) c.probability = 0.01;
  const MatchSearchResult none = SearchMatchSets(s.graph, s.camera, s.constraints, s.prior, s.edges,
                                                 faint, 6, {}, [](MatchedSet*) {
                                                   return Judgement{true, 1, true};
                                                 });
  CHECK(none.branches == 0);
  CHECK_FALSE(none.best);
}

// Beside the true line of one edge a decoy 6 px across it, likelier than every true line: the
// first sets, built from it, fit only a pose centimetres off, which the judge refuses, and each
// refusal lowers it, until a set of true lines is taken.
TEST_CASE("match search: the likeliest line that does not fit gives way to those that do",
          "[track]") {
  const Scene s;
  std::vector<EdgeCandidate> candidates = s.lines;
  for (EdgeCandidate& c : candidates) {
    c.support = 0.5;
    c.clutter = 0.5;
    c.probability = 0.6;
  }
  EdgeCandidate decoy = candidates[0];
  decoy.a += 6 * s.edges[0].normal;
  decoy.b += 6 * s.edges[0].normal;
  decoy.probability = 0.95;
  candidates.push_back(decoy);
  const int decoy_index = static_cast<int>(candidates.size()) - 1;
  MatchSearchOptions options;
  options.max_branches = 10;
  std::vector<bool> with_decoy;
  const MatchSearchResult result = SearchMatchSets(
      s.graph, s.camera, s.constraints, s.prior, s.edges, candidates, 6, options,
      [&](MatchedSet* set) {
        with_decoy.push_back(std::count(set->set.begin(), set->set.end(), decoy_index) > 0);
        return Judgement{s.Off(set->state) < 1e-3, 1, true};
      });
  REQUIRE(result.best);
  CHECK(s.Off(result.best->state) < 1e-3);
  CHECK(std::count(result.best->set.begin(), result.best->set.end(), decoy_index) == 0);
  // Each refusal lowers a set's lines by 1 - 1/n, n its size (3 or 4 here): once, the decoy
  // stays above the true lines' 0.6 (0.63 or 0.71); twice, it falls below (0.42 or 0.53), and
  // the third set is the truth's.
  CHECK(result.branches == 3);
  CHECK(with_decoy == std::vector<bool>{true, true, false});
}

}  // namespace
}  // namespace cfuse
