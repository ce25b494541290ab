// Images from numpy, the tracker fed frame by frame, and detection in one image.
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <chrono>

#include <opencv2/imgproc.hpp>
#include <optional>

#include "bindings.h"
#include "cfuse/dsl/pose_reader.h"
#include "cfuse/kernel/error.h"
#include "cfuse/track/auto_tracker.h"
#include "cfuse/track/detector.h"
#include "cli/command_support.h"
#include "cli/frame_results.h"
#include "cli/image_support.h"

namespace cfuse::python {

GrayImage ToGray(const py::array& image, const std::string& order, const std::string& what) {
  if (!py::isinstance<py::array_t<std::uint8_t>>(image) ||
      !image.dtype().is(py::dtype::of<std::uint8_t>())) {
    throw InputError(SourceLocation(what),
                     fmt::format("an image must be a numpy uint8 array, not of dtype {}",
                                 py::str(image.dtype()).cast<std::string>()));
  }
  if (order != "bgr" && order != "rgb") {
    throw InputError(SourceLocation("order"), "must be 'bgr' or 'rgb', not '" + order + "'");
  }
  const bool grey = image.ndim() == 2;
  const bool colour = image.ndim() == 3 && image.shape(2) == 3;
  if (!grey && !colour) {
    throw InputError(SourceLocation(what), "an image must be of shape (H, W) or (H, W, 3)");
  }
  const int height = static_cast<int>(image.shape(0)), width = static_cast<int>(image.shape(1));
  if (width < 1 || height < 1) throw InputError(SourceLocation(what), "the image is empty");
  GrayImage out;
  if (grey && image.strides(1) == 1 && image.strides(0) >= width) {
    // Read in place: rows of contiguous bytes.
    out.view = GrayView{static_cast<const std::uint8_t*>(image.data()), width, height,
                        static_cast<int>(image.strides(0))};
    return out;
  }
  // Any other layout: the array's own strides, copied into grey.
  const py::ssize_t sy = image.strides(0), sx = image.strides(1);
  const py::ssize_t sc = colour ? image.strides(2) : 0;
  const auto* base = static_cast<const std::uint8_t*>(image.data());
  out.converted.create(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y) {
    std::uint8_t* row = out.converted.ptr<std::uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      const std::uint8_t* p = base + y * sy + x * sx;
      if (!colour) {
        row[x] = *p;
        continue;
      }
      const double first = p[0], second = p[sc], third = p[2 * sc];
      const double b = order == "bgr" ? first : third, r = order == "bgr" ? third : first;
      // ITU-R BT.601 luma, as OpenCV's cvtColor to grey.
      row[x] = cv::saturate_cast<std::uint8_t>(0.114 * b + 0.587 * second + 0.299 * r);
    }
  }
  out.view = GrayView{out.converted.data, width, height, static_cast<int>(out.converted.step)};
  return out;
}

Camera CameraForImage(const Camera& camera, const GrayView& image) {
  Camera out = camera;
  if (out.width <= 0 || out.height <= 0) {
    out.width = image.width;
    out.height = image.height;
  } else if (out.width != image.width || out.height != image.height) {
    throw InputError(SourceLocation("image"),
                     fmt::format("the image is {} x {}, the camera's {} x {}", image.width,
                                 image.height, out.width, out.height));
  }
  return out;
}

namespace {

// The model at a starting pose: a path to a results file or a ViSP .pos file, or a dict in the
// results format.
std::optional<Values> Initial(const Model& model, const py::object& init) {
  if (init.is_none()) return std::nullopt;
  if (py::isinstance<py::str>(init) || py::hasattr(init, "__fspath__")) {
    return cli::PosedModel(*model.graph, py::str(init).cast<std::string>());
  }
  return cli::PosedModel(*model.graph, ReadPosesFromString(FromPython(init, "init").dump(), "init"),
                         "init");
}

// A range sensor's points from numpy: (H, W, 3) floats, metres in the camera's frame; a point
// without depth has z <= 0 or NaN. None: no depth.
std::optional<DepthFrame> ToDepth(const py::object& depth) {
  if (depth.is_none()) return std::nullopt;
  if (!py::isinstance<py::array>(depth)) {
    throw InputError(SourceLocation("depth"), "must be a numpy array of shape (H, W, 3), or None");
  }
  const py::array array = depth.cast<py::array>();
  if (array.dtype().kind() != 'f') {
    throw InputError(SourceLocation("depth"),
                     fmt::format("must hold floats (metres), not dtype {}",
                                 py::str(array.dtype()).cast<std::string>()));
  }
  if (array.ndim() != 3 || array.shape(2) != 3 || array.shape(0) < 1 || array.shape(1) < 1) {
    throw InputError(SourceLocation("depth"), "must be of shape (H, W, 3): a point a pixel");
  }
  const auto points = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(array);
  DepthFrame frame;
  frame.height = static_cast<int>(array.shape(0));
  frame.width = static_cast<int>(array.shape(1));
  frame.points.resize(static_cast<size_t>(frame.width) * frame.height);
  const float* data = points.data();
  for (size_t i = 0; i < frame.points.size(); ++i) {
    frame.points[i] = Eigen::Vector3f(data[3 * i], data[3 * i + 1], data[3 * i + 2]);
  }
  return frame;
}

// A tracker over a sequence of numpy images. The camera's size, when it has none, is the first
// image's.
class PyTracker {
 public:
  PyTracker(Model model, Camera camera, const py::object& init, int max_branches)
      : model_(std::move(model)), camera_(std::move(camera)), initial_(Initial(model_, init)) {
    cli::RequireEdges(*model_.graph, model_.path, "track");
    if (max_branches < 1 || max_branches > 1000) {
      throw InputError(SourceLocation("max_branches"), "must be in [1, 1000]");
    }
    options_.tracker.max_branches = max_branches;
    if (camera_.width > 0 && camera_.height > 0) Start();
  }

  py::dict Track(const py::array& image, const std::string& order, const py::object& depth) {
    const GrayImage gray = ToGray(image, order, "image");
    const std::optional<DepthFrame> points = ToDepth(depth);
    const Camera sized = CameraForImage(camera_, gray.view);
    if (!tracker_) {
      camera_ = sized;
      Start();
    }
    TrackedFrame frame;
    double ms = 0;
    {
      py::gil_scoped_release release;
      const auto start = std::chrono::steady_clock::now();
      frame = points ? tracker_->Track(gray.view, *points) : tracker_->Track(gray.view);
      ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
               .count();
    }
    nlohmann::json json = cli::FrameJson(*model_.graph, frame);
    json["frame"] = frames_++;
    json["detected"] = frame.detected;
    json["reacquired"] = frame.reacquired;
    json["time_ms"] = ms;  // the C++ call's, as the solve's time_ms is
    return ToPython(json);
  }

  void Skip() {
    if (tracker_) tracker_->Skip();
    ++frames_;
  }

 private:
  void Start() { tracker_.emplace(*model_.graph, camera_, initial_, options_); }

  Model model_;  // holds the graph the tracker refers to
  Camera camera_;
  std::optional<Values> initial_;
  AutoTrackerOptions options_;
  std::optional<AutoTracker> tracker_;
  int frames_ = 0;
};

}  // namespace

void BindTracking(py::module_& m) {
  py::class_<PyTracker>(m, "_Tracker", "cfuse.Tracker's work: frames as dicts.")
      .def(py::init<Model, Camera, py::object, int>(), py::arg("model"), py::arg("camera"),
           py::arg("init"), py::arg("max_branches"))
      .def("track", &PyTracker::Track, py::arg("image"), py::arg("order"), py::arg("depth"))
      .def("skip", &PyTracker::Skip);

  m.def(
      "_detect",
      [](const Model& model, const Camera& camera, const py::array& image, int max_results,
         const std::string& order) {
        if (max_results < 1) throw InputError(SourceLocation("max_results"), "must be at least 1");
        cli::RequireEdges(*model.graph, model.path, "find in an image");
        const GrayImage gray = ToGray(image, order, "image");
        const Camera sized = CameraForImage(camera, gray.view);
        DetectorOptions options;
        options.max_results = max_results;
        Detection d;
        {
          py::gil_scoped_release release;
          d = Detect(*model.graph, sized, gray.view, options);
        }
        return ToPython(cli::DetectionJson(*model.graph, d, "<array>"));
      },
      py::arg("model"), py::arg("camera"), py::arg("image"), py::arg("max_results"),
      py::arg("order"), "cfuse.detect's work: the detection's dict.");
}

}  // namespace cfuse::python
