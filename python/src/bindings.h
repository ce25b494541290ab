// What the module's binding units share: the model handle, JSON results as Python objects,
// images from numpy arrays, and Python's arguments checked as a file's entries are.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <memory>
#include <optional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/vision/segments.h"

namespace cfuse::python {

namespace py = pybind11;

// A loaded model; shared by the results, trackers and measurements made with it, so that it
// outlives them whatever Python frees first.
struct Model {
  std::shared_ptr<const ConstraintGraph> graph;
  std::string path;
  mutable std::optional<int> dof;  // from the rank analysis, made when first asked for
};

// nlohmann::json as Python's dict, list, str, float, int, bool and None.
py::object ToPython(const nlohmann::json& json);
// And back: what a user passes where a results file is read (a guess, an initial pose).
nlohmann::json FromPython(const py::handle& object, const std::string& what);

// A numpy uint8 image, (H, W) grey or (H, W, 3) colour (channels in `order`, "bgr" or "rgb"),
// as 8-bit grey: grey rows are read in place where their layout allows (the array is held by the
// caller for the call), colour is converted. InputError at `what` for any other array.
struct GrayImage {
  cv::Mat converted;  // empty when `view` reads the array itself
  GrayView view;
};
GrayImage ToGray(const py::array& image, const std::string& order, const std::string& what);

// The camera checked against an image: a camera without a size takes the image's; one of
// another size is an InputError.
Camera CameraForImage(const Camera& camera, const GrayView& image);

void BindModels(py::module_& m);
void BindMeasurements(py::module_& m);
void BindEstimates(py::module_& m);
void BindTracking(py::module_& m);

}  // namespace cfuse::python
