// The tracker that finds the object by itself (cfuse/track/auto_tracker.h): Castle-simu tracked
// with no start, the first frame detected; a box knocked past every search range, with the
// tracker's own rings turned off, found again by detection; an image without it, not found, with
// the reason.
#include "cfuse/track/auto_tracker.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "cfuse/importers/cao.h"
#include "cfuse/importers/visp.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"
#include "track/track_run.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

TEST_CASE("auto tracker: Castle-simu with no start, its first frame detected", "[tracker]") {
  const fs::path d = "/usr/share/visp-images-data/ViSP-images/mbt-depth/Castle-simu";
  if (!fs::exists(d)) {
    WARN("visp-images-data is not installed: skipped");
    return;
  }
  const ConstraintGraph graph = ImportCao((d / "Models/chateau.cao").string());
  Camera camera = ReadVispCamera((d / "Config/chateau.xml").string());
  camera.width = 640;
  camera.height = 480;
  AutoTracker tracker(graph, camera);
  for (int k = 1; k <= 6; ++k) {
    CAPTURE(k);
    char name[64];
    std::snprintf(name, sizeof name, "Images/Image_%04d.pgm", k);
    const cv::Mat image = cv::imread((d / name).string(), cv::IMREAD_GRAYSCALE);
    REQUIRE_FALSE(image.empty());
    const TrackedFrame f =
        tracker.Track({image.data, image.cols, image.rows, static_cast<int>(image.step)});
    REQUIRE(f.verified);
    CHECK(f.detected == (k == 1));
    std::snprintf(name, sizeof name, "CameraPose/Camera_%03d.txt", k);
    const Rigid3d truth = testing::ReadPoseMatrix((d / name).string());
    CHECK((f.estimate.mean.poses[0].translation - truth.translation).norm() < 0.005);
  }
  CHECK(tracker.detections() == 1);
  CHECK(tracker.detections_found() == 1);
}

TEST_CASE("auto tracker: a box knocked past every range is detected again", "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  SequenceSpec spec = StandardSequence(graph, "steady", 22, 5);
  spec.jump = Eigen::Vector3d(0.3, 0.08, 0);
  spec.jump_frame = 15;
  const std::vector<SequenceFrame> frames = RenderSequence(graph, StandardCamera(), spec);
  AutoTrackerOptions options;
  options.tracker.reacquisition_places = 0;  // no rings: only detection can find it
  AutoTracker tracker(graph, StandardCamera(), frames[0].truth, options);
  int found_at = -1;
  for (int i = 0; i < 22; ++i) {
    CAPTURE(i);
    const TrackedFrame f = tracker.Track(testing::View(frames[i].rendering));
    if (i < 15) CHECK(f.verified);
    if (i >= 15 && f.detected && found_at < 0) found_at = i;
    if (f.verified) {
      // Right, up to the box's symmetry (a detected box may be turned half round): its centre
      // where the truth's is.
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (const FeaturePoint& p : graph.components[0].points) centre += p.position;
      centre /= static_cast<double>(graph.components[0].points.size());
      CHECK((f.estimate.mean.poses[0] * centre - frames[i].truth.poses[0] * centre).norm() < 0.01);
    }
    if (i >= 15 && i < 15 + options.redetect_after) CHECK_FALSE(f.verified);
  }
  CHECK(found_at >= 15 + options.redetect_after - 1);
  CHECK(found_at < 22);
  CHECK(tracker.detections_found() >= 1);
}

TEST_CASE("auto tracker: an image without the object is lost, with the reason", "[tracker]") {
  const ConstraintGraph graph = ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
  const Camera camera = StandardCamera();
  std::vector<std::uint8_t> blank(static_cast<size_t>(camera.width) * camera.height, 128);
  AutoTracker tracker(graph, camera);
  const TrackedFrame f = tracker.Track({blank.data(), camera.width, camera.height, camera.width});
  CHECK_FALSE(f.verified);
  CHECK_FALSE(f.detected);
  CHECK(f.verification.why.find("not detected") != std::string::npos);
  CHECK(tracker.detections() == 1);
  CHECK(tracker.detections_found() == 0);
}

}  // namespace
}  // namespace cfuse
