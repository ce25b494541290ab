#include "cfuse/vision/camera_file.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <regex>
#include <string_view>
#include <vector>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera_checks.h"
#include "file_storage_screen.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

constexpr size_t kMaxCameraFileBytes = 1u << 20;

[[noreturn]] void Fail(const std::string& path, const std::string& node,
                       const std::string& message) {
  throw InputError(SourceLocation(path, 0, 0, node), message);
}

// What cv::FileStorage would otherwise report only on its log: a missing or unreadable file.
void CheckReadable(const std::string& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status))
    throw InputError(SourceLocation(path), "cannot open: no such file");
  if (fs::is_directory(status))
    throw InputError(SourceLocation(path), "is a directory, not a camera file");
  if (fs::file_size(path, ec) > kMaxCameraFileBytes) {
    throw InputError(SourceLocation(path),
                     fmt::format("file is larger than the {} MiB limit for camera files",
                                 kMaxCameraFileBytes >> 20));
  }
  if (!std::ifstream(path, std::ios::binary)) {
    throw InputError(SourceLocation(path), fmt::format("cannot open: {}", std::strerror(errno)));
  }
}

// cv::FileStorage formats a syntax error "FILE(LINE): MESSAGE"; OpenCV 4.6 puts that text in the
// exception's function-name field and the function's name in its error field, so all three
// fields are searched. In the full message it is followed by "' in function ..." (or stands in
// quotes after "in function"); the message itself may hold quotes ("Literal ' or > are not
// allowed").
InputError SyntaxError(const std::string& path, const cv::Exception& e) {
  static const std::regex kLocated(R"(\((\d+)\): ([^\n]+))");
  static const std::regex kTrailer(R"(('| in function '[^']*')$)");
  for (const std::string* text : {&e.func, &e.err, &e.msg}) {
    std::smatch m;
    if (std::regex_search(*text, m, kLocated)) {
      const std::string message =
          text == &e.msg ? std::regex_replace(m[2].str(), kTrailer, "") : m[2].str();
      return InputError(SourceLocation(path, std::stoi(m[1].str())),
                        fmt::format("syntax error (cv::FileStorage): {}", message));
    }
  }
  return InputError(SourceLocation(path), fmt::format("cv::FileStorage cannot read it: {}",
                                                      e.err.empty() ? e.what() : e.err));
}

// The top-level node names, for a message about a missing one (another program's names for the
// same thing, e.g. `K` and `D`, show at once).
std::string NodeNames(const cv::FileStorage& storage) {
  std::string names;
  int count = 0;
  const cv::FileNode root = storage.root();
  for (auto it = root.begin(); it != root.end(); ++it, ++count) {
    if (count == 12) return names + ", ...";
    names += (names.empty() ? "" : ", ") + (*it).name();
  }
  return names;
}

cv::FileNode Require(const cv::FileStorage& storage, const std::string& path, const char* name) {
  const cv::FileNode node = storage[name];
  if (node.empty()) {
    const std::string names = NodeNames(storage);
    Fail(path, name,
         names.empty() ? "missing (the file has no nodes)"
                       : fmt::format("missing (the file's nodes: {})", names));
  }
  return node;
}

double NumberOf(const cv::FileNode& node, const std::string& path, const std::string& name,
                const std::string& what) {
  if (!node.isInt() && !node.isReal()) Fail(path, name, fmt::format("{} is not a number", what));
  return static_cast<double>(node);
}

struct Matrix {
  int rows = 0, cols = 0;
  std::vector<double> data;  // row-major
};

// An `opencv-matrix` node (rows, cols, dt, data), or with `allow_list` also a plain list of
// numbers (what `fs << name << std::vector<double>` writes), read as a 1xN matrix.
Matrix ReadMatrix(const cv::FileNode& node, const std::string& path, const std::string& name,
                  bool allow_list) {
  Matrix m;
  cv::FileNode data = node;
  if (node.isMap()) {
    for (const char* key : {"rows", "cols", "data"}) {
      if (node[key].empty()) {
        Fail(path, name,
             fmt::format("not an OpenCV matrix: it has no '{}' (an opencv-matrix has "
                         "rows, cols, dt and data)",
                         key));
      }
    }
    for (const char* key : {"rows", "cols"}) {
      if (!node[key].isInt() || static_cast<int>(node[key]) < 0) {
        Fail(path, name, fmt::format("'{}' must be a whole number", key));
      }
    }
    m.rows = static_cast<int>(node["rows"]);
    m.cols = static_cast<int>(node["cols"]);
    if (const cv::FileNode dt = node["dt"]; dt.isString() && dt.string().size() != 1) {
      Fail(path, name,
           fmt::format("must be a matrix of numbers (dt 'd' or 'f'), got dt '{}'", dt.string()));
    }
    data = node["data"];
  } else if (!allow_list || !node.isSeq()) {
    Fail(path, name,
         allow_list ? "must be an OpenCV matrix or a list of numbers"
                    : "must be an OpenCV matrix (!!opencv-matrix: rows, cols, dt, "
                      "data)");
  }
  if (data.isSeq()) {
    int i = 0;
    for (auto it = data.begin(); it != data.end(); ++it, ++i) {
      m.data.push_back(NumberOf(*it, path, name, fmt::format("data[{}]", i)));
    }
  } else {
    m.data.push_back(NumberOf(data, path, name, "data"));
  }
  if (!node.isMap()) {
    m.rows = 1;
    m.cols = static_cast<int>(m.data.size());
  }
  if (static_cast<size_t>(m.rows) * static_cast<size_t>(m.cols) != m.data.size()) {
    Fail(path, name,
         fmt::format("rows x cols = {} x {} = {} but data has {} values", m.rows, m.cols,
                     static_cast<size_t>(m.rows) * static_cast<size_t>(m.cols), m.data.size()));
  }
  return m;
}

int ImageSide(const cv::FileStorage& storage, const std::string& path, const char* name) {
  const double v = NumberOf(Require(storage, path, name), path, name, "the value");
  if (!IsImageSide(v)) {
    Fail(path, name, fmt::format("must be a positive whole number of pixels, got {}", v));
  }
  return static_cast<int>(v);
}

Camera Read(const cv::FileStorage& storage, const std::string& path) {
  if (const cv::FileNode f = storage["fisheye_model"]; !f.empty()) {
    if (!f.isInt()) Fail(path, "fisheye_model", "must be 0 or 1");
    if (static_cast<int>(f) != 0) {
      Fail(path, "fisheye_model",
           fmt::format("is {}: the coefficients are of OpenCV's fisheye (Kannala-Brandt) model, "
                       "which cfuse's camera does not have",
                       static_cast<int>(f)));
    }
  }
  const Matrix K = ReadMatrix(Require(storage, path, "camera_matrix"), path, "camera_matrix",
                              /*allow_list=*/false);
  if (K.rows != 3 || K.cols != 3) {
    Fail(path, "camera_matrix", fmt::format("must be 3x3, got {}x{}", K.rows, K.cols));
  }
  if (const auto problem = CameraMatrixProblem(K.data))
    Fail(path, "camera_matrix", problem->message);

  const Matrix D = ReadMatrix(Require(storage, path, "distortion_coefficients"), path,
                              "distortion_coefficients", /*allow_list=*/true);
  if (D.rows != 1 && D.cols != 1) {
    Fail(path, "distortion_coefficients",
         fmt::format("must be 1xN or Nx1, got {}x{}", D.rows, D.cols));
  }
  if (D.data.empty()) {
    Fail(path, "distortion_coefficients",
         "is empty; OpenCV's model takes 4, 5, 8, 12 or 14 coefficients (zeros for none)");
  }
  if (const auto problem = DistortionProblem(D.data))
    Fail(path, "distortion_coefficients", problem->message);

  const int width = ImageSide(storage, path, "image_width");
  const int height = ImageSide(storage, path, "image_height");
  if (const auto problem = PrincipalPointProblem(K.data[2], K.data[5], width, height))
    Fail(path, "camera_matrix", problem->message);
  return PinholeCamera(K.data, D.data, width, height);
}

}  // namespace

bool IsOpenCvStorage(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  std::string_view s(head);
  if (s.starts_with("\xEF\xBB\xBF")) s.remove_prefix(3);
  const size_t start = s.find_first_not_of(" \t\r\n");
  if (start == std::string_view::npos) return false;
  s.remove_prefix(start);
  if (s.starts_with("%YAML:1.")) return true;
  if (s.starts_with("<")) return s.find("<opencv_storage>") != std::string_view::npos;
  if (s.starts_with("{")) return s.find("\"opencv-matrix\"") != std::string_view::npos;
  return false;
}

Camera ReadOpenCvCamera(const std::string& path) {
  CheckReadable(path);
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) {
    throw InputError(SourceLocation(path), fmt::format("cannot read: {}", std::strerror(errno)));
  }
  return ReadOpenCvCameraFromString(text, path);
}

Camera ReadOpenCvCameraFromString(std::string_view text, const std::string& display_name) {
  if (text.size() > kMaxCameraFileBytes) {
    throw InputError(SourceLocation(display_name),
                     fmt::format("file is larger than the {} MiB limit for camera files",
                                 kMaxCameraFileBytes >> 20));
  }
  // cv::FileStorage (OpenCV 4.6) dereferences null on a NUL byte in the text (found by
  // fuzz/camera_fuzz.cpp) and where its parser meets the end of the text inside a construct
  // (`<?xml rr=`), so it only ever sees text whose structure is complete.
  RequireText(display_name, text, "camera file");
  ScreenFileStorageText(display_name, text);
  try {
    const cv::FileStorage storage(std::string(text),
                                  cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!storage.isOpened()) {
      throw InputError(SourceLocation(display_name), "cv::FileStorage cannot open it");
    }
    return Read(storage, display_name);
  } catch (const cv::Exception& e) {
    throw SyntaxError(display_name, e);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    // OpenCV 4.6's YAML parser lets std::length_error escape on some malformed texts (a matrix
    // key starting with ':'; found by fuzz/camera_fuzz.cpp), with no line.
    throw InputError(SourceLocation(display_name),
                     fmt::format("cv::FileStorage cannot parse it ({})", e.what()));
  }
}

}  // namespace cfuse
