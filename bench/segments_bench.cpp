// The segment detectors' speed, stage by stage, against cv::Canny alone: the benchmark of
// issue 6 (docs/benchmarks.md).
//
//   segments_bench [--scenes 20] [--repeat 15] [--sizes 640x480,1280x720]
//
// For each image size it renders SCENES scenes (the hinged box at random poses and openings,
// filling most of the image, 30 clutter lines and 12 blobs, noise 2 grey levels, blur 0.8 px),
// then times on each, REPEAT times, every detector (DetectSegments' own stage times), building
// the segment index over its result, and cv::Canny alone on the same image with the thresholds
// Canny's path uses. All on one core (cv::setNumThreads(1)). It prints the median over scenes
// of each scene's fastest run (a shared machine's pauses only ever add time) per stage, the
// detector's total (the index apart), and the ratio of that total to Canny alone, measured in
// the same run.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "bench/sweep_main.h"
#include "cfuse/dsl/model_loader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/segment_index.h"
#include "cfuse/vision/segments.h"

namespace {

using namespace cfuse;
using Clock = std::chrono::steady_clock;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

struct Sizes {
  int width, height;
};

std::vector<Sizes> ParseSizes(const std::string& text) {
  std::vector<Sizes> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    const size_t x = item.find('x');
    if (x == std::string::npos) throw std::invalid_argument("size '" + item + "' is not WxH");
    out.push_back({std::stoi(item.substr(0, x)), std::stoi(item.substr(x + 1))});
  }
  return out;
}

int Run(int argc, char** argv) {
  CLI::App app{"Segment detectors, stage by stage, against cv::Canny alone (issue 6)"};
  int scenes = 20, repeat = 15;
  std::string sizes = "640x480,1280x720";
  app.add_option("--scenes", scenes, "rendered scenes per size")->check(CLI::Range(1, 1000));
  app.add_option("--repeat", repeat, "runs per scene and detector")->check(CLI::Range(1, 1000));
  app.add_option("--sizes", sizes, "image sizes WxH, comma-separated");
  CLI11_PARSE(app, argc, argv);
  cv::setNumThreads(1);

  const ConstraintGraph g = LoadModel(CFUSE_SOURCE_DIR "/examples/hinged-box.yaml");
  fmt::print(
      "| image | detector | segments | smoothing | edges | linking | subdivision | index | total "
      "| cv::Canny alone | total / Canny |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const Sizes& size : ParseSizes(sizes)) {
    Camera camera;
    camera.width = size.width;
    camera.height = size.height;
    camera.cx = size.width / 2.0;
    camera.cy = size.height / 2.0;
    // The simulation frames the box at 40 % of the image with f = 800 (at 640 x 480); 2.5 x
    // that focal length fills most of it, at any size in proportion.
    camera.fx = camera.fy = 800.0 * size.height / 480;
    std::vector<Rendering> renderings;
    for (int s = 0; s < scenes; ++s) {
      SimulateOptions so;
      so.seed = 500 + s;
      so.camera = camera;
      so.sample_joints = true;
      const Simulation sim = Simulate(g, so);
      Camera close = camera;
      close.fx = close.fy = 2.5 * camera.fx;
      RenderOptions ro;
      ro.seed = s;
      renderings.push_back(Render(g, sim.truth, close, ro));
    }
    // cv::Canny alone, with the thresholds of the Canny path (contrasts 8 and 20 as Sobel
    // magnitudes of a unit step: 2.66 per grey level at sigma 1.2, measured there).
    std::vector<double> canny;
    for (const Rendering& r : renderings) {
      const cv::Mat image(r.height, r.width, CV_8U, const_cast<std::uint8_t*>(r.pixels.data()));
      cv::Mat edges;
      double best = 1e300;
      for (int k = 0; k < repeat; ++k) {
        const auto start = Clock::now();
        cv::Canny(image, edges, 8 * 2.66, 20 * 2.66, 3, true);
        best =
            std::min(best, std::chrono::duration<double, std::milli>(Clock::now() - start).count());
      }
      canny.push_back(best);
    }
    const double canny_ms = Median(canny);
    for (SegmentDetector d :
         {SegmentDetector::kLowe, SegmentDetector::kCanny,
          SegmentDetector::kLsd}) {
      std::vector<double> smoothing, edges, linking, subdivision, index, total;
      std::vector<double> count;
      for (const Rendering& r : renderings) {
        SegmentOptions o;
        o.detector = d;
        StageTimes best;
        double best_total = 1e300, best_index = 1e300;
        size_t n = 0;
        for (int k = 0; k < repeat; ++k) {
          StageTimes t;
          std::vector<ImageSegment> found =
              DetectSegments({r.pixels.data(), r.width, r.height, r.width}, o, &t);
          n = found.size();
          const auto start = Clock::now();
          const SegmentIndex built(std::move(found), r.width, r.height);
          const double index_ms =
              std::chrono::duration<double, std::milli>(Clock::now() - start).count();
          if (t.Total() < best_total) {
            best_total = t.Total();
            best = t;
            best_index = index_ms;
          }
        }
        smoothing.push_back(best.smoothing);
        edges.push_back(best.edges);
        linking.push_back(best.linking);
        subdivision.push_back(best.subdivision);
        index.push_back(best_index);
        total.push_back(best_total);
        count.push_back(static_cast<double>(n));
      }
      fmt::print(
          "| {} x {} | {} | {:.0f} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | {:.3f} | **{:.3f}** | "
          "{:.3f} | {:.2f} |\n",
          size.width, size.height, DetectorName(d), Median(count), Median(smoothing),
          Median(edges), Median(linking), Median(subdivision), Median(index), Median(total),
          canny_ms, Median(total) / canny_ms);
      std::fflush(stdout);
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return cfuse::bench::SweepMain("segments_bench", Run, argc, argv);
}
