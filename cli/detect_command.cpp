#include "cli/detect_command.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>
#include <ostream>

#include "cfuse/track/detector.h"
#include "cli/command_support.h"
#include "cli/frame_results.h"
#include "cli/image_support.h"
#include "cli/results.h"
#include "cli/track_overlay.h"

namespace cfuse::cli {
int RunDetect(const DetectCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    for (const std::string* path : {&options.output, &options.overlay}) {
      if (!path->empty()) RequireWritable(*path);
    }
    if (options.max_results < 1) {
      throw InputError(SourceLocation("--max-results"), "must be at least 1");
    }
    const ConstraintGraph graph = LoadAnyModel(options.model);
    RequireEdges(graph, options.model, "find in an image");
    Camera camera = LoadAnyCamera(options.camera);
    const cv::Mat image = ReadGrayImage(options.image);
    if (camera.width <= 0 || camera.height <= 0) {
      SizeCameraFromImage(image, options.image, options.camera, &camera);
    } else if (image.cols != camera.width || image.rows != camera.height) {
      throw InputError(SourceLocation(options.image),
                       fmt::format("the image is {} x {}, the camera's ({}) {} x {}", image.cols,
                                   image.rows, options.camera, camera.width, camera.height));
    }
    const GrayView view{image.data, image.cols, image.rows, static_cast<int>(image.step)};
    DetectorOptions detector;
    detector.max_results = options.max_results;
    const Detection d = Detect(graph, camera, view, detector);

    const nlohmann::json json = DetectionJson(graph, d, options.image);
    const DetectionStats& s = d.stats;
    const std::string text = json.dump(2) + "\n";
    if (!options.overlay.empty()) {
      // The object found, or the best candidate tracked, marked as refused.
      const TrackedFrame shown = !d.found.empty()      ? d.found[0]
                                 : d.candidates.empty() ? TrackedFrame{}
                                                        : d.candidates[0].frame;
      OverlayOptions overlay;
      overlay.caption = d.found.empty()
                            ? fmt::format("NOT FOUND  {:.0f} ms", s.Total())
                            : fmt::format("found  {} matches  {:.0f} ms", shown.matches, s.Total());
      WriteFileAtomically(options.overlay,
                          PngBytes(DrawOverlay(view, graph, camera, shown, overlay)));
    }
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    if (s.junctions_cut || s.poses_cut) {
      err << fmt::format("cfuse detect: the search was cut short ({})\n",
                         s.poses_cut ? "the bound on ranked poses was reached"
                                     : "junctions beyond the strongest were left out");
    }
    if (d.found.empty()) {
      err << fmt::format("cfuse detect: {} not found in {}: {}\n", graph.name, options.image, d.why);
      return 1;
    }
    for (size_t i = 0; i < d.found.size(); ++i) {
      const Verification& v = d.found[i].verification;
      err << fmt::format(
          "cfuse detect: {} found ({} of {}): {} matched edges, {:.0f} % of the outline supported "
          "(chance {:.0f} %), {:.1f} px RMS{}\n",
          graph.name, i + 1, d.found.size(), d.found[i].matches, 100 * v.share, 100 * v.chance,
          d.found[i].residual_sigma,
          d.twins[i].empty()
              ? ""
              : fmt::format("; the same outline at {} other pose(s): the model's symmetry, "
                            "which the image cannot tell apart",
                            d.twins[i].size()));
    }
    return 0;
  });
}

}  // namespace cfuse::cli
