#include "render_internal.h"

#include <opencv2/imgproc.hpp>
#include <string>

#include "cfuse/kernel/error.h"

namespace cfuse::internal {

void CheckRenderable(const Camera& camera) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw InputError(SourceLocation(), "the camera has no image size (width and height)");
  }
  // A camera file may give up to 10^6 x 10^6 pixels; refused here rather than failing to
  // allocate the image (and its face buffer), which would be reported as an internal error.
  constexpr long long kMaxPixels = 1ll << 28;
  if (static_cast<long long>(camera.width) * camera.height > kMaxPixels) {
    throw InputError(SourceLocation(),
                     "the camera's image, " + std::to_string(camera.width) + " x " +
                         std::to_string(camera.height) +
                         " pixels, is larger than the renderer's limit of 2^28 pixels");
  }
  if (camera.model == Camera::Model::kPinhole &&
      std::any_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double d) { return d != 0; })) {
    throw InputError(SourceLocation(),
                     "the renderer draws undistorted images: give a camera without distortion");
  }
}

void FillPixelCentres(const std::vector<Eigen::Vector2d>& polygon, cv::Mat1b& mask) {
  ForEachSpan(polygon, mask.cols, mask.rows, [&](int v, int u0, int u1) {
    std::uint8_t* row = mask.ptr<std::uint8_t>(v);
    for (int u = u0; u < u1; ++u) row[u] = 255;
  });
}

std::vector<ViewedFace> FrontFaces(const ConstraintGraph& graph, const Values& values,
                                   const Camera& camera) {
  std::vector<ViewedFace> out;
  for (size_t ci = 0; ci < graph.components.size(); ++ci) {
    const Component& c = graph.components[ci];
    if (!c.rigid) continue;
    const Rigid3d& pose = values.poses[graph.blocks[c.block].index];
    for (size_t f = 0; f < c.faces.size(); ++f) {
      if (!FrontFacing(graph, static_cast<int>(ci), static_cast<int>(f), values, camera)) continue;
      ViewedFace viewed;
      viewed.component = static_cast<int>(ci);
      viewed.face = static_cast<int>(f);
      bool behind = false;
      for (int k : c.faces[f].loop) {
        const Eigen::Vector3d p = pose * c.points[k].position;
        behind = behind || (camera.model == Camera::Model::kPinhole && p.z() < kNearPlane);
        viewed.corners.push_back(p);
        viewed.polygon.push_back(camera.Project<double>(p));
      }
      if (behind || viewed.corners.size() < 3) continue;  // a face crossing the camera plane
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < viewed.corners.size(); ++k) {
        normal += viewed.corners[k].cross(viewed.corners[(k + 1) % viewed.corners.size()]);
      }
      if (normal.norm() == 0) continue;
      viewed.normal = normal.normalized();
      out.push_back(std::move(viewed));
    }
  }
  return out;
}

void DrawClutter(cv::Mat1b& image, int lines, int blobs, std::mt19937& rng, cv::Point offset) {
  const int w = image.cols, h = image.rows;
  std::uniform_int_distribution<int> dark(20, 110), x_of(-w / 4, w + w / 4),
      y_of(-h / 4, h + h / 4), thickness(1, 3), radius(4, std::max(5, std::min(w, h) / 12));
  for (int i = 0; i < blobs; ++i) {
    cv::ellipse(image, cv::Point(x_of(rng), y_of(rng)) + offset, cv::Size(radius(rng), radius(rng)),
                std::uniform_real_distribution<double>(0, 180)(rng), 0, 360, cv::Scalar(dark(rng)),
                cv::FILLED, cv::LINE_AA);
  }
  for (int i = 0; i < lines; ++i) {
    cv::line(image, cv::Point(x_of(rng), y_of(rng)) + offset,
             cv::Point(x_of(rng), y_of(rng)) + offset, cv::Scalar(dark(rng)), thickness(rng),
             cv::LINE_AA);
  }
}

namespace {

// A rounded limb: the points within `radius` of the segment a-b.
struct Capsule {
  Eigen::Vector2d a, b;
  double radius;
};

// The hand's limbs (render.h HandOccluder), the forearm reaching `reach` px from the palm.
std::vector<Capsule> HandCapsules(const HandOccluder& hand, double reach) {
  const double w = hand.width;
  const Eigen::Vector2d arm(std::cos(hand.arm_angle), std::sin(hand.arm_angle));
  const Eigen::Vector2d across(-arm.y(), arm.x());
  const Eigen::Vector2d& palm = hand.palm;
  std::vector<Capsule> limbs = {
      {palm + 0.4 * w * arm, palm + reach * arm, 0.42 * w},  // forearm
      {palm + 0.15 * w * arm, palm - 0.2 * w * arm, 0.5 * w},
  };
  constexpr double kOffset[] = {-0.33, -0.11, 0.11, 0.33};
  constexpr double kLength[] = {0.5, 0.66, 0.62, 0.48};
  constexpr double kSpread[] = {-0.12, -0.04, 0.04, 0.12};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d base = palm - 0.45 * w * arm + kOffset[k] * w * across;
    const Eigen::Vector2d along = -std::cos(kSpread[k]) * arm + std::sin(kSpread[k]) * across;
    limbs.push_back({base, base + kLength[k] * w * along, 0.1 * w});
  }
  // The thumb from the heel of the palm, 35 degrees out from the fingers.
  const Eigen::Vector2d thumb = palm + 0.15 * w * arm + 0.36 * w * across;
  limbs.push_back({thumb, thumb + 0.58 * w * (0.57 * across - 0.82 * arm), 0.13 * w});
  return limbs;
}

// Smooth noise in [-1, 1] on a grid of `cell` pixels (skin's mottling).
double ValueNoise(double x, double y, double cell) {
  auto hash = [](int i, int j) {
    std::uint32_t h =
        static_cast<std::uint32_t>(i) * 73856093u ^ static_cast<std::uint32_t>(j) * 19349663u;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (h & 0xffff) / 32767.5 - 1;
  };
  x /= cell;
  y /= cell;
  const int i = static_cast<int>(std::floor(x)), j = static_cast<int>(std::floor(y));
  const double fx = x - i, fy = y - j;
  const double sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
  return (1 - sy) * ((1 - sx) * hash(i, j) + sx * hash(i + 1, j)) +
         sy * ((1 - sx) * hash(i, j + 1) + sx * hash(i + 1, j + 1));
}

}  // namespace

void ForEachHandPixel(const HandOccluder& hand, int width, int height,
                      const std::function<void(int u, int v, float coverage, float shade)>& paint) {
  if (!(hand.width > 0) || !hand.palm.allFinite() || !std::isfinite(hand.arm_angle)) return;
  const std::vector<Capsule> limbs = HandCapsules(hand, 2.0 * std::hypot(width, height));
  // Each pixel takes the limb that stands highest there (a limb is a cylinder of its radius
  // lying on the image: the palm over a finger where they meet), and its shade from that limb's
  // normal.
  const cv::Rect image(0, 0, width, height);
  cv::Rect all;
  std::vector<cv::Rect> boxes;
  for (const Capsule& c : limbs) {
    const double r = c.radius + 1;
    const cv::Point lo(static_cast<int>(std::floor(std::min(c.a.x(), c.b.x()) - r)),
                       static_cast<int>(std::floor(std::min(c.a.y(), c.b.y()) - r)));
    const cv::Point hi(static_cast<int>(std::ceil(std::max(c.a.x(), c.b.x()) + r)),
                       static_cast<int>(std::ceil(std::max(c.a.y(), c.b.y()) + r)));
    boxes.push_back(cv::Rect(lo, hi) & image);
    all |= boxes.back();
  }
  if (all.empty()) return;
  cv::Mat1f top(all.size(), -1.f), outside(all.size(), 1e9f), nx(all.size(), 0.f),
      ny(all.size(), 0.f);
  for (size_t k = 0; k < limbs.size(); ++k) {
    const Capsule& c = limbs[k];
    const Eigen::Vector2d axis = c.b - c.a;
    const double length2 = std::max(axis.squaredNorm(), 1e-12);
    for (int v = boxes[k].y; v < boxes[k].y + boxes[k].height; ++v) {
      for (int u = boxes[k].x; u < boxes[k].x + boxes[k].width; ++u) {
        const Eigen::Vector2d p(u, v);
        const double along = std::clamp((p - c.a).dot(axis) / length2, 0.0, 1.0);
        const Eigen::Vector2d off = p - (c.a + along * axis);
        const double d = off.norm();
        const int i = v - all.y, j = u - all.x;
        outside(i, j) = std::min(outside(i, j), static_cast<float>(d - c.radius));
        const double x = std::min(1.0, d / c.radius);
        const float rise = static_cast<float>(c.radius * std::sqrt(1 - x * x));
        if (rise > top(i, j)) {
          top(i, j) = rise;
          nx(i, j) = static_cast<float>(off.x() / c.radius);
          ny(i, j) = static_cast<float>(off.y() / c.radius);
        }
      }
    }
  }
  const Eigen::Vector3d light = Eigen::Vector3d(-0.45, -0.55, 0.7).normalized();
  for (int i = 0; i < all.height; ++i) {
    for (int j = 0; j < all.width; ++j) {
      const float coverage = std::clamp(0.5f - outside(i, j), 0.f, 1.f);
      if (coverage <= 0) continue;
      const double x = std::min<double>(nx(i, j), 1), y = std::min<double>(ny(i, j), 1);
      const Eigen::Vector3d normal(x, y, std::sqrt(std::max(0.0, 1 - x * x - y * y)));
      const int u = all.x + j, v = all.y + i;
      const double mottle = 1 + 0.05 * ValueNoise(u, v, 7) + 0.03 * ValueNoise(u, v, 2.5);
      const double shade = (0.3 + 0.75 * std::max(0.0, normal.dot(light))) * mottle;
      paint(u, v, coverage, static_cast<float>(shade));
    }
  }
}

std::vector<TruthSegment> VisibleTruth(
    const ConstraintGraph& graph, const Values& values, const Camera& camera,
    const cv::Mat1f& depth, const cv::Mat1i& face,
    const std::function<bool(const Eigen::Vector2d& uv, const Eigen::Vector2d& normal)>& flat) {
  // A sample is in front where its pixel shows one of the edge's own faces, the background, or a
  // face no nearer than it (by the depth one pixel spans at a slant of 70 degrees: the pixel
  // centre lies up to 0.7 px off the edge). And it shows where the image has a contrast across
  // it (`flat` false): two faces of one shade meeting (a lid lying on its box at the same grey)
  // make no edge.
  const int w = depth.cols, h = depth.rows;
  std::vector<TruthSegment> out;
  const std::vector<ModelEdge> edges = ModelEdges(graph);
  for (const ProjectedEdge& e : VisibleEdges(graph, edges, values, camera)) {
    const double length = (e.b - e.a).norm();
    const int n = std::max(2, static_cast<int>(std::ceil(2 * length)) + 1);
    int run_start = -1;
    auto close_run = [&](int last) {
      if (run_start < 0) return;
      const double t0 = static_cast<double>(run_start) / (n - 1);
      const double t1 = static_cast<double>(last) / (n - 1);
      const Eigen::Vector2d a = e.a + t0 * (e.b - e.a), b = e.a + t1 * (e.b - e.a);
      if ((b - a).norm() >= 2) out.push_back({e.edge, a, b});
      run_start = -1;
    };
    const Eigen::Vector2d normal =
        length > 0 ? Eigen::Vector2d(Eigen::Vector2d(-(e.b - e.a).y(), (e.b - e.a).x()) / length)
                   : Eigen::Vector2d(Eigen::Vector2d::UnitX());
    for (int k = 0; k < n; ++k) {
      const double t = static_cast<double>(k) / (n - 1);
      const Eigen::Vector3d P = e.A + t * (e.B - e.A);
      const Eigen::Vector2d uv = e.a + t * (e.b - e.a);
      const int u = static_cast<int>(std::lround(uv.x())),
                v = static_cast<int>(std::lround(uv.y()));
      bool visible = true;
      if (flat(uv, normal)) {
        visible = false;
      } else if (u >= 0 && v >= 0 && u < w && v < h) {
        const int id = face(v, u);
        const ModelEdge& me = edges[e.edge];
        const bool own =
            id >= 0 && id / kFaceStride == me.component &&
            std::find(me.faces.begin(), me.faces.end(), id % kFaceStride) != me.faces.end();
        const double pixel = camera.model == Camera::Model::kOrthographic
                                 ? 1 / camera.scale
                                 : std::abs(P.z()) / camera.fx;
        visible = own || id == -1 || depth(v, u) >= P.z() - 3 * pixel;
      }
      if (visible && run_start < 0) run_start = k;
      if (!visible) close_run(k - 1);
    }
    close_run(n - 1);
  }
  return out;
}

}  // namespace cfuse::internal
