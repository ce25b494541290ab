#include "cfuse/vision/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <stdexcept>

#include "render_internal.h"

namespace cfuse {
namespace {

using internal::kFaceStride;
using internal::kOccluder;

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

// The plain style (render.h).
Rendering RenderPlain(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                      const RenderOptions& options) {
  const int w = camera.width, h = camera.height;
  std::mt19937 rng(options.seed);
  cv::Mat1b image(h, w, static_cast<std::uint8_t>(std::uniform_int_distribution<int>(30, 90)(rng)));
  internal::DrawClutter(image, options.clutter_lines, options.clutter_blobs, rng);

  cv::Mat1f depth(h, w, std::numeric_limits<float>::infinity());
  cv::Mat1i face(h, w, -1);
  const internal::RayCaster rays{camera};
  const Eigen::Vector3d light = Eigen::Vector3d(-0.5, -0.7, -1).normalized();
  constexpr int kBase[] = {150, 195, 235, 125, 170, 215};
  std::vector<std::vector<int>> classes(graph.components.size());
  for (size_t ci = 0; ci < graph.components.size(); ++ci) {
    if (graph.components[ci].rigid) classes[ci] = FaceClasses(graph.components[ci]);
  }
  for (const internal::ViewedFace& f : internal::FrontFaces(graph, values, camera)) {
    const double lambert = std::max(0.0, f.normal.dot(light));
    const int shade = std::min(
        250, kBase[classes[f.component][f.face] % 6] + static_cast<int>(std::lround(15 * lambert)));
    const int id = f.component * kFaceStride + f.face;
    internal::ForEachSpan(f.polygon, w, h, [&](int v, int u0, int u1) {
      float* z = depth.ptr<float>(v);
      int* ids = face.ptr<int>(v);
      std::uint8_t* out = image.ptr<std::uint8_t>(v);
      for (int u = u0; u < u1; ++u) {
        const double d = rays.DepthOnPlane(u, v, f.normal, f.corners[0]);
        if (!(d < z[u])) continue;
        z[u] = static_cast<float>(d);
        ids[u] = id;
        out[u] = static_cast<std::uint8_t>(shade);
      }
    });
  }

  // Hands, then occluders, in front of everything: nearest of all, and no face of the model.
  for (const HandOccluder& hand : options.hands) {
    internal::ForEachHandPixel(hand, w, h, [&](int u, int v, float coverage, float shade) {
      const float skin = static_cast<float>(internal::kWhite * internal::kSkinAlbedo) * shade;
      image(v, u) = cv::saturate_cast<std::uint8_t>(image(v, u) + coverage * (skin - image(v, u)));
      if (coverage >= 0.5f) {
        depth(v, u) = 0;
        face(v, u) = kOccluder;
      }
    });
  }
  for (const std::vector<Eigen::Vector2d>& polygon : options.occluders) {
    if (polygon.size() < 3) continue;
    cv::Mat1b mask(h, w, static_cast<std::uint8_t>(0));
    internal::FillPixelCentres(polygon, mask);
    image.setTo(options.occluder_grey, mask);
    depth.setTo(0, mask);
    face.setTo(kOccluder, mask);
  }

  // The truth's contrast: the clean image 2 px either side of the edge (render.h).
  Rendering out;
  out.width = w;
  out.height = h;
  out.truth = internal::VisibleTruth(
      graph, values, camera, depth, face,
      [&](const Eigen::Vector2d& uv, const Eigen::Vector2d& normal) {
        const Eigen::Vector2d p1 = uv + 2 * normal, p2 = uv - 2 * normal;
        const int u1 = static_cast<int>(std::lround(p1.x())),
                  v1 = static_cast<int>(std::lround(p1.y()));
        const int u2 = static_cast<int>(std::lround(p2.x())),
                  v2 = static_cast<int>(std::lround(p2.y()));
        return u1 >= 0 && v1 >= 0 && u1 < w && v1 < h && u2 >= 0 && v2 >= 0 && u2 < w && v2 < h &&
               std::abs(image(v1, u1) - image(v2, u2)) < options.min_contrast;
      });

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

}  // namespace

std::optional<RenderStyle> ParseRenderStyle(const std::string& name) {
  if (name == "plain") return RenderStyle::kPlain;
  if (name == "realistic") return RenderStyle::kRealistic;
  return std::nullopt;
}

const char* RenderStyleName(RenderStyle style) {
  return style == RenderStyle::kRealistic ? "realistic" : "plain";
}

Rendering Render(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                 const RenderOptions& options) {
  internal::CheckRenderable(camera);
  return options.style == RenderStyle::kRealistic
             ? internal::RenderRealistic(graph, values, camera, options)
             : RenderPlain(graph, values, camera, options);
}

std::vector<std::uint8_t> EncodePng(const std::vector<std::uint8_t>& pixels, int width,
                                    int height) {
  const cv::Mat image(height, width, CV_8U, const_cast<std::uint8_t*>(pixels.data()));
  std::vector<std::uint8_t> bytes;
  cv::imencode(".png", image, bytes);
  return bytes;
}

}  // namespace cfuse
