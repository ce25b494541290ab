#include "cfuse/vision/point_picture.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace cfuse {
namespace {

// OpenCV colours are BGR.
const cv::Scalar kBackground(255, 255, 255), kText(40, 40, 40), kClutter(170, 170, 170),
    kMatched(60, 160, 40), kWrong(40, 40, 220), kModel(0, 140, 255), kFrame(210, 210, 210);

// The principal axes of the model points (or of all points when there are none), largest
// spread first, as the rows of a rotation.
Eigen::Matrix3d PrincipalAxes(const std::vector<PictureMarker>& markers, Eigen::Vector3d* centre) {
  std::vector<Eigen::Vector3d> points;
  for (const PictureMarker& m : markers) {
    if (m.kind == PictureMarker::Kind::kModelPoint || m.kind == PictureMarker::Kind::kOccluded) {
      points.push_back(m.xyz);
    }
  }
  if (points.size() < 3) {
    for (const PictureMarker& m : markers) points.push_back(m.xyz);
  }
  *centre = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) *centre += p;
  if (!points.empty()) *centre /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - *centre) * (p - *centre).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  Eigen::Matrix3d axes;
  for (int i = 0; i < 3; ++i) axes.row(i) = eigen.eigenvectors().col(2 - i).transpose();
  return axes;
}

}  // namespace

std::string PointPicturePng(const std::vector<PictureMarker>& markers,
                            const std::vector<PictureSegment>& segments, const std::string& title,
                            int width, int height) {
  cv::Mat image(height, width, CV_8UC3, kBackground);
  Eigen::Vector3d centre;
  const Eigen::Matrix3d axes = PrincipalAxes(markers, &centre);
  // Two panels: axes (0, 1) seen along axis 2, and axes (0, 2) seen along axis 1. One scale
  // for both, fitted to every point.
  const int top = 50, bottom = 60, margin = 30;
  const int panel_w = (width - 3 * margin) / 2, panel_h = height - top - bottom;
  double reach = 1e-9;
  for (const PictureMarker& m : markers) {
    reach = std::max(reach, (axes * (m.xyz - centre)).cwiseAbs().maxCoeff());
  }
  const double scale = 0.48 * std::min(panel_w, panel_h) / reach;
  const std::array<std::pair<int, int>, 2> views = {{{0, 1}, {0, 2}}};
  for (int v = 0; v < 2; ++v) {
    const int x0 = margin + v * (panel_w + margin);
    const cv::Point origin(x0 + panel_w / 2, top + panel_h / 2);
    auto at = [&](const Eigen::Vector3d& p) {
      const Eigen::Vector3d q = axes * (p - centre);
      return cv::Point(origin.x + static_cast<int>(std::lround(scale * q(views[v].first))),
                       origin.y - static_cast<int>(std::lround(scale * q(views[v].second))));
    };
    cv::rectangle(image, cv::Rect(x0, top, panel_w, panel_h), kFrame, 1);
    cv::putText(image, v == 0 ? "view along the model's thinnest axis" : "side view",
                cv::Point(x0 + 6, top + 18), cv::FONT_HERSHEY_SIMPLEX, 0.45, kText, 1, cv::LINE_AA);
    for (const PictureMarker& m : markers) {
      if (m.kind == PictureMarker::Kind::kClutter) {
        cv::circle(image, at(m.xyz), 2, kClutter, cv::FILLED, cv::LINE_AA);
      }
    }
    for (const PictureSegment& s : segments) {
      cv::line(image, at(s.a), at(s.b), kModel, 1, cv::LINE_AA);
    }
    for (const PictureMarker& m : markers) {
      const cv::Point p = at(m.xyz);
      switch (m.kind) {
        case PictureMarker::Kind::kClutter:
          break;
        case PictureMarker::Kind::kMatched:
          cv::circle(image, p, 6, kMatched, 2, cv::LINE_AA);
          break;
        case PictureMarker::Kind::kWrong:
          cv::drawMarker(image, p, kWrong, cv::MARKER_TILTED_CROSS, 12, 2, cv::LINE_AA);
          break;
        case PictureMarker::Kind::kModelPoint:
          cv::circle(image, p, 3, kModel, cv::FILLED, cv::LINE_AA);
          break;
        case PictureMarker::Kind::kOccluded:
          cv::circle(image, p, 6, kModel, 1, cv::LINE_AA);
          break;
      }
      if (!m.label.empty() && v == 0) {
        cv::putText(image, m.label, p + cv::Point(6, -6), cv::FONT_HERSHEY_SIMPLEX, 0.35, kText, 1,
                    cv::LINE_AA);
      }
    }
  }
  cv::putText(image, title, cv::Point(margin, 32), cv::FONT_HERSHEY_SIMPLEX, 0.6, kText, 1,
              cv::LINE_AA);
  // Legend.
  const int y = height - bottom / 2;
  int x = margin;
  auto entry = [&](const std::string& text, auto draw) {
    draw(cv::Point(x + 8, y - 4));
    cv::putText(image, text, cv::Point(x + 20, y), cv::FONT_HERSHEY_SIMPLEX, 0.45, kText, 1,
                cv::LINE_AA);
    x += 30 + static_cast<int>(text.size()) * 8;
  };
  entry("clutter", [&](cv::Point p) { cv::circle(image, p, 2, kClutter, cv::FILLED); });
  entry("measurement matched right", [&](cv::Point p) { cv::circle(image, p, 6, kMatched, 2); });
  entry("matched wrong / missed",
        [&](cv::Point p) { cv::drawMarker(image, p, kWrong, cv::MARKER_TILTED_CROSS, 12, 2); });
  entry("fitted model", [&](cv::Point p) {
    cv::line(image, p - cv::Point(8, 0), p + cv::Point(8, 0), kModel, 1);
    cv::circle(image, p, 3, kModel, cv::FILLED);
  });
  entry("occluded point, estimated", [&](cv::Point p) { cv::circle(image, p, 6, kModel, 1); });
  std::vector<unsigned char> png;
  cv::imencode(".png", image, png);
  return std::string(png.begin(), png.end());
}

}  // namespace cfuse
