#include "cfuse/vision/texture.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kMaxPhotographBytes = 512ull << 20;
constexpr int kMinPhotographSide = 32;

bool IsImageFile(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* known :
       {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".pnm", ".bmp", ".tif", ".tiff"}) {
    if (ext == known) return true;
  }
  return false;
}

GrayImage ReadPhotograph(const std::string& path) {
  const SourceLocation where(path);
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError(where, "cannot open: " + ec.message());
  if (size > kMaxPhotographBytes) {
    throw InputError(where, fmt::format("the file is larger than the {} MiB limit for images",
                                        kMaxPhotographBytes >> 20));
  }
  // Said here: cv::imread returns an empty image for a file it may not read, as for a damaged one.
  if (!std::ifstream(path, std::ios::binary)) throw InputError(where, "cannot open the file");
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw InputError(where, fmt::format("cannot read the image: {}", e.err));
  }
  if (image.empty()) {
    throw InputError(where, "cannot read the image: not in a format OpenCV reads or damaged");
  }
  if (image.cols < kMinPhotographSide || image.rows < kMinPhotographSide) {
    throw InputError(where,
                     fmt::format("the image is {} x {} pixels: a photograph to texture "
                                 "from must be at least {} x {}",
                                 image.cols, image.rows, kMinPhotographSide, kMinPhotographSide));
  }
  GrayImage out;
  out.width = image.cols;
  out.height = image.rows;
  out.pixels.resize(static_cast<size_t>(image.cols) * image.rows);
  for (int v = 0; v < image.rows; ++v) {
    std::copy_n(image.ptr<std::uint8_t>(v), image.cols, out.pixels.data() + size_t(v) * image.cols);
  }
  return out;
}

// A seed for face `face` of component `component`: faces draw independently, and the same
// face draws the same texture whatever else the model holds.
unsigned FaceSeed(unsigned seed, int component, int face) {
  std::uint64_t x = seed * 0x9E3779B97F4A7C15ull +
                    static_cast<std::uint64_t>(component) * 1000003u +
                    static_cast<std::uint64_t>(face) * 7919u + 1;
  x ^= x >> 30;
  x *= 0xBF58476D1CE4E5B9ull;
  x ^= x >> 27;
  x *= 0x94D049BB133111EBull;
  x ^= x >> 31;
  return static_cast<unsigned>(x);
}

double Bilinear(const GrayImage& photo, double x, double y) {
  x = std::clamp(x, 0.0, photo.width - 1.0);
  y = std::clamp(y, 0.0, photo.height - 1.0);
  const int x0 = std::min(static_cast<int>(x), photo.width - 2);
  const int y0 = std::min(static_cast<int>(y), photo.height - 2);
  const double fx = x - x0, fy = y - y0;
  const std::uint8_t* p = photo.pixels.data() + static_cast<size_t>(y0) * photo.width + x0;
  return (1 - fy) * ((1 - fx) * p[0] + fx * p[1]) +
         fy * ((1 - fx) * p[photo.width] + fx * p[photo.width + 1]);
}

// One card of ProceduralPhotographs.
GrayImage PrintedCard(std::mt19937& rng) {
  constexpr int kSide = 512;
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  auto integer = [&](int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng); };
  const bool light = uniform(0, 1) < 0.7;
  const int ground = light ? integer(190, 240) : integer(25, 70);
  // Ink contrasts with the ground: dark on light card, light on dark.
  auto ink = [&] { return light ? integer(10, 120) : integer(150, 245); };
  cv::Mat1b card(kSide, kSide, static_cast<std::uint8_t>(ground));
  for (int i = integer(2, 5); i > 0; --i) {
    const cv::Point a(integer(-64, kSide), integer(-64, kSide));
    const cv::Point b = a + cv::Point(integer(60, 300), integer(40, 220));
    cv::rectangle(card, a, b, cv::Scalar(uniform(0, 1) < 0.5 ? ink() : integer(60, 200)),
                  cv::FILLED, cv::LINE_AA);
  }
  if (uniform(0, 1) < 0.6) {
    cv::circle(card, cv::Point(integer(0, kSide), integer(0, kSide)), integer(30, 120),
               cv::Scalar(ink()), cv::FILLED, cv::LINE_AA);
  }
  static constexpr char kLetters[] = "ABCDEFGHIJKLMNOPRSTUVWXYZ0123456789 -";
  static constexpr int kFonts[] = {cv::FONT_HERSHEY_SIMPLEX, cv::FONT_HERSHEY_DUPLEX,
                                   cv::FONT_HERSHEY_TRIPLEX, cv::FONT_HERSHEY_COMPLEX};
  for (int i = integer(3, 7); i > 0; --i) {
    std::string text;
    for (int k = integer(3, 14); k > 0; --k) text += kLetters[integer(0, sizeof(kLetters) - 2)];
    const double scale = uniform(0, 1) < 0.3 ? uniform(1.8, 3.5) : uniform(0.6, 1.6);
    cv::putText(card, text, cv::Point(integer(-40, kSide - 80), integer(30, kSide)),
                kFonts[integer(0, 3)], scale, cv::Scalar(ink()),
                std::max(1, static_cast<int>(std::lround(scale * uniform(1.0, 2.5)))), cv::LINE_AA);
  }
  for (int i = integer(1, 3); i > 0; --i) {
    const int y = integer(0, kSide);
    cv::line(card, cv::Point(integer(-50, 200), y), cv::Point(integer(300, kSide + 50), y),
             cv::Scalar(ink()), integer(2, 6), cv::LINE_AA);
  }
  cv::Mat1s grain(kSide, kSide);
  cv::RNG grain_rng(rng());  // not cv::randn: OpenCV's global generator would make cards differ
  grain_rng.fill(grain, cv::RNG::NORMAL, 0, 3);
  cv::Mat1s sum;
  card.convertTo(sum, CV_16S);
  sum += grain;
  sum.convertTo(card, CV_8U);
  GrayImage out;
  out.width = out.height = kSide;
  out.pixels.assign(card.begin(), card.end());
  return out;
}

}  // namespace

std::vector<GrayImage> LoadPhotographs(const std::vector<std::string>& paths) {
  std::vector<GrayImage> out;
  for (const std::string& path : paths) {
    std::error_code ec;
    if (!fs::exists(path, ec)) throw InputError(SourceLocation(path), "cannot open: no such file");
    if (!fs::is_directory(path, ec)) {
      out.push_back(ReadPhotograph(path));
      continue;
    }
    std::vector<std::string> files;
    for (const fs::directory_entry& entry : fs::directory_iterator(path, ec)) {
      if (entry.is_regular_file(ec) && IsImageFile(entry.path())) {
        files.push_back(entry.path().string());
      }
    }
    if (ec) throw InputError(SourceLocation(path), "cannot list the directory: " + ec.message());
    if (files.empty()) {
      throw InputError(SourceLocation(path),
                       "the directory holds no images (.png, .jpg, .pgm, .ppm, .bmp, .tif, ...)");
    }
    std::sort(files.begin(), files.end());
    for (const std::string& file : files) out.push_back(ReadPhotograph(file));
  }
  return out;
}

std::vector<std::string> VispPhotographPaths(const std::string& root) {
  static constexpr const char* kPhotographs[] = {
      "Klimt/Klimt.pgm",
      "Solvay/Solvay_conference_1927_Version2_1280x881.png",
      "AprilTag/AprilTag.pgm",
      "mbt/cube/image0001.pgm",
      "mbt-depth/castel/chateau.ppm",
      "cube/image.0001.pgm",
      "mire-2/image.0001.pgm",
      "calibration/grid36-01.pgm",
  };
  std::vector<std::string> out;
  for (const char* relative : kPhotographs) {
    const fs::path path = fs::path(root) / relative;
    std::error_code ec;
    if (fs::is_regular_file(path, ec)) out.push_back(path.string());
  }
  return out;
}

std::vector<GrayImage> ProceduralPhotographs(unsigned seed, int count) {
  std::mt19937 rng(seed * 2654435761u + 12345u);
  std::vector<GrayImage> out;
  for (int i = 0; i < count; ++i) out.push_back(PrintedCard(rng));
  return out;
}

FacePlane FaceFrame(const Component& component, int face) {
  FacePlane plane;
  const std::vector<int>& loop = component.faces[face].loop;
  if (loop.size() < 3) return plane;
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < loop.size(); ++k) {
    normal += component.points[loop[k]].position.cross(
        component.points[loop[(k + 1) % loop.size()]].position);
  }
  if (normal.norm() == 0) return plane;
  plane.normal = normal.normalized();
  plane.origin = component.points[loop[0]].position;
  const Eigen::Vector3d side = component.points[loop[1]].position - plane.origin;
  const Eigen::Vector3d in_plane = side - plane.normal * plane.normal.dot(side);
  if (in_plane.norm() == 0) return plane;
  plane.s = in_plane.normalized();
  plane.t = plane.normal.cross(plane.s);
  plane.valid = true;
  return plane;
}

std::vector<FaceTexture> FaceTextures(const ConstraintGraph& graph,
                                      const std::vector<GrayImage>& photographs, unsigned seed,
                                      double contrast) {
  for (const GrayImage& photo : photographs) {
    CFUSE_CHECK(photo.width >= kMinPhotographSide && photo.height >= kMinPhotographSide &&
                photo.pixels.size() == static_cast<size_t>(photo.width) * photo.height);
  }
  std::vector<FaceTexture> out;
  for (size_t ci = 0; ci < graph.components.size(); ++ci) {
    const Component& c = graph.components[ci];
    if (!c.rigid) continue;
    for (size_t f = 0; f < c.faces.size(); ++f) {
      FaceTexture texture;
      texture.component = static_cast<int>(ci);
      texture.face = static_cast<int>(f);
      std::mt19937 rng(FaceSeed(seed, texture.component, texture.face));
      auto uniform = [&](double lo, double hi) {
        return std::uniform_real_distribution<double>(lo, hi)(rng);
      };
      texture.base = uniform(0.35, 0.8);
      const FacePlane plane = FaceFrame(c, static_cast<int>(f));
      if (!plane.valid || photographs.empty() || contrast <= 0) {
        out.push_back(texture);
        continue;
      }
      const int index = static_cast<int>(rng() % photographs.size());
      const GrayImage& photo = photographs[index];
      Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
      Eigen::Vector2d hi = -lo;
      for (int k : c.faces[f].loop) {
        const Eigen::Vector3d d = c.points[k].position - plane.origin;
        const Eigen::Vector2d st(d.dot(plane.s), d.dot(plane.t));
        lo = lo.cwiseMin(st);
        hi = hi.cwiseMax(st);
      }
      const int quarter = static_cast<int>(rng() % 4);
      const double angle = quarter * M_PI / 2;
      Eigen::Matrix2d rotation;
      rotation << std::round(std::cos(angle)), -std::round(std::sin(angle)),
          std::round(std::sin(angle)), std::round(std::cos(angle));
      // The face's extent along the photograph's x and y, metres.
      const Eigen::Vector2d extent =
          (rotation.cwiseAbs() * (hi - lo)).cwiseMax(Eigen::Vector2d::Constant(1e-6));
      const double fit = std::min((photo.width - 3) / extent.x(), (photo.height - 3) / extent.y());
      const double scale = std::min(uniform(500, 1100), fit);  // photograph px per metre
      const Eigen::Vector2d half = 0.5 * scale * extent;
      const double x_lo = 1 + half.x(), y_lo = 1 + half.y();
      const Eigen::Vector2d centre(uniform(x_lo, std::max(x_lo, photo.width - 2 - half.x())),
                                   uniform(y_lo, std::max(y_lo, photo.height - 2 - half.y())));
      texture.photo_from_face.leftCols<2>() = scale * rotation;
      texture.photo_from_face.col(2) = centre - scale * rotation * (0.5 * (lo + hi));
      // The crop's mean and spread, on a 16 x 16 grid over the face's extent.
      double sum = 0, sum2 = 0;
      constexpr int kGrid = 16;
      for (int i = 0; i < kGrid; ++i) {
        for (int j = 0; j < kGrid; ++j) {
          const Eigen::Vector2d st = lo + Eigen::Vector2d((i + 0.5) / kGrid * (hi - lo).x(),
                                                          (j + 0.5) / kGrid * (hi - lo).y());
          const Eigen::Vector2d q = texture.photo_from_face * st.homogeneous();
          const double g = Bilinear(photo, q.x(), q.y());
          sum += g;
          sum2 += g * g;
        }
      }
      constexpr double n = kGrid * kGrid;
      texture.mean = sum / n;
      const double spread = std::sqrt(std::max(0.0, sum2 / n - texture.mean * texture.mean));
      if (spread >= 2) {
        texture.photograph = index;
        texture.gain = contrast / spread;
      }
      out.push_back(texture);
    }
  }
  return out;
}

}  // namespace cfuse
