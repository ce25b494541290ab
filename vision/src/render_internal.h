// What the renderer's two styles share (render.h): filling polygons by pixel centres, the depth
// and face buffers, the background clutter, the hand occluder and the truth. Internal to
// cfuse::vision (not installed).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "cfuse/vision/render.h"

namespace cfuse::internal {

constexpr double kNearPlane = 1e-3;
constexpr int kFaceStride = 1 << 16;  // the face buffer holds component * kFaceStride + face
constexpr int kOccluder = -2;         // in the face buffer (-1: background)

// Throws InputError (its location left to the caller, who knows the file) for a camera the renderer
// cannot draw (render.h).
void CheckRenderable(const Camera& camera);

// Calls span(v, u0, u1) for each row v whose pixels u0 <= u < u1 have their centres inside
// `polygon` (even-odd rule, half-open on the right and bottom so faces sharing a side split its
// pixels), within a width x height image. cv::fillPoly also sets every pixel the outline
// touches, which grows each face by about 0.6 px all round and biases anything fitted to the
// rendered edges (depth, for a box seen in full, by several millimetres).
template <typename Span>
void ForEachSpan(const std::vector<Eigen::Vector2d>& polygon, int width, int height, Span span) {
  double top = std::numeric_limits<double>::infinity(), bottom = -top;
  for (const Eigen::Vector2d& p : polygon) {
    top = std::min(top, p.y());
    bottom = std::max(bottom, p.y());
  }
  if (!std::isfinite(top) || !std::isfinite(bottom)) return;
  const int v0 = static_cast<int>(std::ceil(std::clamp(top, 0.0, double(height))));
  const int v1 = static_cast<int>(std::ceil(std::clamp(bottom, 0.0, double(height)))) - 1;
  std::vector<double> crossings;
  for (int v = v0; v <= v1; ++v) {
    crossings.clear();
    for (size_t k = 0; k < polygon.size(); ++k) {
      const Eigen::Vector2d& a = polygon[k];
      const Eigen::Vector2d& b = polygon[(k + 1) % polygon.size()];
      if ((a.y() <= v) == (b.y() <= v)) continue;  // the side does not span this row's centres
      crossings.push_back(a.x() + (v - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
    }
    std::sort(crossings.begin(), crossings.end());
    for (size_t k = 0; k + 1 < crossings.size(); k += 2) {
      const double cols = width;
      const int u0 = static_cast<int>(std::ceil(std::clamp(crossings[k], 0.0, cols)));
      const int u1 = static_cast<int>(std::ceil(std::clamp(crossings[k + 1], 0.0, cols)));
      if (u0 < u1) span(v, u0, u1);
    }
  }
}

// Sets the pixels of `mask` whose centre lies inside `polygon` to 255 (ForEachSpan).
void FillPixelCentres(const std::vector<Eigen::Vector2d>& polygon, cv::Mat1b& mask);

// The camera's rays and depths.
struct RayCaster {
  const Camera& camera;

  // The camera-frame ray through pixel (u, v): for a pinhole camera the point at depth 1,
  // for an orthographic one the point at depth 0 (the ray runs along +z).
  Eigen::Vector3d Ray(double u, double v) const {
    if (camera.model == Camera::Model::kOrthographic) {
      return {(u - camera.cx) / camera.scale, (v - camera.cy) / camera.scale, 0};
    }
    return {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1};
  }
  // Depth at pixel (u, v) of the plane through p with normal n; NaN if parallel to the ray.
  double DepthOnPlane(double u, double v, const Eigen::Vector3d& n,
                      const Eigen::Vector3d& p) const {
    const Eigen::Vector3d r = Ray(u, v);
    if (camera.model == Camera::Model::kOrthographic) {
      if (std::abs(n.z()) < 1e-12) return std::numeric_limits<double>::quiet_NaN();
      return (n.dot(p) - n.x() * r.x() - n.y() * r.y()) / n.z();
    }
    const double denominator = n.dot(r);
    if (std::abs(denominator) < 1e-12) return std::numeric_limits<double>::quiet_NaN();
    return n.dot(p) / denominator;
  }
};

// One front face as the camera sees it: its corners in the camera frame and in the image, and
// its plane's unit normal (towards the camera). Faces crossing a pinhole camera's plane, with
// fewer than three corners or without area are left out.
struct ViewedFace {
  int component = -1, face = -1;
  std::vector<Eigen::Vector3d> corners;
  std::vector<Eigen::Vector2d> polygon;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};
std::vector<ViewedFace> FrontFaces(const ConstraintGraph& graph, const Values& values,
                                   const Camera& camera);

// The random clutter of the background: `blobs` filled ellipses, then `lines` straight lines
// of 1-3 px, in dark greys (20-110), anti-aliased, moved by `offset`.
void DrawClutter(cv::Mat1b& image, int lines, int blobs, std::mt19937& rng,
                 cv::Point offset = cv::Point(0, 0));

// Calls paint(u, v, coverage, shade) for every pixel the hand touches: coverage the share of
// the pixel it covers (0-1, its outline anti-aliased), shade its brightness relative to skin
// in full light (about 0.3-1.1).
void ForEachHandPixel(const HandOccluder& hand, int width, int height,
                      const std::function<void(int u, int v, float coverage, float shade)>& paint);
constexpr double kSkinAlbedo = 0.62;
constexpr double kWhite = 235;  // grey level of a white surface in full light

// The truth (render.h): `flat(uv, normal)` says whether the image shows no contrast across the
// edge at image point uv (normal: the edge's unit normal in the image).
std::vector<TruthSegment> VisibleTruth(
    const ConstraintGraph& graph, const Values& values, const Camera& camera,
    const cv::Mat1f& depth, const cv::Mat1i& face,
    const std::function<bool(const Eigen::Vector2d& uv, const Eigen::Vector2d& normal)>& flat);

Rendering RenderRealistic(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                          const RenderOptions& options);

}  // namespace cfuse::internal
