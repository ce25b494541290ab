#include "bench/chamfer_baseline.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <queue>

#include "cfuse/track/detector.h"

namespace cfuse::bench {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

double Ms(Clock::time_point from) {
  return std::chrono::duration<double, std::milli>(Clock::now() - from).count();
}

int Bin(double normal, int bins) {
  double a = std::fmod(normal, M_PI);
  if (a < 0) a += M_PI;
  return std::min(bins - 1, static_cast<int>(a / M_PI * bins));
}

// Per orientation bin: how near (1 - d / truncate, 0 beyond) the nearest Canny edge pixel whose
// gradient lies in that bin or a neighbouring one is, less that nearness's mean over the image
// (what a sample anywhere gets by chance). A template's evidence is the sum over its samples:
// what it explains beyond chance, so that neither a small outline in a busy corner nor a large
// one over texture wins by its size alone.
std::vector<cv::Mat> OrientedEvidence(const GrayView& image, const ChamferOptions& o,
                                      double* best_gain) {
  const cv::Mat gray(image.height, image.width, CV_8U, const_cast<std::uint8_t*>(image.data),
                     image.step);
  cv::Mat blurred, edges, dx, dy;
  cv::GaussianBlur(gray, blurred, cv::Size(5, 5), 1.2);
  cv::Canny(blurred, edges, o.canny_low, o.canny_high);
  cv::Sobel(blurred, dx, CV_32F, 1, 0);
  cv::Sobel(blurred, dy, CV_32F, 0, 1);
  std::vector<cv::Mat> sources(o.bins, cv::Mat(image.height, image.width, CV_8U, cv::Scalar(255)));
  for (cv::Mat& s : sources) s = s.clone();
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (!edges.at<std::uint8_t>(y, x)) continue;
      const int b = Bin(std::atan2(dy.at<float>(y, x), dx.at<float>(y, x)), o.bins);
      sources[b].at<std::uint8_t>(y, x) = 0;
    }
  }
  std::vector<cv::Mat> own(o.bins), out(o.bins);
  for (int b = 0; b < o.bins; ++b) cv::distanceTransform(sources[b], own[b], cv::DIST_L2, 3);
  for (int b = 0; b < o.bins; ++b) {
    cv::min(own[b], own[(b + 1) % o.bins], out[b]);
    cv::min(out[b], own[(b + o.bins - 1) % o.bins], out[b]);
    cv::min(out[b], o.truncate, out[b]);
    out[b] = 1 - out[b] / o.truncate;
    out[b] -= cv::mean(out[b])[0];
    double low = 0, high = 0;
    cv::minMaxLoc(out[b], &low, &high);
    *best_gain = b == 0 ? high : std::max(*best_gain, high);
  }
  return out;
}

// A template placed in the image: which one, turned and scaled how, centred where.
struct Placement {
  int templ = 0, turn = 0, size = 0;
  int u = 0, v = 0;
  double score = 0;
  // std::priority_queue keeps the least evidence on top: the worst of those kept.
  bool operator<(const Placement& other) const { return score > other.score; }
};

struct Point {
  int dx, dy, bin;
};

// The samples of template `samples` turned by `angle` and scaled by `scale`, every `stride`-th.
std::vector<Point> Transformed(const std::vector<Eigen::Vector3f>& samples, double angle,
                               double scale, int stride, int bins) {
  std::vector<Point> out;
  const double c = std::cos(angle), s = std::sin(angle);
  for (size_t i = 0; i < samples.size(); i += stride) {
    const Eigen::Vector3f& p = samples[i];
    out.push_back({static_cast<int>(std::lround(scale * (c * p.x() - s * p.y()))),
                   static_cast<int>(std::lround(scale * (s * p.x() + c * p.y()))),
                   Bin(p.z() + angle, bins)});
  }
  return out;
}

// The evidence of `points` centred at (u, v), times `weight` (the samples a subset stands for),
// or -inf when fewer than `min_inside` of them fall inside the image or the sum cannot beat
// `bound` even if every sample left gained `best_gain`.
double Score(const std::vector<cv::Mat>& evidence, const std::vector<Point>& points, int u, int v,
             double min_inside, double weight, double best_gain, double bound) {
  const int w = evidence[0].cols, h = evidence[0].rows;
  const int n = static_cast<int>(points.size());
  double sum = 0;
  int inside = 0;
  for (int i = 0; i < n; ++i) {
    const Point& p = points[i];
    const int x = u + p.dx, y = v + p.dy;
    if (x >= 0 && y >= 0 && x < w && y < h) {
      sum += evidence[p.bin].at<float>(y, x);
      ++inside;
    }
    if ((i & 7) == 7 && weight * (sum + best_gain * (n - 1 - i)) < bound) return -kInfinity;
  }
  if (inside < min_inside * n) return -kInfinity;
  return weight * sum;
}

}  // namespace

ChamferBaseline::ChamferBaseline(const ConstraintGraph& graph, const Camera& camera,
                                 ChamferOptions options)
    : graph_(graph), camera_(camera), options_(std::move(options)), edges_(ModelEdges(graph)) {
  const auto start = Clock::now();
  std::vector<Eigen::Vector3d> points;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const Rigid3d& pose = graph.nominal.poses[graph.blocks[c.block].index];
    for (const FeaturePoint& p : c.points) points.push_back(pose * p.position);
  }
  centre_.setZero();
  for (const Eigen::Vector3d& p : points) centre_ += p;
  centre_ /= std::max<size_t>(1, points.size());
  double radius = 0;
  for (const Eigen::Vector3d& p : points) radius = std::max(radius, (p - centre_).norm());
  diameter_ = std::max(2 * radius, 1e-6);
  // Templates on a camera without borders: nothing clipped.
  Camera wide = camera_;
  wide.distortion.fill(0);
  wide.width = wide.height = 20000;
  wide.cx = wide.cy = 10000;
  reference_size_ = 400;
  depth_ = 0.5 * (camera_.fx + camera_.fy) * diameter_ / reference_size_;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  const Visibility visibility{0, 0, true};
  for (int k = 0; k < options_.directions; ++k) {
    const double z = 1 - 2 * (k + 0.5) / options_.directions, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d to_camera(r * std::cos(golden * k), r * std::sin(golden * k), z);
    const Eigen::Vector3d axis = -to_camera;  // the camera's z in the model's frame
    const Eigen::Vector3d up =
        std::abs(axis.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    const Eigen::Vector3d x = up.cross(axis).normalized(), y = axis.cross(x);
    Eigen::Matrix3d world_from_camera;
    world_from_camera << x, y, axis;
    Template t;
    t.camera_from_object = world_from_camera.transpose();
    const Values values = Posed(t.camera_from_object, Eigen::Vector3d(0, 0, depth_));
    for (const ProjectedEdge& e : VisibleEdges(graph_, edges_, values, wide, visibility)) {
      const Eigen::Vector2d d = e.b - e.a;
      const double length = d.norm();
      if (length < 2) continue;
      const double normal = std::atan2(d.x(), -d.y());
      const int n = std::max(1, static_cast<int>(length / options_.sample_step));
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d p = e.a + (i + 0.5) / n * d;
        t.samples.emplace_back(static_cast<float>(p.x() - wide.cx),
                               static_cast<float>(p.y() - wide.cy), static_cast<float>(normal));
      }
    }
    if (t.samples.size() >= 8) templates_.push_back(std::move(t));
  }
  training_ms_ = Ms(start);
}

Values ChamferBaseline::Posed(const Eigen::Matrix3d& rotation,
                              const Eigen::Vector3d& centre_in_camera) const {
  const Rigid3d camera_from_world(rotation, centre_in_camera - rotation * centre_);
  Values v = graph_.nominal;
  for (Rigid3d& pose : v.poses) pose = camera_from_world * pose;
  for (Eigen::Vector3d& point : v.points) point = camera_from_world * point;
  return v;
}

double ChamferBaseline::PoseEvidence(const std::vector<cv::Mat>& evidence,
                                     const Values& values) const {
  const ChamferOptions& o = options_;
  const Visibility visibility{0, 0, true};
  double sum = 0;
  int inside = 0, all = 0;
  for (const ProjectedEdge& e : VisibleEdges(graph_, edges_, values, camera_, visibility)) {
    const Eigen::Vector2d d = e.b - e.a;
    const double length = d.norm();
    const int n = static_cast<int>(length / o.sample_step);
    const int bin = Bin(std::atan2(d.x(), -d.y()), o.bins);
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d p = e.a + (i + 0.5) / n * d;
      const int x = static_cast<int>(std::lround(p.x())), y = static_cast<int>(std::lround(p.y()));
      ++all;
      if (x < 0 || y < 0 || x >= evidence[0].cols || y >= evidence[0].rows) continue;
      sum += evidence[bin].at<float>(y, x);
      ++inside;
    }
  }
  return inside >= o.min_inside * all && inside >= 16 ? sum : -kInfinity;
}

double ChamferBaseline::Evidence(const GrayView& image, const Values& values) const {
  double best_gain = 1;
  return PoseEvidence(OrientedEvidence(image, options_, &best_gain), values);
}

std::vector<Values> ChamferBaseline::Candidates(const GrayView& image, ChamferStats* stats) const {
  const ChamferOptions& o = options_;
  auto start = Clock::now();
  double best_gain = 1;
  const std::vector<cv::Mat> evidence = OrientedEvidence(image, o, &best_gain);
  stats->edges_ms += Ms(start);

  // The coarse pass: every template, turn and size at every `position_step`-th place, on a
  // subset of its samples; the best `kept` placements rescored on all of them.
  start = Clock::now();
  std::priority_queue<Placement> best;  // the worst kept on top
  for (size_t t = 0; t < templates_.size(); ++t) {
    const std::vector<Eigen::Vector3f>& samples = templates_[t].samples;
    const int stride = std::max<int>(1, static_cast<int>(samples.size()) / o.coarse_samples);
    for (int turn = 0; turn < o.turns; ++turn) {
      const double angle = 2 * M_PI * turn / o.turns;
      for (size_t size = 0; size < o.sizes.size(); ++size) {
        const std::vector<Point> points =
            Transformed(samples, angle, o.sizes[size] / reference_size_, stride, o.bins);
        // The subset stands for the samples of the whole outline at this size.
        const double weight = o.sizes[size] / reference_size_ *
                              static_cast<double>(samples.size()) /
                              static_cast<double>(points.size());
        for (int v = o.position_step / 2; v < image.height; v += o.position_step) {
          for (int u = o.position_step / 2; u < image.width; u += o.position_step) {
            ++stats->placements;
            const double bound =
                static_cast<int>(best.size()) < o.kept ? -kInfinity : best.top().score;
            const double score =
                Score(evidence, points, u, v, o.min_inside, weight, best_gain, bound);
            if (!(score > bound)) continue;
            best.push({static_cast<int>(t), turn, static_cast<int>(size), u, v, score});
            if (static_cast<int>(best.size()) > o.kept) best.pop();
          }
        }
      }
    }
  }
  std::vector<Placement> kept;
  while (!best.empty()) {
    Placement p = best.top();
    best.pop();
    const double angle = 2 * M_PI * p.turn / o.turns;
    const std::vector<Point> all = Transformed(templates_[p.templ].samples, angle,
                                               o.sizes[p.size] / reference_size_, 1, o.bins);
    p.score = Score(evidence, all, p.u, p.v, o.min_inside, o.sizes[p.size] / reference_size_,
                    best_gain, -kInfinity);
    kept.push_back(p);
  }
  std::sort(kept.begin(), kept.end(),
            [](const Placement& a, const Placement& b) { return a.score > b.score; });
  stats->matching_ms += Ms(start);

  // The placements as poses: turned about the optical axis, at the size's depth, and turned
  // about the camera's centre so that the model's centre lies on the place's ray.
  start = Clock::now();
  auto pose_of = [&](const Placement& p) {
    const double angle = 2 * M_PI * p.turn / o.turns;
    const Eigen::Vector3d ray =
        Eigen::Vector3d((p.u - camera_.cx) / camera_.fx, (p.v - camera_.cy) / camera_.fy, 1)
            .normalized();
    const Eigen::Matrix3d shift =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), ray).toRotationMatrix();
    const double depth = depth_ * reference_size_ / o.sizes[p.size];
    return std::make_pair(
        Eigen::Matrix3d(shift * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()) *
                        templates_[p.templ].camera_from_object),
        Eigen::Vector3d(depth * ray));
  };
  auto score_of = [&](const Eigen::Matrix3d& rotation, const Eigen::Vector3d& centre) {
    if (!(centre.z() > 0.5 * diameter_)) return -kInfinity;
    return PoseEvidence(evidence, Posed(rotation, centre));
  };

  std::vector<std::vector<Eigen::Vector2d>> chosen_points;
  std::vector<std::pair<double, Values>> refined;
  for (const Placement& p : kept) {
    if (static_cast<int>(refined.size()) >= o.candidates) break;
    auto [rotation, centre] = pose_of(p);
    // Spread apart: not one already chosen again (every model point within spread_pixels).
    const std::vector<Eigen::Vector2d> points =
        ProjectedPoints(graph_, camera_, Posed(rotation, centre));
    bool same = false;
    for (const auto& other : chosen_points) {
      double farthest = 0;
      for (size_t i = 0; i < points.size() && i < other.size(); ++i) {
        farthest = std::max(farthest, (points[i] - other[i]).norm());
      }
      same = same || farthest < o.spread_pixels;
    }
    if (same) continue;
    chosen_points.push_back(points);
    // Refined by coordinate descent on the score: turns about the camera's axes through the
    // model's centre, moves across the line of sight and along it, each step halved three times.
    double score = score_of(rotation, centre);
    double turn_step = 4 * M_PI / 180;
    double pixel_step = 4;
    for (int round = 0; round < 4; ++round) {
      bool moved = true;
      for (int sweep = 0; moved && sweep < 6; ++sweep) {
        moved = false;
        for (int axis = 0; axis < 6; ++axis) {
          for (const double sign : {1.0, -1.0}) {
            Eigen::Matrix3d r = rotation;
            Eigen::Vector3d c = centre;
            if (axis < 3) {
              r = Eigen::AngleAxisd(sign * turn_step, Eigen::Vector3d::Unit(axis)) * rotation;
            } else if (axis < 5) {
              c[axis - 3] += sign * pixel_step * c.z() / camera_.fx;
            } else {
              // Nearer or farther by what moves the outline's ends about pixel_step.
              c *= 1 + sign * pixel_step * c.z() / (camera_.fx * diameter_);
            }
            const double s = score_of(r, c);
            if (s > score) {
              score = s;
              rotation = r;
              centre = c;
              moved = true;
            }
          }
        }
      }
      turn_step /= 2;
      pixel_step /= 2;
    }
    refined.emplace_back(score, Posed(rotation, centre));
  }
  std::stable_sort(refined.begin(), refined.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<Values> out;
  for (auto& [score, values] : refined) out.push_back(std::move(values));
  stats->refinement_ms += Ms(start);
  return out;
}

}  // namespace cfuse::bench
