// Detection with no pose given (cfuse/track/detector.h): ViSP's Castle-simu frames found at their
// true pose, the rigid box found in renders of the project's own, nothing found in an image
// without the object (with the reason), and the inputs it refuses.
#include "cfuse/track/detector.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/cao.h"
#include "cfuse/importers/visp.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"
#include "track/track_run.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

const fs::path kCastle = "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu";

GrayView View(const cv::Mat& m) {
  return {m.data, m.cols, m.rows, static_cast<int>(m.step)};
}

// The largest distance (px) between where `a` and `b` project the model's points.
double PointDistance(const ConstraintGraph& graph, const Camera& camera, const Values& a,
                     const Values& b) {
  double most = 0;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const Rigid3d& pa = a.poses[graph.blocks[c.block].index];
    const Rigid3d& pb = b.poses[graph.blocks[c.block].index];
    for (const FeaturePoint& p : c.points) {
      most = std::max(most, (camera.Project<double>(pa * p.position) -
                             camera.Project<double>(pb * p.position))
                                .norm());
    }
  }
  return most;
}

// The largest distance (px) from where `a` projects a model point to the nearest of the points
// `b` projects: PointDistance for a model with no symmetry, and 0 for a box turned half round.
double SetDistance(const ConstraintGraph& graph, const Camera& camera, const Values& a,
                   const Values& b) {
  std::vector<Eigen::Vector2d> pb;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    for (const FeaturePoint& p : c.points) {
      pb.push_back(camera.Project<double>(b.poses[graph.blocks[c.block].index] * p.position));
    }
  }
  double most = 0;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    for (const FeaturePoint& p : c.points) {
      const Eigen::Vector2d q = camera.Project<double>(a.poses[graph.blocks[c.block].index] * p.position);
      double nearest = INFINITY;
      for (const Eigen::Vector2d& r : pb) nearest = std::min(nearest, (q - r).norm());
      most = std::max(most, nearest);
    }
  }
  return most;
}

TEST_CASE("detector: Castle-simu's frames found at their true pose with no pose given",
          "[tracker]") {
  if (!fs::exists(kCastle)) {
    WARN("visp-images-data is not installed: skipped");
    return;
  }
  const ConstraintGraph graph = ImportCao((kCastle / "Models/chateau.cao").string());
  Camera camera = ReadVispCamera((kCastle / "Config/chateau.xml").string());
  for (const int k : {1, 20, 40}) {
    CAPTURE(k);
    char name[64];
    std::snprintf(name, sizeof name, "Images/Image_%04d.pgm", k);
    const cv::Mat image = cv::imread((kCastle / name).string(), cv::IMREAD_GRAYSCALE);
    REQUIRE_FALSE(image.empty());
    camera.width = image.cols;
    camera.height = image.rows;
    std::snprintf(name, sizeof name, "CameraPose/Camera_%03d.txt", k);
    Values truth = graph.nominal;
    const Rigid3d camera_from_object = testing::ReadPoseMatrix((kCastle / name).string());
    for (Rigid3d& pose : truth.poses) pose = camera_from_object * pose;

    const Detection d = Detect(graph, camera, View(image));
    REQUIRE(d.found.size() == 1);
    CHECK(d.found[0].verified);
    CHECK(d.why.empty());
    CHECK(PointDistance(graph, camera, d.found[0].estimate.mean, truth) < 3);
    CHECK(d.stats.junctions > 10);
    CHECK(d.stats.poses > 1000);
    CHECK(d.stats.candidates >= 1);
    CHECK_FALSE(d.stats.poses_cut);
  }
}

TEST_CASE("detector: the rigid box found in renders at several poses", "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  int found = 0;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const std::vector<SequenceFrame> frames =
        RenderSequence(graph, StandardCamera(), StandardSequence(graph, "steady", 1, seed));
    const Detection d = Detect(graph, StandardCamera(), testing::View(frames[0].rendering));
    CAPTURE(seed, d.why);
    // Whatever is found is right, up to the box's symmetry: its corners where the truth's are,
    // in some order.
    for (const TrackedFrame& f : d.found) {
      CHECK(SetDistance(graph, StandardCamera(), f.estimate.mean, frames[0].truth) < 3);
      CHECK(SetDistance(graph, StandardCamera(), frames[0].truth, f.estimate.mean) < 3);
    }
    found += !d.found.empty();
  }
  CHECK(found >= 3);
}

TEST_CASE("detector: the hinged box found with its lid where it stands", "[tracker]") {
  // The candidates try the lid across its range (DetectorOptions::joint_values); found at the
  // nominal angle alone, the lid's edges would find nothing and refuse every candidate.
  const ConstraintGraph graph = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  DetectorOptions nominal;
  nominal.joint_values = 0;
  int found = 0, found_nominal = 0;
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const std::vector<SequenceFrame> frames =
        RenderSequence(graph, StandardCamera(), StandardSequence(graph, "steady", 1, seed));
    const GrayView view = testing::View(frames[0].rendering);
    const Detection d = Detect(graph, StandardCamera(), view);
    CAPTURE(seed, d.why);
    for (const TrackedFrame& f : d.found) {
      CHECK(PointDistance(graph, StandardCamera(), f.estimate.mean, frames[0].truth) < 3);
    }
    found += !d.found.empty();
    found_nominal += !Detect(graph, StandardCamera(), view, nominal).found.empty();
  }
  CHECK(found == 4);
  CHECK(found_nominal < found);  // what the joints' values are for
}

TEST_CASE("detector: an image without the object finds nothing and says why", "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  // A blank image: no segments, no junctions.
  std::vector<std::uint8_t> blank(static_cast<size_t>(camera.width) * camera.height, 128);
  const Detection none = Detect(graph, camera, {blank.data(), camera.width, camera.height, camera.width});
  CHECK(none.found.empty());
  CHECK(none.why.find("no junction") != std::string::npos);
  // Disks of every size and grey: edges and junctions of a sort, but no box.
  cv::Mat disks(camera.height, camera.width, CV_8U, cv::Scalar(90));
  for (int k = 0; k < 40; ++k) {
    cv::circle(disks, cv::Point(37 * k % camera.width, 53 * k % camera.height), 10 + 7 * (k % 5),
               cv::Scalar(30 + 5 * k), cv::FILLED);
  }
  cv::rectangle(disks, cv::Rect(100, 100, 40, 200), cv::Scalar(220), cv::FILLED);
  const Detection d = Detect(graph, camera, View(disks));
  CHECK(d.found.empty());
  CHECK_FALSE(d.why.empty());
  CHECK(d.stats.segments > 0);
  // The caller's segments instead of the detector's: none given, none used.
  const std::vector<ImageSegment> no_segments;
  const Detection given = Detect(graph, camera, View(disks), {}, &no_segments);
  CHECK(given.stats.segments == 0);
  CHECK(given.why.find("no junction") != std::string::npos);
}

TEST_CASE("detector: the model's points in the image, the same for a box turned half round",
          "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  const std::vector<SequenceFrame> frames =
      RenderSequence(graph, camera, StandardSequence(graph, "steady", 1, 1));
  const Values& truth = frames[0].truth;
  const std::vector<Eigen::Vector2d> points = ProjectedPoints(graph, camera, truth);
  REQUIRE(points.size() == graph.components[0].points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    CHECK((points[i] - camera.Project<double>(truth.poses[0] * graph.components[0].points[i].position))
              .norm() < 1e-9);
  }
  // Turned half round about an axis through the box's centre along one of its own axes: the same
  // points, in another order.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const FeaturePoint& p : graph.components[0].points) centre += p.position;
  centre /= static_cast<double>(graph.components[0].points.size());
  Values turned = truth;
  turned.poses[0] = truth.poses[0] * Rigid3d(Eigen::Quaterniond::Identity(), centre) *
                    Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ())),
                            Eigen::Vector3d::Zero()) *
                    Rigid3d(Eigen::Quaterniond::Identity(), -centre);
  const std::vector<Eigen::Vector2d> twin = ProjectedPoints(graph, camera, turned);
  REQUIRE(twin.size() == points.size());
  double moved = 0;  // the most any one point moved
  for (size_t i = 0; i < twin.size(); ++i) {
    double nearest = INFINITY;
    for (const Eigen::Vector2d& p : points) nearest = std::min(nearest, (twin[i] - p).norm());
    CHECK(nearest < 1e-6);
    moved = std::max(moved, (twin[i] - points[i]).norm());
  }
  CHECK(moved > 10);
}

TEST_CASE("detector: noise finds nothing, and a search cut short says so", "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  // Noise at every contrast: steps and segments everywhere, never a box.
  for (const int seed : {1, 2, 3}) {
    cv::Mat noise(camera.height, camera.width, CV_8U);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5 * seed);
    const Detection d = Detect(graph, camera, View(noise));
    CAPTURE(seed, d.why);
    CHECK(d.found.empty());
    CHECK_FALSE(d.why.empty());
  }
  // The rigid box in a plain render, the search bounded to 2 junctions and 50 poses: the
  // bounds are reported, and whatever is found is right.
  const std::vector<SequenceFrame> frames =
      RenderSequence(graph, camera, StandardSequence(graph, "steady", 1, 1));
  DetectorOptions tight;
  tight.max_junctions = 2;
  tight.max_poses = 50;
  const Detection d = Detect(graph, camera, testing::View(frames[0].rendering), tight);
  CHECK(d.stats.junctions_cut);
  CHECK(d.stats.poses_cut);
  CHECK(d.stats.poses == 50);
  for (const TrackedFrame& f : d.found) {
    CHECK(SetDistance(graph, camera, f.estimate.mean, frames[0].truth) < 3);
  }
  // Unbounded, neither is.
  const Detection full = Detect(graph, camera, testing::View(frames[0].rendering));
  CHECK_FALSE(full.stats.junctions_cut);
  CHECK_FALSE(full.stats.poses_cut);
}

TEST_CASE("detector: poses from elsewhere tracked and decided among as detection's own",
          "[tracker]") {
  // DetectFrom is Detect's last step alone (for a baseline's hypotheses): the true pose among
  // poses far off is found, and found alone; far-off poses alone find nothing, and say so.
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  const std::vector<SequenceFrame> frames =
      RenderSequence(graph, camera, StandardSequence(graph, "steady", 1, 1));
  const GrayView view = testing::View(frames[0].rendering);
  Values far = frames[0].truth;
  for (Rigid3d& pose : far.poses) pose.translation += Eigen::Vector3d(0.3, 0.2, 0);
  const Detection found = DetectFrom(graph, camera, view, {far, frames[0].truth});
  REQUIRE(found.found.size() == 1);
  CHECK(found.why.empty());
  CHECK(SetDistance(graph, camera, found.found[0].estimate.mean, frames[0].truth) < 3);
  CHECK(found.stats.candidates == 2);
  CHECK(found.candidates.size() == 2);
  CHECK_FALSE(found.candidates[0].frame.verified);

  const Detection missed = DetectFrom(graph, camera, view, {far});
  CHECK(missed.found.empty());
  CHECK(missed.why == "none of 1 poses verified");
  CHECK(DetectFrom(graph, camera, view, {}).why == "no pose to start from");
  std::vector<std::uint8_t> small(100 * 80, 128);
  CHECK_THROWS_WITH(DetectFrom(graph, camera, {small.data(), 100, 80, 100}, {far}),
                    Catch::Contains("the image is 100 x 80, the camera's"));
}

TEST_CASE("detector: refuses an image of another size, an empty one, a model without edges",
          "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  std::vector<std::uint8_t> small(100 * 80, 128);
  CHECK_THROWS_WITH(Detect(graph, camera, {small.data(), 100, 80, 100}),
                    Catch::Contains("the image is 100 x 80, the camera's"));
  CHECK_THROWS_AS(Detect(graph, camera, GrayView{}), InputError);
  ConstraintGraph bare = graph;
  for (Component& c : bare.components) {
    c.edges.clear();
    c.faces.clear();
  }
  std::vector<std::uint8_t> image(static_cast<size_t>(camera.width) * camera.height, 128);
  CHECK_THROWS_WITH(Detect(bare, camera, {image.data(), camera.width, camera.height, camera.width}),
                    Catch::Contains("no edges to find"));
}

}  // namespace
}  // namespace cfuse
