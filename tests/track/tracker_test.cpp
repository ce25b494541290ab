// The tracker on rendered sequences with known truth (cfuse/vision/sequence.h's standard
// scenarios): the rigid box and the hinged box, steady, fast (about 20 px a frame), half occluded,
// in heavy clutter, and knocked further than the search range reaches (the range must double). Each
// asserts the share of frames verified and the errors of the verified ones, over two seeds;
// then what a tracker must never do: verify a wrong pose from a far-off start, or let a lost
// frame corrupt the next.
#include "cfuse/track/tracker.h"

#include <algorithm>
#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/cao.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/vision/sequence.h"
#include "cfuse/vision/texture.h"
#include "test_util.h"
#include "track/track_run.h"

namespace cfuse {
namespace {

using testing::Errors;
using testing::Run;
using testing::View;

ConstraintGraph HingedBox() {
  return LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
}
ConstraintGraph RigidBox() {
  return ImportCao(testing::SourcePath("tests/data/cao/file_box.cao"));
}

struct Bar {
  const char* scenario;
  double verified;      // share of frames, at least
  double median_mm;     // translation error, at most
  double p90_mm;        // 90th percentile
  double median_joint;  // degrees
  RenderStyle style = RenderStyle::kPlain;
};

// The photographs of Debian's visp-images-data on the realistic renders' faces and backgrounds
// (procedural cards when the package is missing, cfuse/vision/texture.h).
std::shared_ptr<const std::vector<GrayImage>> Photographs() {
  static const auto photographs = std::make_shared<const std::vector<GrayImage>>(
      LoadPhotographs(VispPhotographPaths()));
  return photographs;
}

void CheckScenario(const ConstraintGraph& graph, const Bar& bar, int frames = 40) {
  for (unsigned seed : {1u, 2u}) {
    CAPTURE(bar.scenario, seed, RenderStyleName(bar.style));
    const SequenceSpec spec = StandardSequence(
        graph, bar.scenario, frames, seed, bar.style,
        bar.style == RenderStyle::kRealistic ? Photographs() : nullptr);
    const std::vector<SequenceFrame> sequence =
        RenderSequence(graph, StandardCamera(), spec);
    const Errors e = Run(graph, sequence, sequence[0].truth);
    CHECK(e.verified >= bar.verified * e.frames);
    // No wrong pose verified: every verified frame within 10 mm of the truth.
    CHECK(Errors::Quantile(e.translation_mm, 1.0) <= 10);
    // ... and its joint within 6 degrees (the most measured: 5.2, a lid in realistic clutter;
    // docs/benchmarks.md).
    if (!graph.joints.empty()) CHECK(Errors::Quantile(e.joint_deg, 1.0) <= 6);
    CHECK(Errors::Quantile(e.translation_mm, 0.5) <= bar.median_mm);
    CHECK(Errors::Quantile(e.translation_mm, 0.9) <= bar.p90_mm);
    CHECK(Errors::Quantile(e.rotation_deg, 0.5) <= 1.0);
    if (!graph.joints.empty()) CHECK(Errors::Quantile(e.joint_deg, 0.5) <= bar.median_joint);
    if (std::string(bar.scenario) == "fast")
      CHECK(MedianImageMotion(graph, sequence, StandardCamera()) >= 15);
  }
}

TEST_CASE("tracker: the rigid box, steady and fast, to a fraction of a millimetre", "[tracker]") {
  const ConstraintGraph graph = RigidBox();
  CheckScenario(graph, {"steady", 1.0, 0.5, 1.0, 0});
  CheckScenario(graph, {"fast", 0.95, 0.5, 3.0, 0});
}

TEST_CASE("tracker: the hinged box opening and closing while it moves (7 DOF)", "[tracker]") {
  CheckScenario(HingedBox(), {"steady", 1.0, 3.0, 5.0, 1.5});
}

TEST_CASE("tracker: the hinged box moving fast (median motion over 15 px a frame)", "[tracker]") {
  // (Where the smeared lid turns edge-on its matches leave the pose known to 4.2-4.5 mm, more
  // than the tracker's 4 mm: those frames are refused, their estimates carrying the track.)
  CheckScenario(HingedBox(), {"fast", 0.85, 3.0, 8.0, 1.5});
}

TEST_CASE("tracker: the hinged box behind a sweeping occluder", "[tracker]") {
  // While the bar hides half the box, its depth at 1.3 m is known to 6-7 mm (one standard
  // deviation) from the edges left: those frames are refused (TrackerOptions::
  // max_position_sigma) rather than verified with errors near 10 mm.
  CheckScenario(HingedBox(), {"occluded", 0.75, 3.0, 8.0, 2.0});
}

TEST_CASE("tracker: the hinged box in heavy clutter", "[tracker]") {
  CheckScenario(HingedBox(), {"clutter", 0.95, 3.0, 5.0, 1.5});
}

TEST_CASE("tracker: a robot from its URDF, links with box primitives (the hinged box)",
          "[tracker]") {
  const ConstraintGraph graph =
      ImportUrdf(testing::SourcePath("tests/data/urdf/file_box.urdf"));
  CheckScenario(graph, {"steady", 1.0, 3.0, 5.0, 1.5});
}

// Realistic renders (cfuse/vision/render.h): photographs printed on the faces and behind the
// object, shading with a highlight, motion blur, sensor noise, a hand passing in front.
TEST_CASE("tracker: the hinged box, realistic: texture, highlight, blur, a hand",
          "[tracker][heavy]") {
  const ConstraintGraph graph = HingedBox();
  const auto realistic = RenderStyle::kRealistic;
  CheckScenario(graph, {"steady", 1.0, 2.5, 4.0, 0.5, realistic});
  CheckScenario(graph, {"hand", 0.95, 2.5, 4.0, 0.5, realistic});
  CheckScenario(graph, {"occluded", 0.7, 2.5, 4.0, 0.5, realistic});
  CheckScenario(graph, {"clutter", 0.95, 3.0, 5.0, 0.5, realistic});
  CheckScenario(graph, {"jump", 0.95, 2.5, 4.0, 0.5, realistic});
}

TEST_CASE("tracker: a robot from its URDF, realistic", "[tracker]") {
  const ConstraintGraph graph =
      ImportUrdf(testing::SourcePath("tests/data/urdf/file_box.urdf"));
  CheckScenario(graph, {"steady", 1.0, 2.5, 4.0, 1.0, RenderStyle::kRealistic});
  CheckScenario(graph, {"hand", 0.95, 2.5, 4.0, 1.0, RenderStyle::kRealistic});
}

TEST_CASE("tracker: a cabinet, drawer and door (8 DOF, three parts), with default options",
          "[tracker]") {
  const ConstraintGraph graph =
      LoadModel(testing::SourcePath("examples/cabinet.yaml"));
  // (Its realistic renders are not here: with the door nearly edge-on against a photograph of a
  // calibration grid, a frame 15 mm off was verified; docs/benchmarks.md.)
  CheckScenario(graph, {"steady", 0.95, 2.0, 3.0, 0.5}, 60);
}

TEST_CASE("tracker: a 10 mm plate, its rims' two outlines 6 px apart: never verified wrong",
          "[tracker]") {
  // Which outline of a rim the image shows depends on the light; the plate's depth is then not
  // determined to the tracker's 4 mm, and its frames are refused (the twin edges are not yet
  // told apart: docs/benchmarks.md).
  const ConstraintGraph graph = LoadModel(testing::SourcePath("tests/data/models/plate.yaml"));
  for (const auto style : {RenderStyle::kPlain, RenderStyle::kRealistic}) {
    CAPTURE(RenderStyleName(style));
    const SequenceSpec spec = StandardSequence(
        graph, "steady", 30, 1, style,
        style == RenderStyle::kRealistic ? Photographs() : nullptr);
    const std::vector<SequenceFrame> sequence =
        RenderSequence(graph, StandardCamera(), spec);
    const Errors e = Run(graph, sequence, sequence[0].truth);
    for (double t : e.translation_mm) CHECK(t <= 10);
    for (const TrackedFrame& f : e.track) {
      if (!f.verified) CHECK(f.verification.refusal != Refusal::kNone);
    }
  }
}

TEST_CASE("tracker: a knock the prediction cannot foresee", "[tracker]") {
  CheckScenario(RigidBox(), {"jump", 0.95, 0.5, 3.0, 0});
}

TEST_CASE("tracker: a knock beyond the search range is found by doubling it", "[tracker]") {
  const ConstraintGraph graph = HingedBox();
  CheckScenario(graph, {"jump", 0.95, 3.0, 8.0, 1.5});
  const SequenceSpec spec = StandardSequence(graph, "jump", 40, 1);
  const std::vector<SequenceFrame> sequence =
      RenderSequence(graph, StandardCamera(), spec);
  const Errors e = Run(graph, sequence, sequence[0].truth);
  // At the knock, the range doubled (within at most two frames the track is back).
  const auto& knocked = e.track[spec.jump_frame];
  CHECK(knocked.doublings >= 1);
  CHECK((knocked.verified || e.track[spec.jump_frame + 1].verified ||
         e.track[spec.jump_frame + 2].verified));
  // The knock is no velocity: the frames after it track too.
  for (int i = spec.jump_frame + 3; i < 40; ++i) CHECK(e.track[i].verified);
  // Without doubling, the knock loses the object.
  TrackerOptions no_doubling;
  no_doubling.max_doublings = 0;
  Tracker tracker(graph, StandardCamera(), sequence[0].truth, no_doubling);
  bool lost = false;
  for (int i = 0; i <= spec.jump_frame; ++i) {
    lost = !tracker.Track(View(sequence[i].rendering)).verified;
  }
  CHECK(lost);
}

TEST_CASE("tracker: a far-off start is lost, never verified as a wrong pose", "[tracker]") {
  const ConstraintGraph graph = HingedBox();
  const SequenceSpec spec = StandardSequence(graph, "steady", 20, 3);
  const std::vector<SequenceFrame> sequence =
      RenderSequence(graph, StandardCamera(), spec);
  for (const Eigen::Vector3d& offset :
       {Eigen::Vector3d(0.3, 0, 0), Eigen::Vector3d(0, -0.25, 0), Eigen::Vector3d(0, 0, 0.8)}) {
    CAPTURE(offset.transpose());
    Values initial = sequence[0].truth;
    for (Rigid3d& pose : initial.poses) pose.translation += offset;
    const Errors e = Run(graph, sequence, initial);
    CHECK(e.track[0].verified == false);
    // Whatever it verifies later is right.
    for (double t : e.translation_mm) CHECK(t <= 20);
  }
}

TEST_CASE("tracker: a start off in depth does not pull the first estimate toward it",
          "[tracker]") {
  // The rigid box at 1.3 m, its start 40 or 80 mm too far along the line of sight (8 to 15
  // standard deviations of the prior): held where the start put it, the prior pulls the depth,
  // which the edges fix less well than the rest, a few mm toward itself; widened until the estimate
  // lies within it (TrackerOptions::prior_confidence), it leaves the edges to decide.
  const ConstraintGraph graph = RigidBox();
  const SequenceSpec spec = StandardSequence(graph, "steady", 1, 1);
  const std::vector<SequenceFrame> sequence =
      RenderSequence(graph, StandardCamera(), spec);
  auto first_error_mm = [&](double dz, double confidence) {
    Values initial = sequence[0].truth;
    for (Rigid3d& pose : initial.poses) pose.translation *= 1 + dz / pose.translation.norm();
    TrackerOptions options;
    options.prior_confidence = confidence;
    Tracker tracker(graph, StandardCamera(), initial, options);
    const TrackedFrame f = tracker.Track(View(sequence[0].rendering));
    CHECK(f.verified);
    return 1000 * (f.estimate.mean.poses[0].translation - sequence[0].truth.poses[0].translation)
                      .norm();
  };
  CHECK(first_error_mm(0.04, 1) > 3);  // held
  CHECK(first_error_mm(0.04, 0.999) < 2.5);
  CHECK(first_error_mm(0.08, 1) > 1.5 * first_error_mm(0.08, 0.999));
}

TEST_CASE("tracker: a lost frame does not corrupt the next", "[tracker]") {
  const ConstraintGraph graph = HingedBox();
  const SequenceSpec spec = StandardSequence(graph, "steady", 30, 4);
  std::vector<SequenceFrame> sequence =
      RenderSequence(graph, StandardCamera(), spec);
  // Frames 10 to 12 blank: nothing to match.
  for (int i = 10; i <= 12; ++i) {
    std::fill(sequence[i].rendering.pixels.begin(), sequence[i].rendering.pixels.end(), 90);
  }
  const Errors e = Run(graph, sequence, sequence[0].truth);
  for (int i = 10; i <= 12; ++i) CHECK_FALSE(e.track[i].verified);
  // Each lost frame's estimate is the prediction from the last verified frame, and the track
  // resumes at once.
  for (int i = 13; i < 30; ++i) {
    CAPTURE(i);
    CHECK(e.track[i].verified);
    CHECK((e.track[i].estimate.mean.poses[0].translation - sequence[i].truth.poses[0].translation)
              .norm() <= 0.01);
  }
}

TEST_CASE("tracker: a lost frame's lid pushed shut by its limit is not carried to the next",
          "[tracker][heavy]") {
  // The realistic `clutter` sequence of 120 frames, seed 1: while the lid stands open at 55-110
  // degrees, frames lost for their precision alone find it shut on the box's rim, the lid held
  // at 0 by its limit, and the box 20 mm off so that the closed outline lines up with the open
  // box's. Carried on, that estimate is the next frames' prediction, and the shut lid is
  // verified from there, frame after frame.
  const ConstraintGraph graph = HingedBox();
  const SequenceSpec spec =
      StandardSequence(graph, "clutter", 120, 1, RenderStyle::kRealistic, Photographs());
  const std::vector<SequenceFrame> sequence = RenderSequence(graph, StandardCamera(), spec);
  TrackerOptions carried;
  carried.carry_joints_at_limits = true;
  const Errors with_carry = Run(graph, sequence, sequence[0].truth, carried);
  CHECK(with_carry.JointOff(30) >= 10);  // what it is for
  const Errors e = Run(graph, sequence, sequence[0].truth);
  CHECK(e.JointOff(30) == 0);
  CHECK(Errors::Quantile(e.translation_mm, 1.0) <= 10);
  for (size_t i = 0; i < e.track.size(); ++i) {
    CAPTURE(i);
    if (!e.track[i].imprecise) continue;
    CHECK(JointValues(graph, e.track[i].estimate.mean)[0] > 0.01);
  }
}

TEST_CASE("tracker: bad input is refused with a reason", "[tracker]") {
  const ConstraintGraph graph = HingedBox();
  Camera no_size = StandardCamera();
  no_size.width = no_size.height = 0;
  const Values initial =
      SequencePose(graph, StandardSequence(graph, "steady", 2), 0);
  CHECK_THROWS_WITH(Tracker(graph, no_size, initial), Catch::Contains("no image size"));
  CHECK_THROWS_AS(Tracker(graph, no_size, initial), InputError);
  Tracker tracker(graph, StandardCamera(), initial);
  std::vector<std::uint8_t> small(320 * 240, 0);
  CHECK_THROWS_WITH(tracker.Track({small.data(), 320, 240, 320}),
                    Catch::Contains("320 x 240") && Catch::Contains("640 x 480"));
  CHECK_THROWS_AS(tracker.Track({small.data(), 320, 240, 320}), InputError);
}

}  // namespace
}  // namespace cfuse
