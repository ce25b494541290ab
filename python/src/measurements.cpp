// Measurements from numpy arrays or files, and simulated ones with their truth.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <optional>

#include "bindings.h"
#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/interp/simulate.h"
#include "cfuse/kernel/error.h"
#include "cli/results.h"

namespace cfuse::python {
namespace {

constexpr const char* kWhere = "Measurements(...)";

InputError At(const std::string& element, const std::string& message) {
  return InputError(SourceLocation(kWhere, 0, 0, element), message);
}

// A covariance must be symmetric (to 1e-9 of its size) and positive definite.
template <int N>
void CheckCovariance(const Eigen::Matrix<double, N, N>& cov, const std::string& element) {
  if (!cov.allFinite()) throw At(element, "the covariance must be finite");
  if ((cov - cov.transpose()).cwiseAbs().maxCoeff() > 1e-9 * cov.cwiseAbs().maxCoeff()) {
    throw At(element, "the covariance must be symmetric");
  }
  if (Eigen::LLT<Eigen::Matrix<double, N, N>>(cov).info() != Eigen::Success) {
    throw At(element, "the covariance must be positive definite");
  }
}

// Points (N, D) with a covariance per row from `sigma` (a number or (N,) standard deviations)
// or `cov` (N, D, D), D = 3 (metres) or 2 (pixels).
template <int D>
void Fill(const py::array_t<double, py::array::c_style | py::array::forcecast>& points,
          const py::object& sigma, const py::object& cov, const char* name, MeasurementSet* set) {
  if (points.ndim() != 2 || points.shape(1) != D) {
    throw At(name, fmt::format("must be an array of shape (N, {}), not of {} dimensions{}", D,
                               points.ndim(),
                               points.ndim() == 2 ? fmt::format(" ({} columns)", points.shape(1))
                                                  : ""));
  }
  const Eigen::Index n = points.shape(0);
  if (!sigma.is_none() && !cov.is_none()) {
    throw At("sigma", "give sigma or cov, not both");
  }
  std::vector<Eigen::Matrix<double, D, D>> covariances(n);
  if (!cov.is_none()) {
    const auto c = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(cov);
    if (!c || c.ndim() != 3 || c.shape(0) != n || c.shape(1) != D || c.shape(2) != D) {
      throw At("cov", fmt::format("must be an array of shape ({}, {}, {})", n, D, D));
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      for (int r = 0; r < D; ++r)
        for (int k = 0; k < D; ++k) covariances[i](r, k) = c.at(i, r, k);
      CheckCovariance<D>(covariances[i], fmt::format("cov[{}]", i));
    }
  } else {
    const py::object s = sigma.is_none() ? py::cast(D == 3 ? 0.002 : 1.0) : sigma;
    const auto values = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(s);
    if (!values || !(values.ndim() == 0 || (values.ndim() == 1 && values.shape(0) == n))) {
      throw At("sigma", fmt::format("must be a number or an array of shape ({},)", n));
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      const double v = values.ndim() == 0 ? *values.data() : values.at(i);
      if (!(std::isfinite(v) && v > 0)) {
        throw At(values.ndim() == 0 ? "sigma" : fmt::format("sigma[{}]", i),
                 fmt::format("a standard deviation must be positive and finite, not {}", v));
      }
      covariances[i] = v * v * Eigen::Matrix<double, D, D>::Identity();
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    MeasuredPoint p;
    p.is_3d = D == 3;
    p.where = SourceLocation(kWhere, 0, 0, fmt::format("{}[{}]", name, i));
    for (int k = 0; k < D; ++k) {
      const double v = points.at(i, k);
      if (!std::isfinite(v)) throw At(p.where.element, "coordinates must be finite");
      if constexpr (D == 3) {
        p.xyz[k] = v;
      } else {
        p.uv[k] = v;
      }
    }
    if constexpr (D == 3) {
      p.cov3 = covariances[i];
    } else {
      p.cov2 = covariances[i];
    }
    set->points.push_back(std::move(p));
  }
}

using Labels = std::vector<std::optional<std::string>>;

MeasurementSet MakeMeasurements(const py::object& xyz, const py::object& uv,
                                const py::object& sigma, const py::object& cov,
                                const std::optional<Labels>& labels,
                                const std::optional<Camera>& camera) {
  MeasurementSet set;
  set.source = kWhere;
  if (xyz.is_none() == uv.is_none()) throw At("xyz", "give xyz (N, 3) or uv (N, 2), one of them");
  if (!xyz.is_none()) {
    if (camera) throw At("camera", "a camera is for image points (uv), not for xyz");
    Fill<3>(xyz, sigma, cov, "xyz", &set);
  } else {
    if (!camera) throw At("camera", "image points (uv) need the camera that saw them");
    set.camera = *camera;
    Fill<2>(uv, sigma, cov, "uv", &set);
  }
  if (labels) {
    if (labels->size() != set.points.size()) {
      throw At("labels", fmt::format("{} labels for {} points", labels->size(), set.points.size()));
    }
    for (size_t i = 0; i < labels->size(); ++i) set.points[i].label = (*labels)[i].value_or("");
  }
  return set;
}

Labels LabelsOf(const MeasurementSet& set) {
  Labels out;
  for (const MeasuredPoint& p : set.points) {
    out.push_back(p.label.empty() ? std::nullopt : std::optional<std::string>(p.label));
  }
  return out;
}

// Rows of the points of one kind; NaN in the rows of the other.
template <int D>
Eigen::Matrix<double, Eigen::Dynamic, D> Rows(const MeasurementSet& set) {
  Eigen::Matrix<double, Eigen::Dynamic, D> out(set.points.size(), D);
  for (size_t i = 0; i < set.points.size(); ++i) {
    const MeasuredPoint& p = set.points[i];
    if ((D == 3) == p.is_3d) {
      if constexpr (D == 3) {
        out.row(i) = p.xyz.transpose();
      } else {
        out.row(i) = p.uv.transpose();
      }
    } else {
      out.row(i).setConstant(NAN);
    }
  }
  return out;
}

// (N, D, D), D 3 when every point is 3D, 2 when every point is an image point; else a list.
py::object Covariances(const MeasurementSet& set) {
  const bool all3 = std::all_of(set.points.begin(), set.points.end(),
                                [](const MeasuredPoint& p) { return p.is_3d; });
  const bool all2 = std::none_of(set.points.begin(), set.points.end(),
                                 [](const MeasuredPoint& p) { return p.is_3d; });
  if (all3 || all2) {
    const py::ssize_t n = static_cast<py::ssize_t>(set.points.size()), d = all3 ? 3 : 2;
    py::array_t<double> out({n, d, d});
    auto a = out.mutable_unchecked<3>();
    for (py::ssize_t i = 0; i < n; ++i)
      for (py::ssize_t r = 0; r < d; ++r)
        for (py::ssize_t k = 0; k < d; ++k) {
          a(i, r, k) = all3 ? set.points[i].cov3(r, k) : set.points[i].cov2(r, k);
        }
    return out;
  }
  py::list out;
  for (const MeasuredPoint& p : set.points) {
    out.append(p.is_3d ? py::cast(Eigen::Matrix3d(p.cov3)) : py::cast(Eigen::Matrix2d(p.cov2)));
  }
  return out;
}

}  // namespace

void BindMeasurements(py::module_& m) {
  py::class_<MeasurementSet>(m, "Measurements",
                             "Measured points: 3D (metres, camera frame) or image points "
                             "(pixels), each with a covariance and an optional label.")
      .def(py::init(&MakeMeasurements), py::kw_only(), py::arg("xyz") = py::none(),
           py::arg("uv") = py::none(), py::arg("sigma") = py::none(),
           py::arg("cov") = py::none(), py::arg("labels") = py::none(),
           py::arg("camera") = py::none(),
           "xyz (N, 3) in metres, or uv (N, 2) in pixels with the camera that saw them; sigma "
           "(a number or (N,): 2 mm or 1 px when neither is given) or cov (N, 3, 3) or (N, 2, "
           "2); labels: the model point each measures ('component.point'), None if unknown.")
      .def_static(
          "load", [](const std::filesystem::path& path) { return ReadMeasurements(path); },
          py::arg("path"),
                  "A measurement file (docs/formats.md).")
      .def("__len__", [](const MeasurementSet& s) { return s.points.size(); })
      .def_property_readonly("xyz", &Rows<3>, "(N, 3) metres; NaN rows for image points.")
      .def_property_readonly("uv", &Rows<2>, "(N, 2) pixels; NaN rows for 3D points.")
      .def_property_readonly("cov", &Covariances,
                             "(N, 3, 3) or (N, 2, 2); a list when the kinds are mixed.")
      .def_property_readonly("labels", &LabelsOf)
      .def_property_readonly("camera", [](const MeasurementSet& s) { return s.camera; })
      .def("to_dict", [](const MeasurementSet& s) { return ToPython(cli::MeasurementsJson(s)); },
           "The measurement file's content (docs/formats.md), as a dict.")
      .def("__repr__", [](const MeasurementSet& s) {
        return fmt::format("<cfuse.Measurements {} points from '{}'>", s.points.size(), s.source);
      });

  m.def(
      "_simulate",
      [](const Model& model, unsigned seed, double noise, double pixel_noise, double clutter,
         double occlusion, bool labels, bool sample_joints, const std::optional<Camera>& camera) {
        // The ranges `cfuse simulate` accepts.
        const auto require = [](bool ok, const char* name, const char* range, double value) {
          if (!ok) {
            throw InputError(SourceLocation(name), fmt::format("must be {}, not {}", range, value));
          }
        };
        require(std::isfinite(noise) && noise > 0, "noise", "positive (metres)", noise);
        require(std::isfinite(pixel_noise) && pixel_noise > 0, "pixel_noise", "positive (pixels)",
                pixel_noise);
        require(clutter >= 0 && clutter <= 100, "clutter", "in [0, 100]", clutter);
        require(occlusion >= 0 && occlusion <= 1, "occlusion", "in [0, 1]", occlusion);
        SimulateOptions options;
        options.seed = seed;
        options.noise = noise;
        options.pixel_noise = pixel_noise;
        options.clutter = clutter;
        options.occlusion = occlusion;
        options.labels = labels;
        options.sample_joints = sample_joints;
        options.camera = camera;
        if (camera && (camera->width <= 0 || camera->height <= 0)) {
          throw InputError(SourceLocation("camera"),
                           "the camera gives no image size, and simulate places the model and "
                           "the clutter inside the image");
        }
        Simulation sim;
        {
          py::gil_scoped_release release;
          sim = Simulate(*model.graph, options);
        }
        return py::make_tuple(sim.measurements,
                              ToPython(cli::TruthJson(*model.graph, sim.truth, sim.matches)));
      },
      py::arg("model"), py::arg("seed"), py::arg("noise"), py::arg("pixel_noise"),
      py::arg("clutter"), py::arg("occlusion"), py::arg("labels"), py::arg("sample_joints"),
      py::arg("camera"), "cfuse.simulate's work: (measurements, the truth's dict).");
}

}  // namespace cfuse::python
