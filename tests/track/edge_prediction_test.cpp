// The model's edges as a predicted state shows them (cfuse/track/edge_prediction.h): each piece
// where the mean projects it, its ends' variance across the edge as A P Aᵀ against central
// differences, the edge factor's residual, and the pieces reprojected by a tightened state.
#include "cfuse/track/edge_prediction.h"

#include <catch2/catch.hpp>

#include "cfuse/importers/cao.h"
#include "cfuse/kernel/evaluate.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"

namespace cfuse {
namespace {

const Visibility kVisibility{0.17, 6, true};

struct Scene {
  ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  Camera camera = StandardCamera();
  Values at = SequencePose(graph, StandardSequence(graph, "steady", 2), 0);
  std::vector<ModelEdge> edges = ModelEdges(graph);
};

// A state about `mean` whose pose is uncertain by 0.01 and 0.003 in its tangent coordinates,
// with correlations.
GaussianState Uncertain(const std::vector<Block>& blocks, const Values& mean) {
  GaussianState state = MakePrior(blocks, mean, {});
  Eigen::Matrix<double, 6, 6> root = Eigen::Matrix<double, 6, 6>::Identity();
  root.diagonal() << 0.01, 0.01, 0.01, 0.003, 0.003, 0.003;
  root(3, 0) = root(4, 1) = 0.002;
  state.covariance.topLeftCorner<6, 6>() = root * root.transpose();
  return state;
}

// The image-segment residual of piece e, its measured ends at e's image, with the component at
// `pose`: the signed distances of a and b from the line through the projected ends.
Eigen::Vector2d Across(const Camera& camera, const EdgeModel& e, const Rigid3d& pose) {
  const Eigen::Vector2d pa = camera.Project<double>(pose * e.A);
  const Eigen::Vector2d pb = camera.Project<double>(pose * e.B);
  const Eigen::Vector2d d = (pb - pa).normalized();
  const Eigen::Vector2d n(-d.y(), d.x());
  return {n.dot(e.a - pa), n.dot(e.b - pa)};
}

TEST_CASE("edge prediction: SigmaAt interpolates the ends' variances", "[track]") {
  EdgeModel e;
  e.var_a = 4;
  e.var_b = 9;
  CHECK(e.SigmaAt(0) == Approx(2));
  CHECK(e.SigmaAt(1) == Approx(3));
  CHECK(e.SigmaAt(0.5) == Approx(std::sqrt(0.25 * 4 + 0.25 * 9)));
  e.cov_ab = -6;  // perfectly anti-correlated ends: the piece turns about a point inside it
  CHECK(e.SigmaAt(0.4) == Approx(0).margin(1e-6));
}

TEST_CASE("edge prediction: each visible piece where the mean projects it", "[track]") {
  const Scene s;
  const GaussianState state = MakePrior(s.graph.blocks, s.at, {1e-9, 1e-9, 1e-9});
  const std::vector<EdgeModel> predicted =
      PredictEdges(s.graph, s.edges, state, s.camera, kVisibility, 0.5, 12);
  std::vector<ProjectedEdge> pieces;
  for (const ProjectedEdge& p : VisibleEdges(s.graph, s.edges, s.at, s.camera, kVisibility)) {
    if ((p.b - p.a).norm() >= 12) pieces.push_back(p);
  }
  REQUIRE(predicted.size() == pieces.size());
  REQUIRE(predicted.size() >= 6);
  const Rigid3d& pose = s.at.poses[0];
  for (size_t i = 0; i < predicted.size(); ++i) {
    const EdgeModel& e = predicted[i];
    const ProjectedEdge& p = pieces[i];
    CAPTURE(i);
    CHECK(e.edge == p.edge);
    CHECK(e.block == s.graph.components[0].block);
    CHECK((pose * e.A - p.A).norm() < 1e-12);
    CHECK((pose * e.B - p.B).norm() < 1e-12);
    CHECK((e.a - p.a).norm() < 1e-12);
    CHECK(e.length == Approx((p.b - p.a).norm()));
    CHECK((e.dir * e.length - (p.b - p.a)).norm() < 1e-9);
    CHECK(e.normal == Eigen::Vector2d(-e.dir.y(), e.dir.x()));
    CHECK((e.mid - 0.5 * (p.a + p.b)).norm() < 1e-12);
    CHECK(e.orientation == Approx(std::atan2(e.dir.y(), e.dir.x())));
    // The piece's ends as fractions of its whole model edge.
    const Component& c = s.graph.components[0];
    const Eigen::Vector3d start = c.points[s.edges[e.edge].a].position;
    const Eigen::Vector3d end = c.points[s.edges[e.edge].b].position;
    CHECK((start + e.t0 * (end - start) - e.A).norm() < 1e-9);
    CHECK((start + e.t1 * (end - start) - e.B).norm() < 1e-9);
    // A state known exactly: only the pixel noise is left.
    CHECK(e.noise == 0.5);
    CHECK(e.var_a < 1e-6);
    CHECK(e.sigma_x == Approx(e.noise).epsilon(1e-4));
    CHECK(e.sigma_y == Approx(std::sqrt(2.0) * e.noise / e.length).epsilon(1e-4));
  }
  CHECK(PredictEdges(s.graph, s.edges, state, s.camera, kVisibility, 0.5, 1e9).empty());
}

TEST_CASE("edge prediction: the ends' variance across the edge is A P Aᵀ", "[track]") {
  const Scene s;
  const GaussianState state = Uncertain(s.graph.blocks, s.at);
  const std::vector<EdgeModel> predicted =
      PredictEdges(s.graph, s.edges, state, s.camera, kVisibility, 0.5, 12);
  REQUIRE_FALSE(predicted.empty());
  const double h = 1e-6;
  for (const EdgeModel& e : predicted) {
    Eigen::Matrix<double, 2, 6> A;
    for (int i = 0; i < 6; ++i) {
      Eigen::VectorXd step = Eigen::VectorXd::Zero(6);
      step[i] = h;
      Values plus = s.at, minus = s.at;
      Retract(s.graph.blocks, step, &plus);
      Retract(s.graph.blocks, -step, &minus);
      A.col(i) =
          (Across(s.camera, e, plus.poses[0]) - Across(s.camera, e, minus.poses[0])) / (2 * h);
    }
    const Eigen::Matrix2d S = A * state.covariance.topLeftCorner<6, 6>() * A.transpose();
    CHECK(e.var_a == Approx(S(0, 0)).epsilon(1e-5));
    CHECK(e.var_b == Approx(S(1, 1)).epsilon(1e-5));
    CHECK(e.cov_ab == Approx(S(0, 1)).epsilon(1e-5));
    // The midpoint across, and the angle, each with the pixel noise.
    const double mid = 0.25 * (S(0, 0) + S(1, 1) + 2 * S(0, 1)) + e.noise * e.noise;
    const double turn =
        (S(0, 0) + S(1, 1) - 2 * S(0, 1) + 2 * e.noise * e.noise) / (e.length * e.length);
    CHECK(e.sigma_x == Approx(std::sqrt(mid)).epsilon(1e-5));
    CHECK(e.sigma_y == Approx(std::sqrt(turn)).epsilon(1e-5));
  }
  // An end behind the camera has no variance.
  EdgeModel behind = predicted[0];
  GaussianState flipped = state;
  flipped.mean.poses[0].translation.z() = -2;
  CHECK_FALSE(PredictVariance(s.camera, flipped, &behind));
}

TEST_CASE("edge prediction: the edge factor measures a line's ends across the edge", "[track]") {
  const Scene s;
  const GaussianState state = MakePrior(s.graph.blocks, s.at, {});
  const EdgeModel e = PredictEdges(s.graph, s.edges, state, s.camera, kVisibility, 0.5, 12)[0];
  const Eigen::Matrix2d noise = Eigen::Vector2d(0.3, 0.7).asDiagonal();
  const Factor f = EdgeFactor(s.camera, e, e.a + 2 * e.normal, e.b - 1.5 * e.normal, noise);
  CHECK(f.blocks == std::vector<int>{e.block});
  CHECK(f.noise == noise);
  Eigen::VectorXd r;
  EvaluateResidual(*f.residual, s.graph.blocks, f.blocks, s.at, &r, nullptr);
  CHECK(r[0] == Approx(2).margin(1e-9));
  CHECK(r[1] == Approx(-1.5).margin(1e-9));
}

TEST_CASE("edge prediction: pieces reprojected where a tightened state puts them", "[track]") {
  const Scene s;
  const GaussianState wide = Uncertain(s.graph.blocks, s.at);
  std::vector<EdgeModel> edges =
      PredictEdges(s.graph, s.edges, wide, s.camera, kVisibility, 0.5, 12);
  GaussianState tight = wide;
  tight.mean.poses[0].translation += Eigen::Vector3d(0.01, -0.005, 0.02);
  tight.covariance *= 0.01;
  const std::vector<EdgeModel> before = edges;
  Reproject(s.graph, s.camera, tight, &edges);
  for (size_t i = 0; i < edges.size(); ++i) {
    const EdgeModel& e = edges[i];
    CHECK((e.a - s.camera.Project<double>(tight.mean.poses[0] * e.A)).norm() < 1e-9);
    CHECK((e.b - s.camera.Project<double>(tight.mean.poses[0] * e.B)).norm() < 1e-9);
    CHECK((e.A - before[i].A).norm() == 0);  // the same piece of the model
    CHECK(e.var_a == Approx(0.01 * before[i].var_a).epsilon(0.2));
  }
  // Behind the camera a piece keeps its last image.
  GaussianState behind = tight;
  behind.mean.poses[0].translation.z() = -2;
  std::vector<EdgeModel> kept = edges;
  Reproject(s.graph, s.camera, behind, &kept);
  CHECK(kept[0].a == edges[0].a);
}

}  // namespace
}  // namespace cfuse
