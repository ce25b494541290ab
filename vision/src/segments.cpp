#include "cfuse/vision/segments.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point from, Clock::time_point to) {
  return std::chrono::duration<double, std::milli>(to - from).count();
}

int KernelSize(double sigma) { return 2 * static_cast<int>(std::ceil(3 * sigma)) + 1; }

// The LoG in float: the Gaussian straight from the 8-bit image (one separable pass pair), then
// the 3 x 3 Laplacian. (Blurring in 8 bits is twice as fast but its rounding puts a noise of
// about 2 LoG units on every pixel, as much as a 12-level edge's slope: crossings everywhere.)
cv::Mat LaplacianOfGaussian(const cv::Mat& image8, double sigma) {
  thread_local cv::Mat kernel;
  thread_local double kernel_sigma = 0;
  if (kernel_sigma != sigma) {
    kernel = cv::getGaussianKernel(KernelSize(sigma), sigma, CV_32F);
    kernel_sigma = sigma;
  }
  // Kept between calls: fresh megabytes would cost a page fault per 4 KiB every frame.
  thread_local cv::Mat blurred, log;
  cv::sepFilter2D(image8, blurred, CV_32F, kernel, kernel, cv::Point(-1, -1), 0,
                  cv::BORDER_REPLICATE);
  cv::Laplacian(blurred, log, CV_32F, 1, 1, 0, cv::BORDER_REPLICATE);
  return log;
}

// What a unit step edge produces, measured on the kernels themselves (so the thresholds read
// as edge contrasts whatever the discretisation): the LoG's slope across the crossing, and
// Canny's Sobel gradient magnitude at the edge. Computed once per σ.
struct StepResponse {
  double log_slope = 0, sobel = 0;
};

StepResponse UnitStep(double sigma) {
  static std::mutex mutex;
  static std::map<double, StepResponse> known;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = known.find(sigma); it != known.end()) return it->second;
  const int n = 8 * KernelSize(sigma);
  cv::Mat step(n, n, CV_8U, cv::Scalar(50));
  step.colRange(n / 2, n).setTo(250);
  const cv::Mat log = LaplacianOfGaussian(step, sigma);
  double slope = 0;
  for (int x = 0; x + 1 < n; ++x) {
    slope = std::max(slope, std::abs(static_cast<double>(log.at<float>(n / 2, x)) -
                                     static_cast<double>(log.at<float>(n / 2, x + 1))));
  }
  cv::Mat blurred, gx;
  const int k = KernelSize(sigma);
  cv::GaussianBlur(step, blurred, cv::Size(k, k), sigma, sigma, cv::BORDER_REPLICATE);
  cv::Sobel(blurred, gx, CV_32F, 1, 0, 3);
  double sobel = 0;
  cv::minMaxLoc(cv::abs(gx), nullptr, &sobel);
  StepResponse r{slope / 200, sobel / 200};
  known.emplace(sigma, r);
  return r;
}

// Edge pixels on a map one pixel wider on every side than the image (so neighbours need no
// bounds checks). Index of image pixel (x, y): (y + 1) * stride + x + 1.
struct EdgeMap {
  enum : std::uint8_t { kNone = 0, kWeak = 1, kStrong = 2, kKept = 3, kLinked = 4 };
  int width = 0, height = 0, stride = 0;
  std::vector<std::uint8_t> state;
  std::vector<int> strong, kept;  // indices

  void Reset(int w, int h) {
    width = w;
    height = h;
    stride = w + 2;
    state.assign(static_cast<size_t>(stride) * (h + 2), kNone);
    strong.clear();
    kept.clear();
  }
  int Index(int x, int y) const { return (y + 1) * stride + x + 1; }
  int X(int i) const { return i % stride - 1; }
  int Y(int i) const { return i / stride - 1; }
};

// The 8 neighbours' index offsets: 4-neighbours first (chains prefer them), then diagonals.
std::array<int, 8> Neighbours(int stride) {
  return {1, stride, -1, -stride, stride + 1, stride - 1, -stride - 1, -stride + 1};
}

// Hysteresis: from every strong pixel, through 8-connected weak or strong ones; fills `kept`.
void Hysteresis(EdgeMap* e) {
  const std::array<int, 8> nb = Neighbours(e->stride);
  std::uint8_t* state = e->state.data();
  std::vector<int> stack;
  for (int seed : e->strong) {
    if (state[seed] != EdgeMap::kStrong) continue;
    state[seed] = EdgeMap::kKept;
    e->kept.push_back(seed);
    stack.push_back(seed);
    while (!stack.empty()) {
      const int p = stack.back();
      stack.pop_back();
      for (int d : nb) {
        const int q = p + d;
        if (state[q] == EdgeMap::kWeak || state[q] == EdgeMap::kStrong) {
          state[q] = EdgeMap::kKept;
          e->kept.push_back(q);
          stack.push_back(q);
        }
      }
    }
  }
}

// Lowe's edges: zero crossings of the LoG between 4-neighbours, each on the pixel of its
// positive side (those pixels form a contour one pixel thin), weak or strong by the steepest
// slope of the LoG across its crossings; then hysteresis. The per-pixel work has no branch
// (the sign changes at random in flat, noisy regions, where a branch mispredicts half the
// time), and strong pixels are collected eight bytes at a time.
void LoweEdges(const cv::Mat& log, float low, float high, EdgeMap* e) {
  e->Reset(log.cols, log.rows);
  const int w = log.cols, h = log.rows;
  thread_local std::vector<float> slope;
  slope.resize(w);
  for (int y = 0; y < h; ++y) {
    const float* row = log.ptr<float>(y);
    const float* up = log.ptr<float>(y > 0 ? y - 1 : y);
    const float* down = log.ptr<float>(y + 1 < h ? y + 1 : y);
    // The steepest slope from this pixel, if positive, to a negative 4-neighbour.
    auto one = [&](int x, float r, float left) {
      const float l = row[x];
      if (l < 0) return 0.f;
      float s = 0;
      for (float q : {r, left, down[x], up[x]}) {
        if (q < 0) s = std::max(s, l - q);
      }
      return s;
    };
    int x = 1;
#if CV_SIMD
    // In SIMD lanes: GCC turns every scalar formulation of this back into branches, which
    // mispredict half the time on the random signs of a flat, noisy region (10 ns a pixel).
    const cv::v_float32 zero = cv::vx_setzero_f32();
    for (; x + cv::v_float32::nlanes < w; x += cv::v_float32::nlanes) {
      const cv::v_float32 l = cv::vx_load(row + x);
      const cv::v_float32 r = cv::vx_load(row + x + 1), left = cv::vx_load(row + x - 1);
      const cv::v_float32 below = cv::vx_load(down + x), above = cv::vx_load(up + x);
      cv::v_float32 s = cv::v_select(r < zero, l - r, zero);
      s = cv::v_max(s, cv::v_select(left < zero, l - left, zero));
      s = cv::v_max(s, cv::v_select(below < zero, l - below, zero));
      s = cv::v_max(s, cv::v_select(above < zero, l - above, zero));
      cv::v_store(slope.data() + x, cv::v_select(l >= zero, s, zero));
    }
#endif
    for (; x + 1 < w; ++x) slope[x] = one(x, row[x + 1], row[x - 1]);
    slope[0] = one(0, row[std::min(1, w - 1)], row[0]);
    if (w > 1) slope[w - 1] = one(w - 1, row[w - 1], row[w - 2]);
    std::uint8_t* out = e->state.data() + e->Index(0, y);
    for (int k = 0; k < w; ++k) {
      // kNone 0, kWeak 1, kStrong 2.
      out[k] = static_cast<std::uint8_t>(static_cast<int>(slope[k] >= low) +
                                         static_cast<int>(slope[k] >= high));
    }
    x = 0;
    for (; x + 8 <= w; x += 8) {
      std::uint64_t word;
      std::memcpy(&word, out + x, 8);
      if (!(word & 0x0202020202020202ull)) continue;
      for (int k = x; k < x + 8; ++k) {
        if (out[k] == EdgeMap::kStrong) e->strong.push_back(e->Index(k, y));
      }
    }
    for (; x < w; ++x) {
      if (out[x] == EdgeMap::kStrong) e->strong.push_back(e->Index(x, y));
    }
  }
  Hysteresis(e);
}

// Where the edge of a Lowe edge pixel lies, to sub-pixel precision, and its contrast: the
// steepest of its 4-neighbour crossings, interpolated linearly.
void LoweEdgePoint(const cv::Mat& log, int x, int y, double contrast_per_slope,
                   Eigen::Vector2f* point, float* contrast) {
  const int w = log.cols, h = log.rows;
  const float l = log.at<float>(y, x);
  float best = -1;
  float t = 0;
  int dx = 0, dy = 0;
  for (const auto& [ox, oy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
    const int qx = x + ox, qy = y + oy;
    if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
    const float q = log.at<float>(qy, qx);
    if ((l >= 0) == (q >= 0)) continue;
    const float slope = std::abs(l - q);
    if (slope > best) {
      best = slope;
      t = l / (l - q);
      dx = ox;
      dy = oy;
    }
  }
  *point = Eigen::Vector2f(static_cast<float>(x) + t * static_cast<float>(dx),
                           static_cast<float>(y) + t * static_cast<float>(dy));
  *contrast = static_cast<float>(std::max(best, 0.f) * contrast_per_slope);
}

// Canny's edges (whole pixels) on the Gaussian-smoothed image.
void CannyEdges(const cv::Mat& blurred8, double low, double high, EdgeMap* e) {
  thread_local cv::Mat edges;
  cv::Canny(blurred8, edges, low, high, 3, true);
  e->Reset(edges.cols, edges.rows);
  for (int y = 0; y < edges.rows; ++y) {
    const std::uint8_t* row = edges.ptr<std::uint8_t>(y);
    int x = 0;
    // Edge pixels are few: skip eight bytes at a time where none is.
    for (; x + 8 <= edges.cols; x += 8) {
      std::uint64_t word;
      std::memcpy(&word, row + x, 8);
      if (!word) continue;
      for (int k = x; k < x + 8; ++k) {
        if (!row[k]) continue;
        const int i = e->Index(k, y);
        e->state[i] = EdgeMap::kKept;
        e->kept.push_back(i);
      }
    }
    for (; x < edges.cols; ++x) {
      if (!row[x]) continue;
      const int i = e->Index(x, y);
      e->state[i] = EdgeMap::kKept;
      e->kept.push_back(i);
    }
  }
}

// The Sobel gradient magnitude of an 8-bit image at (x, y), borders replicated: Canny's edge
// strength, at the few pixels that need it.
float SobelMagnitude(const cv::Mat& image, int x, int y) {
  auto at = [&](int u, int v) {
    return static_cast<float>(
        image.at<std::uint8_t>(std::clamp(v, 0, image.rows - 1), std::clamp(u, 0, image.cols - 1)));
  };
  const float gx = (at(x + 1, y - 1) + 2 * at(x + 1, y) + at(x + 1, y + 1)) -
                   (at(x - 1, y - 1) + 2 * at(x - 1, y) + at(x - 1, y + 1));
  const float gy = (at(x - 1, y + 1) + 2 * at(x, y + 1) + at(x + 1, y + 1)) -
                   (at(x - 1, y - 1) + 2 * at(x, y - 1) + at(x + 1, y - 1));
  return std::hypot(gx, gy);
}

// The kept edge pixels traced into chains of indices: from every end (a pixel with one kept
// neighbour) first, then whatever is left (closed contours), each continued both ways from
// where it starts. A chain ends where no unvisited neighbour is left, so junctions split.
std::vector<std::vector<int>> Link(EdgeMap* e) {
  const std::array<int, 8> nb = Neighbours(e->stride);
  std::uint8_t* state = e->state.data();
  auto next = [&](int i) {
    for (int d : nb) {
      if (state[i + d] == EdgeMap::kKept) return i + d;
    }
    return -1;
  };
  auto walk = [&](int from, std::vector<int>* out) {
    for (int i = next(from); i >= 0; i = next(i)) {
      state[i] = EdgeMap::kLinked;
      out->push_back(i);
    }
  };
  std::vector<std::vector<int>> chains;
  std::vector<int> backward;
  auto trace = [&](int start) {
    state[start] = EdgeMap::kLinked;
    std::vector<int> chain;
    backward.clear();
    walk(start, &backward);
    chain.assign(backward.rbegin(), backward.rend());
    chain.push_back(start);
    walk(start, &chain);
    chains.push_back(std::move(chain));
  };
  for (int i : e->kept) {
    if (state[i] != EdgeMap::kKept) continue;
    int count = 0;
    for (int d : nb) count += state[i + d] == EdgeMap::kKept || state[i + d] == EdgeMap::kLinked;
    if (count <= 1) trace(i);
  }
  for (int i : e->kept) {
    if (state[i] == EdgeMap::kKept) trace(i);
  }
  return chains;
}

struct Piece {
  int first, last;
};

// Lowe's subdivision of points [i, j]: appends the pieces of the subtree's most significant
// level to `out` and returns their best significance.
double Subdivide(const std::vector<Eigen::Vector2f>& p, int i, int j, double min_deviation,
                 int depth, std::vector<Piece>* out) {
  const Eigen::Vector2f chord = p[j] - p[i];
  const float length = chord.norm();
  int far = i;
  float deviation = 0;
  if (length > 0) {
    const Eigen::Vector2f normal(-chord.y() / length, chord.x() / length);
    for (int k = i + 1; k < j; ++k) {
      const float d = std::abs(normal.dot(p[k] - p[i]));
      if (d > deviation) {
        deviation = d;
        far = k;
      }
    }
  } else {
    for (int k = i + 1; k < j; ++k) {
      const float d = (p[k] - p[i]).norm();
      if (d > deviation) {
        deviation = d;
        far = k;
      }
    }
  }
  const double significance = length / std::max<double>(deviation, min_deviation);
  // Straight within the noise, or too short to split: a leaf. (A depth cap keeps the
  // recursion bounded on pathological chains.)
  if (deviation <= min_deviation || far <= i + 1 || far >= j - 1 || depth > 48) {
    out->push_back({i, j});
    return significance;
  }
  std::vector<Piece> children;
  const double left = Subdivide(p, i, far, min_deviation, depth + 1, &children);
  const double right = Subdivide(p, far, j, min_deviation, depth + 1, &children);
  const double best = std::max(left, right);
  if (best > significance) {
    out->insert(out->end(), children.begin(), children.end());
    return best;
  }
  out->push_back({i, j});
  return significance;
}

// The least-squares line through points [first, last], ended at their projections.
ImageSegment Fit(const std::vector<Eigen::Vector2f>& p, const std::vector<float>* contrast,
                 const Piece& piece) {
  const int n = piece.last - piece.first + 1;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (int k = piece.first; k <= piece.last; ++k) centre += p[k].cast<double>();
  centre /= n;
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (int k = piece.first; k <= piece.last; ++k) {
    const Eigen::Vector2d d = p[k].cast<double>() - centre;
    scatter += d * d.transpose();
  }
  Eigen::Vector2d direction = (p[piece.last] - p[piece.first]).cast<double>();
  if (n > 2) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
    direction = eigen.eigenvectors().col(1);
  }
  if (direction.norm() == 0) direction = Eigen::Vector2d::UnitX();
  direction.normalize();
  auto project = [&](const Eigen::Vector2f& q) {
    return (centre + direction * direction.dot(q.cast<double>() - centre)).cast<float>();
  };
  ImageSegment s;
  s.a = project(p[piece.first]);
  s.b = project(p[piece.last]);
  if (contrast) {
    double sum = 0;
    for (int k = piece.first; k <= piece.last; ++k) sum += (*contrast)[k];
    s.strength = static_cast<float>(sum / n);
  }
  return s;
}

void Check(const GrayView& image, const SegmentOptions& options) {
  if (!image.data || image.width <= 0 || image.height <= 0) {
    throw InputError(SourceLocation(), "the image is empty");
  }
  if (options.roi) {
    const PixelRect& r = *options.roi;
    if (r.width <= 0 || r.height <= 0 || r.x < 0 || r.y < 0 || r.x + r.width > image.width ||
        r.y + r.height > image.height) {
      throw InputError(
          SourceLocation(),
          "the region of interest " + std::to_string(r.x) + "," + std::to_string(r.y) + "," +
          std::to_string(r.width) + "," + std::to_string(r.height) + " is not inside the " +
          std::to_string(image.width) + " x " + std::to_string(image.height) + " image");
    }
  }
  // The detector's parameters are the caller's, not the user's data: a contract.
  CFUSE_CHECK_MSG(options.sigma > 0.3 && options.sigma < 20,
                  "the smoothing sigma is " + std::to_string(options.sigma));
  CFUSE_CHECK_MSG(options.low_contrast > 0 && options.high_contrast >= options.low_contrast,
                  "contrast thresholds " + std::to_string(options.low_contrast) + " and " +
                      std::to_string(options.high_contrast));
  CFUSE_CHECK_MSG(options.min_length >= 2,
                  "the shortest segment is " + std::to_string(options.min_length));
  CFUSE_CHECK(options.min_deviation > 0);
}

}  // namespace

float ImageSegment::Orientation() const {
  float angle = std::atan2(b.y() - a.y(), b.x() - a.x());
  if (angle < 0) angle += static_cast<float>(M_PI);
  if (angle >= static_cast<float>(M_PI)) angle -= static_cast<float>(M_PI);
  return angle;
}

const char* DetectorName(SegmentDetector detector) {
  switch (detector) {
    case SegmentDetector::kLowe:
      return "lowe";
    case SegmentDetector::kCanny:
      return "canny";
    case SegmentDetector::kLsd:
      return "lsd";
  }
  return "?";
}

std::optional<SegmentDetector> ParseDetector(const std::string& name) {
  for (SegmentDetector d :
       {SegmentDetector::kLowe, SegmentDetector::kCanny, SegmentDetector::kLsd}) {
    if (name == DetectorName(d)) return d;
  }
  return std::nullopt;
}

std::vector<ImageSegment> SubdivideChain(const std::vector<Eigen::Vector2f>& chain,
                                         double min_deviation, double min_length) {
  std::vector<ImageSegment> out;
  if (chain.size() < 2) return out;
  std::vector<Piece> pieces;
  Subdivide(chain, 0, static_cast<int>(chain.size()) - 1, min_deviation, 0, &pieces);
  for (const Piece& p : pieces) {
    ImageSegment s = Fit(chain, nullptr, p);
    if (s.Length() >= min_length) out.push_back(s);
  }
  return out;
}

std::vector<ImageSegment> DetectSegments(const GrayView& image, const SegmentOptions& options,
                                         StageTimes* times) {
  Check(image, options);
  StageTimes t;
  const cv::Mat whole(image.height, image.width, CV_8U, const_cast<std::uint8_t*>(image.data),
                      static_cast<size_t>(image.step));
  const PixelRect r = options.roi.value_or(PixelRect{0, 0, image.width, image.height});
  const cv::Mat view = whole(cv::Rect(r.x, r.y, r.width, r.height));
  const Eigen::Vector2f origin(static_cast<float>(r.x), static_cast<float>(r.y));
  std::vector<ImageSegment> out;

  if (options.detector == SegmentDetector::kLsd) {
    auto start = Clock::now();
    cv::Ptr<cv::LineSegmentDetector> lsd = cv::createLineSegmentDetector(cv::LSD_REFINE_STD);
    std::vector<cv::Vec4f> lines;
    std::vector<double> widths;
    lsd->detect(view, lines, widths);
    for (size_t i = 0; i < lines.size(); ++i) {
      ImageSegment s;
      s.a = Eigen::Vector2f(lines[i][0], lines[i][1]) + origin;
      s.b = Eigen::Vector2f(lines[i][2], lines[i][3]) + origin;
      s.strength = i < widths.size() ? static_cast<float>(widths[i]) : 0.f;
      if (s.Length() >= options.min_length) out.push_back(s);
    }
    t.edges = Ms(start, Clock::now());
    if (times) *times = t;
    return out;
  }

  const StepResponse unit = UnitStep(options.sigma);
  auto start = Clock::now();
  thread_local EdgeMap edges;  // reused: its maps are as large as the image
  cv::Mat log, blurred;
  const bool lowe = options.detector == SegmentDetector::kLowe;
  if (lowe) {
    log = LaplacianOfGaussian(view, options.sigma);
  } else {
    const int k = KernelSize(options.sigma);
    cv::GaussianBlur(view, blurred, cv::Size(k, k), options.sigma, options.sigma,
                     cv::BORDER_REPLICATE);
  }
  auto smoothed = Clock::now();
  t.smoothing = Ms(start, smoothed);
  if (lowe) {
    // Thresholds on the LoG's slope, from the contrasts.
    LoweEdges(log, static_cast<float>(options.low_contrast * unit.log_slope),
              static_cast<float>(options.high_contrast * unit.log_slope), &edges);
  } else {
    CannyEdges(blurred, options.low_contrast * unit.sobel, options.high_contrast * unit.sobel,
               &edges);
  }
  t.edges = Ms(smoothed, Clock::now());
  start = Clock::now();
  const std::vector<std::vector<int>> chains = Link(&edges);
  const auto linked = Clock::now();
  t.linking = Ms(start, linked);
  std::vector<Piece> pieces;
  std::vector<Eigen::Vector2f> points;
  std::vector<float> contrast;
  for (const std::vector<int>& chain : chains) {
    if (chain.size() < 2) continue;
    const int first_x = edges.X(chain.front()), first_y = edges.Y(chain.front());
    const int last_x = edges.X(chain.back()), last_y = edges.Y(chain.back());
    // No segment can come of a chain whose pixels all lie within min_length of its start.
    if (static_cast<double>(chain.size()) < options.min_length &&
        std::hypot(last_x - first_x, last_y - first_y) < options.min_length - 2) {
      continue;
    }
    points.resize(chain.size());
    contrast.resize(chain.size());
    for (size_t k = 0; k < chain.size(); ++k) {
      const int x = edges.X(chain[k]), y = edges.Y(chain[k]);
      if (lowe) {
        LoweEdgePoint(log, x, y, 1 / unit.log_slope, &points[k], &contrast[k]);
      } else {
        points[k] = Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y));
        contrast[k] = SobelMagnitude(blurred, x, y) / static_cast<float>(unit.sobel);
      }
    }
    pieces.clear();
    Subdivide(points, 0, static_cast<int>(points.size()) - 1, options.min_deviation, 0, &pieces);
    for (const Piece& p : pieces) {
      if ((points[p.last] - points[p.first]).norm() < options.min_length) continue;
      ImageSegment s = Fit(points, &contrast, p);
      if (s.Length() < options.min_length) continue;
      s.a += origin;
      s.b += origin;
      out.push_back(s);
    }
  }
  t.subdivision = Ms(linked, Clock::now());
  if (times) *times = t;
  return out;
}

}  // namespace cfuse
