#include "vision/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <stdexcept>

namespace cfuse::vision {
namespace {

constexpr double kNearPlane = 1e-3;
constexpr int kFaceStride = 1 << 16;
constexpr int kOccluder = -2;  // in the face buffer (-1: background)

// Face albedo classes by greedy colouring of the faces' adjacency (faces sharing a side get
// different classes; three suffice for boxes and most polyhedra, more are used if needed).
std::vector<int> FaceClasses(const Component& c) {
  std::map<std::pair<int, int>, std::vector<int>> sides;
  for (size_t f = 0; f < c.faces.size(); ++f) {
    const std::vector<int>& loop = c.faces[f].loop;
    for (size_t k = 0; k < loop.size(); ++k) {
      const int a = loop[k], b = loop[(k + 1) % loop.size()];
      sides[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(f));
    }
  }
  std::vector<std::set<int>> neighbours(c.faces.size());
  for (const auto& [side, faces] : sides) {
    for (int f : faces) {
      for (int g : faces) {
        if (f != g) neighbours[f].insert(g);
      }
    }
  }
  std::vector<int> cls(c.faces.size(), -1);
  for (size_t f = 0; f < c.faces.size(); ++f) {
    int k = 0;
    while (std::any_of(neighbours[f].begin(), neighbours[f].end(),
                       [&](int g) { return cls[g] == k; })) {
      ++k;
    }
    cls[f] = k;
  }
  return cls;
}

// Sets the pixels whose centre lies inside `polygon` (even-odd rule, half-open on the right and
// bottom so faces sharing a side split its pixels). cv::fillPoly also sets every pixel the
// outline touches, which grows each face by about 0.6 px all round and biases anything fitted
// to the rendered edges (depth, for a box seen in full, by several millimetres).
void FillPixelCentres(const std::vector<Eigen::Vector2d>& polygon, cv::Mat1b& mask) {
  double top = std::numeric_limits<double>::infinity(), bottom = -top;
  for (const Eigen::Vector2d& p : polygon) {
    top = std::min(top, p.y());
    bottom = std::max(bottom, p.y());
  }
  if (!std::isfinite(top) || !std::isfinite(bottom)) return;
  const int v0 = static_cast<int>(std::ceil(std::clamp(top, 0.0, double(mask.rows))));
  const int v1 = static_cast<int>(std::ceil(std::clamp(bottom, 0.0, double(mask.rows)))) - 1;
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
    std::uint8_t* row = mask.ptr<std::uint8_t>(v);
    for (size_t k = 0; k + 1 < crossings.size(); k += 2) {
      const double cols = mask.cols;
      const int u0 = static_cast<int>(std::ceil(std::clamp(crossings[k], 0.0, cols)));
      const int u1 = static_cast<int>(std::ceil(std::clamp(crossings[k + 1], 0.0, cols)));
      for (int u = u0; u < u1; ++u) row[u] = 255;
    }
  }
}

struct Scene {
  const Camera& camera;
  cv::Mat1f depth;  // z of the nearest face per pixel, +inf where none
  cv::Mat1i face;   // that face, as component * kFaceStride + face, or -1

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

}  // namespace

Rendering Render(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                 const RenderOptions& options) {
  if (camera.width <= 0 || camera.height <= 0) {
    throw std::invalid_argument("the camera has no image size (width and height)");
  }
  // A camera file may give up to 10^6 x 10^6 pixels; refused here rather than failing to
  // allocate the image (and its face buffer), which would be reported as an internal error.
  constexpr long long kMaxPixels = 1ll << 28;
  if (static_cast<long long>(camera.width) * camera.height > kMaxPixels) {
    throw std::invalid_argument("the camera's image, " + std::to_string(camera.width) + " x " +
                                std::to_string(camera.height) +
                                " pixels, is larger than the renderer's limit of 2^28 pixels");
  }
  if (camera.model == Camera::Model::kPinhole &&
      std::any_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double d) { return d != 0; })) {
    throw std::invalid_argument(
        "the renderer draws undistorted images: give a camera without distortion");
  }
  const int w = camera.width, h = camera.height;
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> dark(20, 110), x_of(-w / 4, w + w / 4),
      y_of(-h / 4, h + h / 4), thickness(1, 3), radius(4, std::max(5, std::min(w, h) / 12));
  cv::Mat1b image(h, w, static_cast<std::uint8_t>(std::uniform_int_distribution<int>(30, 90)(rng)));
  for (int i = 0; i < options.clutter_blobs; ++i) {
    cv::ellipse(image, cv::Point(x_of(rng), y_of(rng)), cv::Size(radius(rng), radius(rng)),
                std::uniform_real_distribution<double>(0, 180)(rng), 0, 360, cv::Scalar(dark(rng)),
                cv::FILLED, cv::LINE_AA);
  }
  for (int i = 0; i < options.clutter_lines; ++i) {
    cv::line(image, cv::Point(x_of(rng), y_of(rng)), cv::Point(x_of(rng), y_of(rng)),
             cv::Scalar(dark(rng)), thickness(rng), cv::LINE_AA);
  }

  Scene scene{camera, cv::Mat1f(h, w, std::numeric_limits<float>::infinity()), cv::Mat1i(h, w, -1)};
  const Eigen::Vector3d light = Eigen::Vector3d(-0.5, -0.7, -1).normalized();
  constexpr int kBase[] = {150, 195, 235, 125, 170, 215};
  for (size_t ci = 0; ci < graph.components.size(); ++ci) {
    const Component& c = graph.components[ci];
    if (!c.rigid) continue;
    const Rigid3d& pose = values.poses[graph.blocks[c.block].index];
    const std::vector<int> classes = FaceClasses(c);
    for (size_t f = 0; f < c.faces.size(); ++f) {
      if (!FrontFacing(graph, static_cast<int>(ci), static_cast<int>(f), values, camera)) continue;
      std::vector<Eigen::Vector3d> corners;
      std::vector<Eigen::Vector2d> polygon;
      bool behind = false;
      for (int k : c.faces[f].loop) {
        const Eigen::Vector3d p = pose * c.points[k].position;
        behind = behind || (camera.model == Camera::Model::kPinhole && p.z() < kNearPlane);
        corners.push_back(p);
        const Eigen::Vector2d uv = camera.Project<double>(p);
        polygon.push_back(uv);
      }
      if (behind || corners.size() < 3) continue;  // a face crossing the camera plane
      Eigen::Vector3d normal = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < corners.size(); ++k) {
        normal += corners[k].cross(corners[(k + 1) % corners.size()]);
      }
      if (normal.norm() == 0) continue;
      normal.normalize();
      const double lambert = std::max(0.0, normal.dot(light));
      const int shade =
          std::min(250, kBase[classes[f] % 6] + static_cast<int>(std::lround(15 * lambert)));
      cv::Mat1b mask(h, w, static_cast<std::uint8_t>(0));
      FillPixelCentres(polygon, mask);
      const cv::Rect box = cv::boundingRect(mask);
      for (int v = box.y; v < box.y + box.height; ++v) {
        const std::uint8_t* m = mask.ptr<std::uint8_t>(v);
        float* z = scene.depth.ptr<float>(v);
        int* id = scene.face.ptr<int>(v);
        std::uint8_t* out = image.ptr<std::uint8_t>(v);
        for (int u = box.x; u < box.x + box.width; ++u) {
          if (!m[u]) continue;
          const double d = scene.DepthOnPlane(u, v, normal, corners[0]);
          if (!(d < z[u])) continue;
          z[u] = static_cast<float>(d);
          id[u] = static_cast<int>(ci) * kFaceStride + static_cast<int>(f);
          out[u] = static_cast<std::uint8_t>(shade);
        }
      }
    }
  }

  // Occluders in front of everything: nearest of all, and no face of the model.
  for (const std::vector<Eigen::Vector2d>& polygon : options.occluders) {
    if (polygon.size() < 3) continue;
    cv::Mat1b mask(h, w, static_cast<std::uint8_t>(0));
    FillPixelCentres(polygon, mask);
    image.setTo(options.occluder_grey, mask);
    scene.depth.setTo(0, mask);
    scene.face.setTo(kOccluder, mask);
  }

  // The truth: visible edges sampled against the buffers. A sample is in front where its pixel
  // shows one of the edge's own faces, the background, or a face no nearer than it (by the depth
  // one pixel spans at a slant of 70 degrees: the pixel centre lies up to 0.7 px off the edge). And
  // it shows where the clean image differs by `min_contrast` 2 px either side of it: two faces of
  // one shade meeting (a lid lying on its box at the same grey) make no edge.
  Rendering out;
  out.width = w;
  out.height = h;
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
      if ((b - a).norm() >= 2) out.truth.push_back({e.edge, a, b});
      run_start = -1;
    };
    for (int k = 0; k < n; ++k) {
      const double t = static_cast<double>(k) / (n - 1);
      const Eigen::Vector3d P = e.A + t * (e.B - e.A);
      const Eigen::Vector2d uv = e.a + t * (e.b - e.a);
      const int u = static_cast<int>(std::lround(uv.x())),
                v = static_cast<int>(std::lround(uv.y()));
      bool visible = true;
      const Eigen::Vector2d normal =
          length > 0 ? Eigen::Vector2d(Eigen::Vector2d(-(e.b - e.a).y(), (e.b - e.a).x()) / length)
                     : Eigen::Vector2d(Eigen::Vector2d::UnitX());
      const Eigen::Vector2d p1 = uv + 2 * normal, p2 = uv - 2 * normal;
      const int u1 = static_cast<int>(std::lround(p1.x())),
                v1 = static_cast<int>(std::lround(p1.y()));
      const int u2 = static_cast<int>(std::lround(p2.x())),
                v2 = static_cast<int>(std::lround(p2.y()));
      if (u1 >= 0 && v1 >= 0 && u1 < w && v1 < h && u2 >= 0 && v2 >= 0 && u2 < w && v2 < h &&
          std::abs(image(v1, u1) - image(v2, u2)) < options.min_contrast) {
        visible = false;
      } else if (u >= 0 && v >= 0 && u < w && v < h) {
        const int id = scene.face(v, u);
        const ModelEdge& me = edges[e.edge];
        const bool own =
            id >= 0 && id / kFaceStride == me.component &&
            std::find(me.faces.begin(), me.faces.end(), id % kFaceStride) != me.faces.end();
        const double pixel = camera.model == Camera::Model::kOrthographic
                                 ? 1 / camera.scale
                                 : std::abs(P.z()) / camera.fx;
        visible = own || id == -1 || scene.depth(v, u) >= P.z() - 3 * pixel;
      }
      if (visible && run_start < 0) run_start = k;
      if (!visible) close_run(k - 1);
    }
    close_run(n - 1);
  }

  if (options.blur > 0) {
    cv::GaussianBlur(image, image, cv::Size(0, 0), options.blur, options.blur,
                     cv::BORDER_REPLICATE);
  }
  if (options.noise > 0) {
    cv::Mat1f noise(h, w);
    cv::RNG cv_rng(options.seed * 7919u + 17u);
    cv_rng.fill(noise, cv::RNG::NORMAL, 0, options.noise);
    cv::Mat1f sum;
    image.convertTo(sum, CV_32F);
    sum += noise;
    sum.convertTo(image, CV_8U);
  }
  out.pixels.assign(image.begin(), image.end());
  return out;
}

std::vector<std::uint8_t> EncodePng(const std::vector<std::uint8_t>& pixels, int width,
                                    int height) {
  const cv::Mat image(height, width, CV_8U, const_cast<std::uint8_t*>(pixels.data()));
  std::vector<std::uint8_t> bytes;
  cv::imencode(".png", image, bytes);
  return bytes;
}

}  // namespace cfuse::vision
