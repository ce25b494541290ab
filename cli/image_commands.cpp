#include "cli/image_commands.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <ostream>
#include <set>
#include <sstream>

#include "cfuse/dsl/pose_reader.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/segments.h"
#include "cfuse/vision/sequence.h"
#include "cfuse/vision/texture.h"
#include "cli/command_support.h"
#include "cli/image_support.h"
#include "cli/results.h"
#include "cli/track_command.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

// Three decimals: a thousandth of a pixel is far below any detector's precision.
double Round3(double x) { return std::round(x * 1000) / 1000; }

nlohmann::json SegmentJson(double x1, double y1, double x2, double y2) {
  return nlohmann::json::array({Round3(x1), Round3(y1), Round3(x2), Round3(y2)});
}

// "x,y,w,h": four whole numbers, the region inside the image.
PixelRect ParseRoi(const std::string& text, const std::string& image, int width,
                           int height) {
  std::vector<long> v;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    long n = 0;
    try {
      n = std::stol(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size()) {
      throw InputError(SourceLocation(image),
                       fmt::format("--roi '{}': expected x,y,w,h, four whole numbers", text));
    }
    v.push_back(n);
  }
  if (v.size() != 4) {
    throw InputError(SourceLocation(image),
                     fmt::format("--roi '{}': expected x,y,w,h, four whole numbers", text));
  }
  if (v[2] <= 0 || v[3] <= 0 || v[0] < 0 || v[1] < 0 || v[0] + v[2] > width ||
      v[1] + v[3] > height) {
    throw InputError(
        SourceLocation(image),
        fmt::format("--roi {}: the region is not inside the {} x {} image", text, width, height));
  }
  return {static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]),
          static_cast<int>(v[3])};
}

// JSON indented, but each array of numbers (a segment) on one line.
std::string Dump(const nlohmann::json& json) {
  const std::string text = JsonText(json, 1);
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '[') {
      // Collapse when only numbers, commas and white space come before the closing bracket.
      size_t j = i + 1;
      while (j < text.size() && (std::isdigit(static_cast<unsigned char>(text[j])) ||
                                 std::strchr("-+.eE, \n", text[j]))) {
        ++j;
      }
      if (j < text.size() && text[j] == ']' && j > i + 1) {
        std::string inner;
        for (size_t k = i + 1; k < j; ++k) {
          if (text[k] == '\n') continue;
          if (text[k] == ' ' && (inner.empty() || inner.back() != ',')) continue;
          inner += text[k];
        }
        out += "[" + inner + "]";
        i = j;
        continue;
      }
    }
    out += text[i];
  }
  return out + "\n";
}

// The JSON to `path`, committed with the command's other staged outputs, or to `out`.
void WriteOrPrint(const std::string& path, const nlohmann::json& json, OutputFiles* files,
                  std::ostream& out) {
  const std::string text = Dump(json);
  if (!path.empty()) files->Stage(path, text);
  files->Commit();
  if (path.empty()) out << text;
}

}  // namespace

int RunSegments(const SegmentsCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    for (const std::string* path : {&options.output, &options.overlay}) {
      if (!path->empty()) RequireWritable(*path);
    }
    const std::optional<SegmentDetector> detector = ParseDetector(options.detector);
    if (!detector) {
      throw InputError(
          SourceLocation(options.image),
          fmt::format("--detector '{}': the detectors are lowe, canny and lsd", options.detector));
    }
    const cv::Mat image = ReadGrayImage(options.image);
    SegmentOptions so;
    so.detector = *detector;
    if (!options.roi.empty()) so.roi = ParseRoi(options.roi, options.image, image.cols, image.rows);
    StageTimes times;
    const std::vector<ImageSegment> segments = DetectSegments(
        {image.data, image.cols, image.rows, static_cast<int>(image.step)}, so, &times);
    nlohmann::json json = {{"width", image.cols},
                           {"height", image.rows},
                           {"detector", DetectorName(*detector)},
                           {"segments", nlohmann::json::array()}};
    for (const ImageSegment& s : segments) {
      json["segments"].push_back(SegmentJson(s.a.x(), s.a.y(), s.b.x(), s.b.y()));
    }
    json["time_ms"] = Round3(times.Total());
    OutputFiles files;  // the overlay and the segments both, or neither
    if (!options.overlay.empty()) {
      cv::Mat picture;
      cv::cvtColor(image, picture, cv::COLOR_GRAY2BGR);
      if (so.roi) {
        cv::rectangle(picture, cv::Rect(so.roi->x, so.roi->y, so.roi->width, so.roi->height),
                      cv::Scalar(255, 160, 0), 1);
      }
      for (const ImageSegment& s : segments) {
        cv::line(picture, cv::Point2f(s.a.x(), s.a.y()), cv::Point2f(s.b.x(), s.b.y()),
                 cv::Scalar(0, 0, 255), 1, cv::LINE_AA);
      }
      files.Stage(options.overlay, PngBytes(picture));
    }
    WriteOrPrint(options.output, json, &files, out);
    return 0;
  });
}

int RunProject(const ProjectCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    for (const std::string* path : {&options.output, &options.overlay}) {
      if (!path->empty()) RequireWritable(*path);
    }
    const ConstraintGraph graph = LoadAnyModel(options.model);
    Camera camera = LoadAnyCamera(options.camera);
    if (camera.width <= 0 || camera.height <= 0) {
      // A camera without a size (ViSP's tracker settings give none) takes the image's.
      if (options.image.empty()) {
        throw InputError(SourceLocation(options.camera),
                         "the camera gives no image size (width and height) to clip the edges "
                         "to: give --image, whose size it then takes");
      }
      SizeCameraFromImage(ReadGrayImage(options.image), options.image, options.camera, &camera);
    }
    if (!options.overlay.empty() && options.image.empty()) {
      throw InputError(SourceLocation(options.overlay),
                       "--overlay draws on an image: give --image");
    }
    const Values values = PosedModel(graph, options.pose);
    const std::vector<ModelEdge> edges = ModelEdges(graph);
    const std::vector<ProjectedEdge> visible =
        VisibleEdges(graph, edges, values, camera);
    nlohmann::json json = {{"width", camera.width},
                           {"height", camera.height},
                           {"edges", nlohmann::json::array()},
                           {"names", nlohmann::json::array()}};
    for (const ProjectedEdge& e : visible) {
      json["edges"].push_back(SegmentJson(e.a.x(), e.a.y(), e.b.x(), e.b.y()));
      json["names"].push_back(graph.components[edges[e.edge].component].name + "." +
                              edges[e.edge].name);
    }
    OutputFiles files;  // the overlay and the edges both, or neither
    if (!options.overlay.empty()) {
      const cv::Mat image = ReadGrayImage(options.image);
      if (image.cols != camera.width || image.rows != camera.height) {
        throw InputError(SourceLocation(options.image),
                         fmt::format("the image is {} x {}, the camera's {} x {}", image.cols,
                                     image.rows, camera.width, camera.height));
      }
      cv::Mat picture;
      cv::cvtColor(image, picture, cv::COLOR_GRAY2BGR);
      for (const ProjectedEdge& e : visible) {
        cv::line(picture, cv::Point2d(e.a.x(), e.a.y()), cv::Point2d(e.b.x(), e.b.y()),
                 cv::Scalar(0, 220, 255), 1, cv::LINE_AA);
      }
      files.Stage(options.overlay, PngBytes(picture));
    }
    WriteOrPrint(options.output, json, &files, out);
    return 0;
  });
}

namespace {

// The render command's style, or an InputError naming the styles.
RenderStyle RenderStyleOption(const RenderCommandOptions& options) {
  const std::optional<RenderStyle> style = ParseRenderStyle(options.style);
  if (!style) {
    throw InputError(
        SourceLocation(options.model),
        fmt::format("--style '{}': the styles are plain and realistic", options.style));
  }
  if (*style != RenderStyle::kRealistic && !options.photographs.empty()) {
    throw InputError(SourceLocation(options.photographs.front()),
                     "--photographs is for --style realistic");
  }
  return *style;
}

// The realistic style's photographs: those given, else the visp-images-data package's if it is
// installed; null (procedural cards) when neither.
std::shared_ptr<const std::vector<GrayImage>> RenderPhotographs(
    const RenderCommandOptions& options, RenderStyle style) {
  if (style != RenderStyle::kRealistic) return nullptr;
  const std::vector<std::string> paths =
      options.photographs.empty() ? VispPhotographPaths() : options.photographs;
  if (paths.empty()) return nullptr;
  return std::make_shared<const std::vector<GrayImage>>(LoadPhotographs(paths));
}

std::string StyleNote(RenderStyle style) {
  return style == RenderStyle::kPlain
             ? ""
             : fmt::format(" ({})", RenderStyleName(style));
}

// `cfuse render --sequence`: the frames, the true track and the first frame's poses, written
// into a sibling directory first and renamed into place at the end.
int RenderSequenceCommand(const RenderCommandOptions& options, const ConstraintGraph& graph,
                          const Camera& camera, RenderStyle style,
                          std::shared_ptr<const std::vector<GrayImage>> photographs,
                          std::ostream& out) {
  const SourceLocation where(options.output);
  std::error_code ec;
  // Like every other output, a new directory in an existing one (not its parents created).
  const fs::path parent = fs::path(options.output).has_parent_path()
                              ? fs::path(options.output).parent_path()
                              : fs::path(".");
  if (!fs::is_directory(parent, ec)) {
    throw InputError(
        where, fs::exists(parent, ec)
                   ? fmt::format("cannot write: '{}' is not a directory", parent.string())
                   : fmt::format("cannot write: directory '{}' does not exist", parent.string()));
  }
  if (fs::exists(options.output, ec) &&
      !(fs::is_directory(options.output, ec) && fs::is_empty(options.output, ec))) {
    throw InputError(where, "exists and is not an empty directory: give a new one");
  }
  const SequenceSpec spec = AtFile(options.model, [&] {
    return StandardSequence(graph, options.sequence, options.frames, options.seed, style,
                                    std::move(photographs));
  });
  const std::vector<SequenceFrame> frames =
      AtFile(options.camera, [&] { return RenderSequence(graph, camera, spec); });
  const fs::path target = fs::absolute(options.output).lexically_normal();
  const fs::path partial = target.string() + ".partial";
  fs::remove_all(partial, ec);
  if (!fs::create_directories(partial, ec)) {
    throw InputError(where, "cannot create the directory: " + ec.message());
  }
  try {
    std::string truth = TrackCsvHeader(graph);
    for (size_t i = 0; i < frames.size(); ++i) {
      const Rendering& r = frames[i].rendering;
      const std::vector<std::uint8_t> png = EncodePng(r.pixels, r.width, r.height);
      WriteFileAtomically((partial / fmt::format("frame_{:05d}.png", i)).string(),
                          std::string(png.begin(), png.end()));
      truth += TrackCsvRow(graph, static_cast<int>(i), 0, true, frames[i].truth);
    }
    WriteFileAtomically((partial / "truth.csv").string(), truth);
    WriteFileAtomically((partial / "init.json").string(),
                        JsonText(PosesJson(graph, frames.front().truth), 1) + "\n");
    fs::remove(target, ec);  // an empty directory, or nothing
    // With an error code: a failed rename is an InputError at the output, not an internal one.
    fs::rename(partial, target, ec);
    if (ec) throw InputError(where, "cannot write the directory: " + ec.message());
  } catch (...) {
    fs::remove_all(partial, ec);
    throw;
  }
  out << fmt::format(
      "rendered '{}', sequence '{}'{}: {} frames of {} x {} -> {}/ (frame_NNNNN.png, truth.csv, "
      "init.json)\n",
      graph.name, options.sequence, StyleNote(style), frames.size(), camera.width, camera.height,
      options.output);
  return 0;
}

}  // namespace

int RunRender(const RenderCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    if (options.sequence.empty()) {
      RequireWritable(options.output);
      if (!options.truth.empty()) RequireWritable(options.truth);
    }
    const RenderStyle style = RenderStyleOption(options);
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const Camera camera = LoadAnyCamera(options.camera);
    if (camera.width <= 0 || camera.height <= 0) {
      // ViSP's tracker settings give no size, and there is no image to take one from.
      throw InputError(SourceLocation(options.camera),
                       "the camera gives no image size (width and height), and render draws "
                       "images of the camera's size: give a camera file with one");
    }
    std::shared_ptr<const std::vector<GrayImage>> photographs =
        RenderPhotographs(options, style);
    if (!options.sequence.empty()) {
      if (!options.pose.empty()) {
        throw InputError(SourceLocation(options.pose),
                         "--pose and --sequence exclude each other: a sequence has its own poses");
      }
      return RenderSequenceCommand(options, graph, camera, style, std::move(photographs), out);
    }
    if (options.pose.empty()) {
      throw InputError(SourceLocation(options.model), "give --pose (or --sequence NAME)");
    }
    const Values values = PosedModel(graph, options.pose);
    RenderOptions ro;
    ro.seed = options.seed;
    ro.noise = options.noise;
    ro.blur = options.blur;
    ro.clutter_lines = options.clutter_lines;
    ro.clutter_blobs = options.clutter_blobs;
    ro.style = style;
    ro.realistic.photographs = std::move(photographs);
    ro.realistic.look_seed = options.seed;
    const Rendering r =
        AtFile(options.camera, [&] { return Render(graph, values, camera, ro); });
    const std::vector<ModelEdge> edges = ModelEdges(graph);
    nlohmann::json truth = {{"width", r.width},
                            {"height", r.height},
                            {"edges", nlohmann::json::array()},
                            {"names", nlohmann::json::array()}};
    for (const TruthSegment& s : r.truth) {
      truth["edges"].push_back(SegmentJson(s.a.x(), s.a.y(), s.b.x(), s.b.y()));
      truth["names"].push_back(graph.components[edges[s.edge].component].name + "." +
                               edges[s.edge].name);
    }
    const std::vector<std::uint8_t> png = EncodePng(r.pixels, r.width, r.height);
    OutputFiles files;  // the image and its edges both, or neither
    files.Stage(options.output, std::string(png.begin(), png.end()));
    if (!options.truth.empty()) files.Stage(options.truth, Dump(truth));
    files.Commit();
    out << fmt::format("rendered '{}'{} at {} x {} -> {}{}\n", graph.name, StyleNote(style),
                       r.width, r.height, options.output,
                       options.truth.empty() ? "" : ", its visible edges -> " + options.truth);
    return 0;
  });
}

}  // namespace cfuse::cli
