#include "cli/image_support.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "cfuse/dsl/pose_reader.h"
#include "cfuse/importers/visp.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera_checks.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kMaxImageBytes = 512ull << 20;

}  // namespace

QuietStderr::QuietStderr() {
  std::fflush(stderr);
  saved_ = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY);
  if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
  if (null >= 0) ::close(null);
}

QuietStderr::~QuietStderr() {
  if (saved_ < 0) return;
  std::fflush(stderr);
  ::dup2(saved_, 2);
  ::close(saved_);
}

cv::Mat ReadGrayImage(const std::string& path) {
  const SourceLocation where(path);
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(where, "cannot open: no such file");
  if (fs::is_directory(path, ec)) throw InputError(where, "cannot open: it is a directory");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError(where, "cannot open: " + ec.message());
  if (size == 0) throw InputError(where, "the file is empty");
  // Said here: cv::imread returns an empty image for a file it may not read, as for a damaged one.
  if (!std::ifstream(path, std::ios::binary)) {
    throw InputError(where, fmt::format("cannot open: {}", std::strerror(errno)));
  }
  if (size > kMaxImageBytes) {
    throw InputError(where, fmt::format("the file is larger than the {} MiB limit for images",
                                        kMaxImageBytes >> 20));
  }
  cv::Mat image;
  try {
    const QuietStderr quiet;
    image = cv::imread(path, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    // e.err, not e.msg: the msg is several lines naming OpenCV's own source file and line.
    if (e.err.find("CV_IO_MAX_IMAGE_PIXELS") != std::string::npos) {
      throw InputError(where,
                       "cannot read the image: it has more pixels than OpenCV reads "
                       "(CV_IO_MAX_IMAGE_PIXELS, 2^30 by default)");
    }
    throw InputError(where, fmt::format("cannot read the image: {}", e.err));
  }
  if (image.empty()) {
    throw InputError(where,
                     "cannot read the image: not in a format OpenCV reads (PNG, JPEG, TIFF, BMP, "
                     "PNM, ...) or damaged");
  }
  if (image.depth() != CV_8U) {
    const char* depth = image.depth() == CV_16U   ? "16-bit"
                        : image.depth() == CV_32F ? "float"
                                                  : "non-8-bit";
    throw InputError(where, fmt::format("the image has {} samples: give an 8-bit grey or colour "
                                        "image",
                                        depth));
  }
  cv::Mat gray;
  switch (image.channels()) {
    case 1:
      gray = image;
      break;
    case 3:
      cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
      break;
    case 4:
      cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
      break;
    default:
      throw InputError(where, fmt::format("the image has {} channels: give a grey (1), colour "
                                          "(3) or colour-and-alpha (4) image",
                                          image.channels()));
  }
  return gray;
}

void SizeCameraFromImage(const cv::Mat& image, const std::string& source,
                         const std::string& camera_file, Camera* camera) {
  camera->width = image.cols;
  camera->height = image.rows;
  if (const auto problem =
          PrincipalPointProblem(camera->cx, camera->cy, camera->width, camera->height)) {
    throw InputError(
        SourceLocation(camera_file),
        fmt::format("{} (the camera gives no size: it is {}'s)", problem->message, source));
  }
}

std::string PngBytes(const cv::Mat& image) {
  std::vector<std::uint8_t> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

Values PosedModel(const ConstraintGraph& graph, const std::string& pose_file) {
  std::string ext = fs::path(pose_file).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".pos") {
    // ViSP's cMo places the model's frame: every component and point rides on it rigidly.
    const Rigid3d camera_from_object = ReadVispPose(pose_file);
    Values values = graph.nominal;
    for (Rigid3d& pose : values.poses) pose = camera_from_object * pose;
    for (Eigen::Vector3d& point : values.points) point = camera_from_object * point;
    return values;
  }
  return PosedModel(graph, ReadPoses(pose_file), pose_file);
}

Values PosedModel(const ConstraintGraph& graph, const PoseSet& poses, const std::string& source) {
  Values values = graph.nominal;
  ApplyGuess(graph, poses, &values);
  std::set<int> placed;
  for (const NamedPose& p : poses.components) {
    if (const int c = graph.FindComponent(p.name); c >= 0) {
      placed.insert(c);
    } else if (const auto frame = graph.FindFrame(p.name)) {
      placed.insert(frame->first);
    }
  }
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (graph.components[c].rigid && !placed.count(static_cast<int>(c))) {
      throw InputError(SourceLocation(source),
                       fmt::format("no pose for component '{}' of model '{}' under "
                                   "'components'",
                                   graph.components[c].name, graph.name));
    }
  }
  return values;
}

}  // namespace cfuse::cli
