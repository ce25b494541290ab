// Models and cameras: load_model (YAML, URDF, CAO), Model's names and check(), fk, Camera.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <fmt/format.h>

#include <cmath>

#include "bindings.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera_checks.h"
#include "cli/answers.h"
#include "cli/command_support.h"
#include "cli/summary.h"

namespace cfuse::python {
namespace {

std::vector<std::string> ComponentNames(const Model& model) {
  std::vector<std::string> out;
  for (const Component& c : model.graph->components) {
    if (c.rigid) out.push_back(c.name);
  }
  return out;
}

std::vector<std::string> JointNames(const Model& model) {
  std::vector<std::string> out;
  for (const Joint& j : model.graph->joints) {
    if (HasJointVariable(j.type)) out.push_back(j.name);
  }
  return out;
}

// The labels a measurement may carry: "component.point", or a single point's name.
std::vector<std::string> PointNames(const Model& model) {
  std::vector<std::string> out;
  for (const Component& c : model.graph->components) {
    if (!c.rigid) {
      out.push_back(c.name);
      continue;
    }
    for (const FeaturePoint& p : c.points) out.push_back(c.name + "." + p.name);
  }
  return out;
}

Camera MakeCamera(double fx, double fy, double cx, double cy, int width, int height,
                  const std::vector<double>& dist) {
  const std::string where = "Camera(...)";
  const std::array<double, 9> K = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  if (const auto problem = CameraMatrixProblem(K)) {
    throw InputError(SourceLocation(where), problem->message);
  }
  const std::vector<double> coefficients = dist.empty() ? std::vector<double>(5, 0.0) : dist;
  if (const auto problem = DistortionProblem(coefficients)) {
    throw InputError(SourceLocation(where, 0, 0, "dist"), "dist " + problem->message);
  }
  for (const auto& [side, name] : {std::pair{width, "width"}, std::pair{height, "height"}}) {
    if (!IsImageSide(side)) {
      throw InputError(SourceLocation(where, 0, 0, name),
                       fmt::format("{} must be a whole number of pixels in [1, 10^6], not {}",
                                   name, side));
    }
  }
  if (const auto problem = PrincipalPointProblem(cx, cy, width, height)) {
    throw InputError(SourceLocation(where, 0, 0, problem->index == 0 ? "cx" : "cy"),
                     problem->message);
  }
  return PinholeCamera(K, coefficients, width, height);
}

}  // namespace

void BindModels(py::module_& m) {
  py::class_<Model>(m, "Model", "A model: rigid components, single points, joints, constraints.")
      .def_property_readonly(
          "name", [](const Model& x) { return x.graph->name; }, "The model's `name:`.")
      .def_property_readonly(
          "path", [](const Model& x) { return x.path; }, "The file it was loaded from.")
      .def_property_readonly(
          "dof",
          [](const Model& x) {
            if (!x.dof) x.dof = cli::Summarize(*x.graph).dof.dof;
            return *x.dof;
          },
          "The degrees of freedom the constraints leave (rank of their Jacobian).")
      .def_property_readonly("components", &ComponentNames, "The rigid components' names.")
      .def_property_readonly("joints", &JointNames, "The joints with a variable, by name.")
      .def_property_readonly("points", &PointNames,
                             "The labels a measurement may carry: 'component.point' or a single "
                             "point's name.")
      .def(
          "check",
          [](const Model& x) {
            return ToPython(cli::SummaryJson(*x.graph, cli::Summarize(*x.graph)));
          },
          "What `cfuse check --json` says of the model, as a dict.")
      .def("__repr__", [](const Model& x) {
        return fmt::format("<cfuse.Model '{}' from '{}'>", x.graph->name, x.path);
      });

  m.def(
      "load_model",
      [](const std::filesystem::path& file) {
        const std::string path = file.string();
        return Model{std::make_shared<const ConstraintGraph>(cli::LoadAnyModel(path)), path, {}};
      },
      py::arg("path"), py::call_guard<py::gil_scoped_release>(),
      "A model from a YAML model file, a URDF or a ViSP CAO file.");

  m.def(
      "_fk",
      [](const Model& model, const py::dict& joints) {
        std::vector<JointValue> given;
        for (const auto& [key, value] : joints) {
          const std::string name = py::str(key).cast<std::string>();
          if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value) &&
              !py::hasattr(value, "__float__")) {
            throw InputError(SourceLocation("joints", 0, 0, "'" + name + "'"),
                             "a joint value must be a number (radians or metres)");
          }
          JointValue v;
          v.name = name;
          v.value = value.cast<double>();
          v.where = SourceLocation("joints", 0, 0, "'" + name + "'");
          given.push_back(v);
        }
        cli::FkAnswer answer;
        {
          py::gil_scoped_release release;
          answer = cli::ForwardKinematicsAndJudge(*model.graph, given);
        }
        return py::make_tuple(ToPython(answer.result), answer.verdict.status,
                              py::cast(answer.verdict.lines));
      },
      py::arg("model"), py::arg("joints"),
      "cfuse.fk's work: (the poses' dict, the exit status, the verdict's lines).");

  py::class_<Camera>(m, "Camera", "A pinhole camera (OpenCV's distortion model).")
      .def(py::init(&MakeCamera), py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"),
           py::arg("width"), py::arg("height"), py::arg("dist") = std::vector<double>{},
           "Focal lengths and principal point in pixels, the image size, and OpenCV's "
           "distortion coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]]).")
      .def_static(
          "load", [](const std::filesystem::path& path) { return cli::LoadAnyCamera(path); },
          py::arg("path"),
                  "A camera from any file `cfuse` reads: cfuse's camera YAML or JSON, ROS "
                  "camera_info, OpenCV calibration YAML or XML, ViSP's XML settings.")
      .def_readonly("fx", &Camera::fx, "Focal length in pixels, x.")
      .def_readonly("fy", &Camera::fy, "Focal length in pixels, y.")
      .def_readonly("cx", &Camera::cx, "Principal point, x (pixels).")
      .def_readonly("cy", &Camera::cy, "Principal point, y (pixels).")
      .def_readonly("width", &Camera::width, "Image width in pixels; 0 when the file gives none.")
      .def_readonly("height", &Camera::height, "Image height in pixels; 0 when none.")
      .def_property_readonly("dist",
                             [](const Camera& c) {
                               return std::vector<double>(c.distortion.begin(),
                                                          c.distortion.end());
                             },
                             "The 12 distortion coefficients k1 k2 p1 p2 k3 k4 k5 k6 s1 s2 s3 "
                             "s4 (zeros where none were given).")
      .def(
          "project",
          [](const Camera& c, const Eigen::Matrix<double, Eigen::Dynamic, 3>& xyz) {
            Eigen::Matrix<double, Eigen::Dynamic, 2> uv(xyz.rows(), 2);
            for (Eigen::Index i = 0; i < xyz.rows(); ++i) {
              uv.row(i) = c.Project<double>(xyz.row(i).transpose()).transpose();
            }
            return uv;
          },
          py::arg("xyz"),
          "Pixels (N, 2) of points (N, 3) in the camera frame (metres); NaN at or behind it.")
      .def("__repr__", [](const Camera& c) {
        return fmt::format("<cfuse.Camera fx={} fy={} cx={} cy={} {}x{}>", c.fx, c.fy, c.cx,
                           c.cy, c.width, c.height);
      });
}

}  // namespace cfuse::python
