#include "cfuse/dsl/measurement_reader.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <vector>

#include "cfuse/kernel/measurements/camera_checks.h"
#include "measurement_json.h"
#include "yaml_document.h"
#include "yaml_numbers.h"

namespace cfuse {
namespace {

const FileKind kMeasurementFile{"measurement", "a measurement file needs 'points'",
                                kMaxMeasurementFileBytes};
const FileKind kCameraFile{"camera", "a camera file needs fx, fy, cx, cy, width and height",
                           1u << 20};

Eigen::MatrixXd Covariance(const Document& doc, const YAML::Node& entry, int n,
                           const std::string& what) {
  const YAML::Node sigma = entry["sigma"], cov = entry["cov"];
  if (Present(sigma) == Present(cov)) {
    doc.Fail(entry, fmt::format("{} needs either 'sigma' or 'cov'{}", what,
                                Present(sigma) ? ", not both" : ""));
  }
  if (Present(sigma)) {
    const double s = Number(doc, sigma, what + " sigma");
    if (const auto problem = SigmaProblem(s))
      doc.Fail(sigma, fmt::format("{} sigma {}", what, *problem));
    return s * s * Eigen::MatrixXd::Identity(n, n);
  }
  if (!cov.IsSequence() || static_cast<int>(cov.size()) != n) {
    doc.Fail(cov, fmt::format("{} cov must be a {}x{} matrix (a list of {} rows)", what, n, n, n));
  }
  Eigen::MatrixXd C(n, n);
  for (int i = 0; i < n; ++i)
    C.row(i) = Numbers(doc, cov[i], n, fmt::format("{} cov row {}", what, i + 1));
  if (const auto problem = CovarianceProblem(C))
    doc.Fail(cov, fmt::format("{} cov {}", what, *problem));
  return 0.5 * (C + C.transpose());
}

Camera ReadCamera(const Document& doc, const YAML::Node& node) {
  const auto entries = doc.Entries(
      node, "camera", {"model", "fx", "fy", "cx", "cy", "scale", "width", "height", "dist"});
  Camera camera;
  std::string model = "pinhole";
  if (YAML::Node m = Document::Find(entries, "model"); Present(m))
    model = doc.Scalar(m, "camera model");
  if (model != "pinhole" && model != "orthographic") {
    doc.Fail(node["model"],
             fmt::format("unknown camera model '{}': pinhole or orthographic", model));
  }
  camera.model = model == "pinhole" ? Camera::Model::kPinhole : Camera::Model::kOrthographic;
  auto get = [&](const char* key, bool required) -> std::optional<double> {
    const YAML::Node n = Document::Find(entries, key);
    if (!Present(n)) {
      if (required) doc.Fail(node, fmt::format("the {} camera needs '{}'", model, key));
      return std::nullopt;
    }
    return Number(doc, n, fmt::format("camera {}", key));
  };
  const bool pinhole = camera.model == Camera::Model::kPinhole;
  for (const char* key : {"fx", "fy", "dist"}) {
    if (!pinhole && Present(Document::Find(entries, key))) {
      doc.Fail(Document::Find(entries, key),
               fmt::format("an orthographic camera has no '{}'", key));
    }
  }
  if (pinhole && Present(Document::Find(entries, "scale"))) {
    doc.Fail(Document::Find(entries, "scale"), "a pinhole camera has no 'scale' (use fx and fy)");
  }
  if (pinhole) {
    camera.fx = *get("fx", true);
    camera.fy = *get("fy", true);
    for (const char* key : {"fx", "fy"}) {
      if (!(*(key[1] == 'x' ? &camera.fx : &camera.fy) > 0)) {
        doc.Fail(Document::Find(entries, key), "camera fx and fy must be positive");
      }
    }
  } else {
    camera.scale = *get("scale", true);
    if (!(camera.scale > 0)) doc.Fail(node["scale"], "camera scale must be positive");
  }
  camera.cx = *get("cx", true);
  camera.cy = *get("cy", true);
  for (const char* key : {"width", "height"}) {
    const double v = *get(key, true);
    if (!IsImageSide(v)) {
      doc.Fail(Document::Find(entries, key),
               fmt::format("camera {} must be a positive whole number of pixels", key));
    }
    (std::string(key) == "width" ? camera.width : camera.height) = static_cast<int>(v);
  }
  if (YAML::Node d = Document::Find(entries, "dist"); Present(d)) {
    if (!d.IsSequence()) doc.Fail(d, "camera dist must be a list of distortion coefficients");
    std::vector<double> coefficients(d.size());
    for (size_t i = 0; i < d.size() && i < 14; ++i)
      coefficients[i] = Number(doc, d[i], "camera dist");
    if (const auto problem = DistortionProblem(coefficients)) {
      doc.Fail(problem->index < 0 ? d : d[problem->index], "camera dist " + problem->message);
    }
    std::copy_n(coefficients.begin(), std::min<size_t>(coefficients.size(), 12),
                camera.distortion.begin());
  }
  if (const auto problem = PrincipalPointProblem(camera.cx, camera.cy, camera.width, camera.height))
    doc.Fail(Document::Find(entries, problem->index == 0 ? "cx" : "cy"), problem->message);
  return camera;
}

// ROS camera_info files (camera_calibration_parsers' YAML, written by camera_calibration and
// camera_info_manager): the size, K and the distortion are read; R and P are checked for shape
// only, since cfuse measures raw (distorted) pixels and P describes the rectified image.
const std::vector<std::string> kRosCameraInfoKeys = {
    "image_width",          "image_height",     "camera_name",
    "camera_matrix",        "distortion_model", "distortion_coefficients",
    "rectification_matrix", "projection_matrix"};

struct RosMatrix {
  int rows = 0, cols = 0;
  std::vector<double> values;  // row-major
  YAML::Node data;
};

// {rows: R, cols: C, data: [R*C numbers]}.
RosMatrix ReadRosMatrix(const Document& doc, const YAML::Node& node, const std::string& name) {
  if (node.Tag().find("opencv-matrix") != std::string::npos ||
      (node.IsMap() && Present(node["dt"]))) {
    doc.Fail(node, fmt::format("{} is an OpenCV matrix (!!opencv-matrix), but the file does not "
                               "start with OpenCV's '%YAML:1.0': add that first line to read it as "
                               "an OpenCV calibration file",
                               name));
  }
  const auto entries = doc.Entries(node, name, {"rows", "cols", "data"});
  RosMatrix m;
  for (const char* key : {"rows", "cols", "data"}) {
    if (!Present(Document::Find(entries, key)))
      doc.Fail(node, fmt::format("{} needs '{}' (a matrix is rows, cols and data)", name, key));
  }
  for (const char* key : {"rows", "cols"}) {
    const YAML::Node n = Document::Find(entries, key);
    const double v = Number(doc, n, fmt::format("{} {}", name, key));
    if (!(v >= 0) || v != std::floor(v) || v > 1000)
      doc.Fail(n, fmt::format("{} {} must be a whole number, got {}", name, key, v));
    (std::string(key) == "rows" ? m.rows : m.cols) = static_cast<int>(v);
  }
  m.data = Document::Find(entries, "data");
  doc.RequireSequence(m.data, name + " data");
  if (m.data.size() != static_cast<size_t>(m.rows * m.cols)) {
    doc.Fail(m.data, fmt::format("{} has rows: {}, cols: {} but {} values in data", name, m.rows,
                                 m.cols, m.data.size()));
  }
  for (const YAML::Node& v : m.data) m.values.push_back(Number(doc, v, name + " data"));
  return m;
}

RosMatrix ReadRosMatrix(const Document& doc, const YAML::Node& node, const std::string& name,
                        int rows, int cols) {
  RosMatrix m = ReadRosMatrix(doc, node, name);
  if (m.rows != rows || m.cols != cols) {
    doc.Fail(node, fmt::format("{} must be {}x{}, got rows: {}, cols: {}", name, rows, cols, m.rows,
                               m.cols));
  }
  return m;
}

Camera ReadRosCameraInfo(const Document& doc, const YAML::Node& root) {
  const auto entries = doc.Entries(root, "the camera_info", kRosCameraInfoKeys);
  auto require = [&](const char* key) {
    const YAML::Node n = Document::Find(entries, key);
    if (!Present(n)) doc.Fail(root, fmt::format("a ROS camera_info file needs '{}'", key));
    return n;
  };
  int size[2];
  for (int i = 0; i < 2; ++i) {
    const char* key = i == 0 ? "image_width" : "image_height";
    const YAML::Node n = require(key);
    const double v = Number(doc, n, key);
    if (!IsImageSide(v))
      doc.Fail(n, fmt::format("{} must be a positive whole number of pixels", key));
    size[i] = static_cast<int>(v);
  }
  if (YAML::Node n = Document::Find(entries, "camera_name"); Present(n))
    doc.Scalar(n, "camera_name");

  const RosMatrix K = ReadRosMatrix(doc, require("camera_matrix"), "camera_matrix", 3, 3);
  if (const auto problem = CameraMatrixProblem(K.values))
    doc.Fail(K.data[problem->index], "camera_matrix: " + problem->message);
  if (const auto problem = PrincipalPointProblem(K.values[2], K.values[5], size[0], size[1]))
    doc.Fail(K.data[problem->index == 0 ? 2 : 5], "camera_matrix: " + problem->message);

  std::string model = "plumb_bob";  // camera_calibration_parsers' default for older files
  const YAML::Node model_node = Document::Find(entries, "distortion_model");
  if (Present(model_node)) model = doc.Scalar(model_node, "distortion_model");
  if (model == "equidistant" || model == "fisheye") {
    doc.Fail(model_node, fmt::format("distortion_model '{}' is the fisheye (Kannala-Brandt) model; "
                                     "cfuse's camera has OpenCV's pinhole distortion only "
                                     "(plumb_bob or rational_polynomial)",
                                     model));
  }
  if (model != "plumb_bob" && model != "rational_polynomial") {
    doc.Fail(model_node, fmt::format("unknown distortion_model '{}': cfuse reads plumb_bob and "
                                     "rational_polynomial",
                                     model));
  }
  const YAML::Node d_node = require("distortion_coefficients");
  const RosMatrix D = ReadRosMatrix(doc, d_node, "distortion_coefficients");
  if (D.rows != 1 && D.cols != 1) {
    doc.Fail(d_node, fmt::format("distortion_coefficients must be 1xN, got rows: {}, cols: {}",
                                 D.rows, D.cols));
  }
  const size_t n = D.values.size();
  // rational_polynomial is 8 in ROS; drivers publishing OpenCV's full vector use the same name
  // for 12 or 14, which image_geometry hands to OpenCV as they are.
  const bool count_ok = model == "plumb_bob" ? n == 5 : (n == 8 || n == 12 || n == 14);
  if (!count_ok) {
    doc.Fail(D.data, fmt::format("distortion_coefficients has {} coefficients but distortion_model "
                                 "{} takes {}",
                                 n, model,
                                 model == "plumb_bob" ? "5 (k1 k2 p1 p2 k3)"
                                                      : "8 (k1 k2 p1 p2 k3 k4 k5 k6), or "
                                                        "OpenCV's 12 or 14"));
  }
  if (const auto problem = DistortionProblem(D.values)) {
    doc.Fail(problem->index < 0 ? D.data : D.data[problem->index],
             "distortion_coefficients " + problem->message);
  }
  if (YAML::Node n = Document::Find(entries, "rectification_matrix"); Present(n))
    ReadRosMatrix(doc, n, "rectification_matrix", 3, 3);
  if (YAML::Node n = Document::Find(entries, "projection_matrix"); Present(n))
    ReadRosMatrix(doc, n, "projection_matrix", 3, 4);
  return PinholeCamera(K.values, D.values, size[0], size[1]);
}

// cfuse's camera object (at the top or under `camera`) or a ROS camera_info, told apart by their
// keys, which no two of them share.
Camera ReadCameraText(const std::string& display, const std::string& text) {
  CheckText(display, text, kCameraFile);
  const Document doc(display, text, kCameraFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap()) {
    doc.Fail(root,
             "a camera file is a mapping with fx, fy, cx, cy, width, height (or a ROS "
             "camera_info)");
  }
  for (const std::string& key : kRosCameraInfoKeys) {
    if (Present(root[key])) return ReadRosCameraInfo(doc, root);
  }
  if (Present(root["camera"])) return ReadCamera(doc, root["camera"]);
  return ReadCamera(doc, root);
}

MeasurementSet Read(const std::string& display, const std::string& text) {
  CheckText(display, text, kMeasurementFile);
  const auto read_camera = [&](std::string_view camera_json) {
    const Document doc(display, std::string(camera_json), kMeasurementFile);
    return ReadCamera(doc, doc.Parse());
  };
  if (auto set = ReadPlainJsonMeasurements(text, display, read_camera)) return std::move(*set);
  const Document doc(display, text, kMeasurementFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap()) doc.Fail(root, "a measurement file is a mapping with 'points' (and 'camera')");
  const auto entries = doc.Entries(root, "the measurements", {"camera", "points"});
  MeasurementSet set;
  set.source = display;
  if (YAML::Node c = Document::Find(entries, "camera"); Present(c)) set.camera = ReadCamera(doc, c);
  const YAML::Node points = Document::Find(entries, "points");
  if (!Present(points)) doc.Fail(root, "the measurements need 'points'");
  doc.RequireSequence(points, "points");
  if (points.size() > static_cast<size_t>(kMaxMeasuredPoints)) {
    doc.Fail(points, fmt::format("more than {} points", kMaxMeasuredPoints));
  }
  int index = 0;
  for (const YAML::Node& entry : points) {
    const std::string what = fmt::format("points[{}]", index++);
    doc.Entries(entry, what, {"xyz", "uv", "sigma", "cov", "label"});
    MeasuredPoint p;
    p.where = doc.Loc(entry);
    p.where.element = what;
    const YAML::Node xyz = entry["xyz"], uv = entry["uv"];
    if (Present(xyz) == Present(uv)) {
      doc.Fail(entry, fmt::format("{} needs either 'xyz' (a 3D point) or 'uv' (an image point){}",
                                  what, Present(xyz) ? ", not both" : ""));
    }
    p.is_3d = Present(xyz);
    if (p.is_3d) {
      p.xyz = Numbers(doc, xyz, 3, what + " xyz");
      p.cov3 = Covariance(doc, entry, 3, what);
    } else {
      if (!set.camera)
        doc.Fail(entry, fmt::format("{} is an image point but the file has no 'camera'", what));
      p.uv = Numbers(doc, uv, 2, what + " uv");
      p.cov2 = Covariance(doc, entry, 2, what);
    }
    if (YAML::Node label = entry["label"]; Present(label) && !label.IsNull()) {
      p.label = doc.Scalar(label, what + " label");
      if (p.label.empty()) doc.Fail(label, fmt::format("{} label is empty", what));
    }
    set.points.push_back(std::move(p));
  }
  return set;
}

}  // namespace

MeasurementSet ReadMeasurements(const std::string& path) {
  return Read(path, ReadTextFile(path, SourceLocation(), kMeasurementFile));
}

MeasurementSet ReadMeasurementsFromString(std::string_view text, const std::string& display_name) {
  return Read(display_name, std::string(text));
}

Camera ReadCameraFile(const std::string& path) {
  return ReadCameraText(path, ReadTextFile(path, SourceLocation(), kCameraFile));
}

Camera ReadCameraFromString(std::string_view text, const std::string& display_name) {
  return ReadCameraText(display_name, std::string(text));
}

}  // namespace cfuse
