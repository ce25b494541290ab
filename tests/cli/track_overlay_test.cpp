// The tracker's overlays (cli/track_overlay.h): the model yellow on a verified frame, red on a
// lost one.
#include "cli/track_overlay.h"

#include <algorithm>
#include <catch2/catch.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/vision/sequence.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

GrayView View(const Rendering& r) {
  return {r.pixels.data(), r.width, r.height, r.width};
}

TEST_CASE("tracker: overlays draw the model yellow when verified and red when lost", "[tracker]") {
  const ConstraintGraph graph = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const SequenceSpec spec = StandardSequence(graph, "steady", 2, 1);
  std::vector<SequenceFrame> sequence =
      RenderSequence(graph, StandardCamera(), spec);
  Tracker tracker(graph, StandardCamera(), sequence[0].truth);
  // Pixels of a colour, anti-aliasing allowed for: yellow is strong red and green without
  // blue, red is strong red alone (BGR).
  auto count = [](const cv::Mat3b& image, bool yellow) {
    int n = 0;
    for (int v = 0; v < image.rows; ++v) {
      for (int u = 0; u < image.cols; ++u) {
        const cv::Vec3b& p = image(v, u);
        const bool strong_red = p[2] > 180 && p[0] < 110;
        n += strong_red && (yellow ? p[1] > 150 : p[1] < 80);
      }
    }
    return n;
  };
  const TrackedFrame good = tracker.Track(View(sequence[0].rendering));
  REQUIRE(good.verified);
  const cv::Mat3b drawn =
      DrawOverlay(View(sequence[0].rendering), graph, StandardCamera(), good);
  CHECK(drawn.cols == 640);
  CHECK(drawn.rows == 480);
  CHECK(count(drawn, true) > 500);
  CHECK(count(drawn, false) == 0);

  std::fill(sequence[1].rendering.pixels.begin(), sequence[1].rendering.pixels.end(), 90);
  const TrackedFrame lost = tracker.Track(View(sequence[1].rendering));
  REQUIRE_FALSE(lost.verified);
  const cv::Mat3b red =
      DrawOverlay(View(sequence[1].rendering), graph, StandardCamera(), lost);
  CHECK(count(red, false) > 500);
  CHECK(count(red, true) == 0);
}

}  // namespace
}  // namespace cfuse::cli
