#include "dsl/measurement_reader.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "dsl/yaml_document.h"
#include "dsl/yaml_numbers.h"

namespace cfuse::dsl {
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
    if (!(s > 0)) doc.Fail(sigma, fmt::format("{} sigma must be positive, got {}", what, s));
    return s * s * Eigen::MatrixXd::Identity(n, n);
  }
  if (!cov.IsSequence() || static_cast<int>(cov.size()) != n) {
    doc.Fail(cov, fmt::format("{} cov must be a {}x{} matrix (a list of {} rows)", what, n, n, n));
  }
  Eigen::MatrixXd C(n, n);
  for (int i = 0; i < n; ++i)
    C.row(i) = Numbers(doc, cov[i], n, fmt::format("{} cov row {}", what, i + 1));
  if ((C - C.transpose()).cwiseAbs().maxCoeff() > 1e-9 * C.cwiseAbs().maxCoeff()) {
    doc.Fail(cov, fmt::format("{} cov is not symmetric", what));
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (C + C.transpose()));
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0)) {
    doc.Fail(cov, fmt::format("{} cov is not positive definite", what));
  }
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
    if (!(camera.fx > 0) || !(camera.fy > 0)) doc.Fail(node, "camera fx and fy must be positive");
  } else {
    camera.scale = *get("scale", true);
    if (!(camera.scale > 0)) doc.Fail(node["scale"], "camera scale must be positive");
  }
  camera.cx = *get("cx", true);
  camera.cy = *get("cy", true);
  for (const char* key : {"width", "height"}) {
    const double v = *get(key, true);
    if (!(v >= 1) || v != std::floor(v) || v > 1e6) {
      doc.Fail(Document::Find(entries, key),
               fmt::format("camera {} must be a positive whole number of pixels", key));
    }
    (std::string(key) == "width" ? camera.width : camera.height) = static_cast<int>(v);
  }
  if (YAML::Node d = Document::Find(entries, "dist"); Present(d)) {
    if (!d.IsSequence()) doc.Fail(d, "camera dist must be a list of distortion coefficients");
    const int n = static_cast<int>(d.size());
    if (n == 14) {
      doc.Fail(d,
               "the tilted-sensor coefficients (14 values) are not supported; give 0, 4, 5, 8 "
               "or 12 coefficients");
    }
    if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12) {
      doc.Fail(d, fmt::format("camera dist has {} coefficients; OpenCV's model takes 4, 5, 8 or 12 "
                              "(k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4]]])",
                              n));
    }
    for (int i = 0; i < n; ++i) camera.distortion[i] = Number(doc, d[i], "camera dist");
  }
  return camera;
}

MeasurementSet Read(const std::string& display, const std::string& text) {
  CheckText(display, text, kMeasurementFile);
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
  const std::string text = ReadTextFile(path, SourceLocation(), kCameraFile);
  CheckText(path, text, kCameraFile);
  const Document doc(path, text, kCameraFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap())
    doc.Fail(root, "a camera file is a mapping with fx, fy, cx, cy, width, height");
  if (Present(root["camera"])) return ReadCamera(doc, root["camera"]);
  return ReadCamera(doc, root);
}

}  // namespace cfuse::dsl
