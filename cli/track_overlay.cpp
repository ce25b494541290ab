#include "cli/track_overlay.h"

#include <opencv2/imgproc.hpp>

#include "cfuse/geometry/model_edges.h"

namespace cfuse::cli {
namespace {

// fillPoly and line take fixed-point vertices: 1/16 px.
constexpr int kShift = 4;
cv::Point Fixed(const Eigen::Vector2d& p) {
  return {static_cast<int>(std::lround(p.x() * (1 << kShift))),
          static_cast<int>(std::lround(p.y() * (1 << kShift)))};
}

bool Drawable(const Eigen::Vector2d& p) { return p.allFinite() && p.cwiseAbs().maxCoeff() < 1e6; }

}  // namespace

cv::Mat3b DrawOverlay(const GrayView& image, const ConstraintGraph& graph,
                      const Camera& camera, const TrackedFrame& frame,
                      const OverlayOptions& options) {
  const cv::Mat1b grey(image.height, image.width, const_cast<std::uint8_t*>(image.data),
                       static_cast<size_t>(image.step));
  cv::Mat3b out;
  cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);

  if (options.regions) {
    // Each predicted edge's band of ±2σ across it, blended in at 35 %.
    cv::Mat3b shade = out.clone();
    for (const PredictedEdge& e : frame.predicted) {
      const Eigen::Vector2d d = e.b - e.a;
      if (d.norm() == 0 || !Drawable(e.a) || !Drawable(e.b)) continue;
      const Eigen::Vector2d n = Eigen::Vector2d(-d.y(), d.x()).normalized();
      // At least a pixel either side, so that a tight prediction still shows.
      const double wa = std::max(1.0, 2 * e.sigma_a), wb = std::max(1.0, 2 * e.sigma_b);
      const std::vector<std::vector<cv::Point>> band = {
          {Fixed(e.a + wa * n), Fixed(e.b + wb * n), Fixed(e.b - wb * n), Fixed(e.a - wa * n)}};
      cv::fillPoly(shade, band, cv::Scalar(255, 160, 60), cv::LINE_AA, kShift);
    }
    cv::addWeighted(shade, 0.35, out, 0.65, 0, out);
  }
  if (options.segments) {
    for (const PredictedEdge& e : frame.predicted) {
      if (!e.matched) continue;
      cv::line(out, Fixed(e.segment_a), Fixed(e.segment_b), cv::Scalar(0, 200, 0), 1, cv::LINE_AA,
               kShift);
    }
  }
  const cv::Scalar colour = frame.verified ? cv::Scalar(0, 230, 255) : cv::Scalar(0, 0, 255);
  const std::vector<ModelEdge> edges = ModelEdges(graph);
  for (const ProjectedEdge& e :
       VisibleEdges(graph, edges, frame.estimate.mean, camera)) {
    if (!Drawable(e.a) || !Drawable(e.b)) continue;
    cv::line(out, Fixed(e.a), Fixed(e.b), colour, 1, cv::LINE_AA, kShift);
  }
  if (!options.caption.empty()) {
    const cv::Point at(8, 20);
    cv::putText(out, options.caption, at, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3,
                cv::LINE_AA);
    cv::putText(out, options.caption, at, cv::FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv::LINE_AA);
  }
  return out;
}

}  // namespace cfuse::cli
