#include "measurement_json.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "cfuse/dsl/measurement_reader.h"
#include "cfuse/kernel/error.h"
#include "yaml_document.h"

namespace cfuse {
namespace {

// An iterator over the text that records how far the parser has read, so that an event knows
// its byte offset: nlohmann's lexer reads a '{' or '[' and nothing more before the parser
// announces it.
class CountingIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  CountingIterator(const char* p, const char** furthest) : p_(p), furthest_(furthest) {}
  reference operator*() const { return *p_; }
  CountingIterator& operator++() {
    ++p_;
    *furthest_ = p_;
    return *this;
  }
  CountingIterator operator++(int) {
    CountingIterator old = *this;
    ++*this;
    return old;
  }
  bool operator==(const CountingIterator& o) const { return p_ == o.p_; }
  bool operator!=(const CountingIterator& o) const { return p_ != o.p_; }

 private:
  const char* p_;
  const char** furthest_;
};

// A point as read, checked when its object closes.
struct RawPoint {
  size_t offset = 0;  // of its '{'
  std::vector<double> xyz, uv, sigma;
  std::vector<std::vector<double>> cov;
  bool has_xyz = false, has_uv = false, has_sigma = false, has_cov = false, has_label = false;
  bool label_null = false;
  std::string label;
};

class Handler : public nlohmann::json_sax<nlohmann::json> {
 public:
  Handler(std::string_view text, const std::string& display, const char** furthest)
      : text_(text), display_(display), furthest_(furthest) {}

  // Where each piece is; the result when the parse succeeded.
  std::vector<MeasuredPoint> points;
  size_t points_offset = 0;
  bool has_points = false;
  std::optional<std::pair<size_t, size_t>> camera_range;  // [begin, end) of its object
  bool any_uv = false;
  bool too_many = false;

  bool null() override {
    if (state_ == State::kCamera) return true;
    if (state_ == State::kPointKey && key_ == "label") {
      point_.label_null = true;
      state_ = State::kPoint;
      return true;
    }
    return false;
  }
  bool boolean(bool) override { return state_ == State::kCamera; }
  bool number_integer(number_integer_t v) override { return Number(static_cast<double>(v)); }
  bool number_unsigned(number_unsigned_t v) override { return Number(static_cast<double>(v)); }
  bool number_float(number_float_t, const string_t& s) override {
    // The YAML reader converts the same characters with strtod.
    return Number(std::strtod(s.c_str(), nullptr));
  }
  bool string(string_t& s) override {
    if (state_ == State::kCamera) return true;
    if (state_ == State::kPointKey && key_ == "label") {
      point_.label = s;
      state_ = State::kPoint;
      return true;
    }
    return false;
  }
  bool binary(binary_t&) override { return false; }

  bool start_object(std::size_t) override {
    const size_t offset = Offset() - 1;
    switch (state_) {
      case State::kStart:
        state_ = State::kRoot;
        return true;
      case State::kRootKey:
        if (key_ != "camera") return false;
        state_ = State::kCamera;
        camera_begin_ = offset;
        nesting_ = 1;
        return true;
      case State::kCamera:
        ++nesting_;
        return true;
      case State::kPoints:
        point_ = RawPoint();
        point_.offset = offset;
        state_ = State::kPoint;
        return true;
      default:
        return false;
    }
  }
  bool key(string_t& k) override {
    if (state_ == State::kCamera) return true;
    if (state_ == State::kRoot) {
      if ((k != "points" && k != "camera") || !root_keys_.insert(k).second) return false;
      key_ = k;
      state_ = State::kRootKey;
      return true;
    }
    if (state_ == State::kPoint) {
      bool* seen = k == "xyz"     ? &point_.has_xyz
                   : k == "uv"    ? &point_.has_uv
                   : k == "sigma" ? &point_.has_sigma
                   : k == "cov"   ? &point_.has_cov
                   : k == "label" ? &point_.has_label
                                  : nullptr;
      if (seen == nullptr || *seen) return false;
      *seen = true;
      key_ = k;
      state_ = State::kPointKey;
      return true;
    }
    return false;
  }
  bool end_object() override {
    switch (state_) {
      case State::kCamera:
        if (--nesting_ == 0) {
          camera_range = {camera_begin_, Offset()};
          state_ = State::kRoot;
        }
        return true;
      case State::kPoint:
        state_ = State::kPoints;
        return FinishPoint();
      case State::kRoot:
        state_ = State::kDone;
        return true;
      default:
        return false;
    }
  }
  bool start_array(std::size_t) override {
    switch (state_) {
      case State::kCamera:
        return true;
      case State::kRootKey:
        if (key_ != "points") return false;
        state_ = State::kPoints;
        has_points = true;
        points_offset = Offset() - 1;
        return true;
      case State::kPointKey:
        if (key_ == "cov") {
          state_ = State::kCov;
          return true;
        }
        if (key_ != "xyz" && key_ != "uv") return false;
        state_ = State::kVector;
        return true;
      case State::kCov:
        point_.cov.emplace_back();
        state_ = State::kCovRow;
        return true;
      default:
        return false;
    }
  }
  bool end_array() override {
    switch (state_) {
      case State::kCamera:
        return true;
      case State::kPoints:
        state_ = State::kRoot;
        return true;
      case State::kVector:
      case State::kCov:
        state_ = State::kPoint;
        return true;
      case State::kCovRow:
        state_ = State::kCov;
        return true;
      default:
        return false;
    }
  }
  bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception&) override {
    return false;
  }

 private:
  enum class State {
    kStart,
    kRoot,
    kRootKey,
    kCamera,
    kPoints,
    kPoint,
    kPointKey,
    kVector,
    kCov,
    kCovRow,
    kDone
  };

  size_t Offset() const { return static_cast<size_t>(*furthest_ - text_.data()); }

  bool Number(double v) {
    if (state_ == State::kCamera) return true;
    if (!std::isfinite(v)) return false;
    switch (state_) {
      case State::kPointKey:
        if (key_ != "sigma") return false;
        point_.sigma.push_back(v);
        state_ = State::kPoint;
        return true;
      case State::kVector:
        (key_ == "xyz" ? point_.xyz : point_.uv).push_back(v);
        return point_.xyz.size() <= 3 && point_.uv.size() <= 2;
      case State::kCovRow:
        point_.cov.back().push_back(v);
        return point_.cov.back().size() <= 3;
      default:
        return false;
    }
  }

  // The YAML reader's checks of one entry; any failure hands the file over to it.
  bool FinishPoint() {
    RawPoint& r = point_;
    if (r.has_xyz == r.has_uv || r.has_sigma == r.has_cov) return false;
    if (r.has_label && !r.label_null && r.label.empty()) return false;
    const int n = r.has_xyz ? 3 : 2;
    if (static_cast<int>((r.has_xyz ? r.xyz : r.uv).size()) != n) return false;
    MeasuredPoint p;
    p.is_3d = r.has_xyz;
    Eigen::MatrixXd C(n, n);
    if (r.has_sigma) {
      if (SigmaProblem(r.sigma[0])) return false;
      C = r.sigma[0] * r.sigma[0] * Eigen::MatrixXd::Identity(n, n);
    } else {
      if (static_cast<int>(r.cov.size()) != n) return false;
      for (int i = 0; i < n; ++i) {
        if (static_cast<int>(r.cov[i].size()) != n) return false;
        for (int j = 0; j < n; ++j) C(i, j) = r.cov[i][j];
      }
      if (CovarianceProblem(C)) return false;
      // eval(): the transpose reads what the assignment writes (found by the measurements
      // fuzz target: the result was not symmetric).
      C = (0.5 * (C + C.transpose())).eval();
    }
    if (p.is_3d) {
      p.xyz = Eigen::Vector3d(r.xyz[0], r.xyz[1], r.xyz[2]);
      p.cov3 = C;
    } else {
      p.uv = Eigen::Vector2d(r.uv[0], r.uv[1]);
      p.cov2 = C;
      any_uv = true;
    }
    if (r.has_label && !r.label_null) p.label = std::move(r.label);
    // Where yaml-cpp marks the entry: the line and column of its '{' (the text is ASCII and
    // has no carriage returns, so both count bytes alike).
    for (; scanned_ < r.offset; ++scanned_) {
      if (text_[scanned_] == '\n') {
        ++line_;
        column_ = 1;
      } else {
        ++column_;
      }
    }
    p.where = SourceLocation(display_, line_, column_, fmt::format("points[{}]", points.size()));
    if (points.size() >= static_cast<size_t>(kMaxMeasuredPoints)) {
      too_many = true;
      return false;
    }
    points.push_back(std::move(p));
    return true;
  }

  std::string_view text_;
  const std::string& display_;  // the file, for each point's location
  const char** furthest_;
  State state_ = State::kStart;
  std::string key_;
  std::set<std::string> root_keys_;
  size_t camera_begin_ = 0;
  int nesting_ = 0;
  RawPoint point_;
  size_t scanned_ = 0;
  int line_ = 1, column_ = 1;
};

// What the fast path leaves to the YAML reader: anything but printable ASCII, tabs and line
// feeds (so columns count alike), and escapes (whose decoding might differ).
bool PlainText(std::string_view text) {
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\\' || (c < 0x20 && c != '\n' && c != '\t') || c > 0x7e) return false;
  }
  return true;
}

}  // namespace

std::optional<std::string> SigmaProblem(double sigma) {
  if (!(sigma > 0)) return fmt::format("must be positive, got {}", sigma);
  const double variance = sigma * sigma;
  if (!std::isnormal(variance)) {
    return fmt::format("must have a finite, nonzero square, got {}", sigma);
  }
  return std::nullopt;
}

std::optional<std::string> CovarianceProblem(const Eigen::MatrixXd& C) {
  if (!C.allFinite()) return "has an entry that is not a finite number";
  if ((C - C.transpose()).cwiseAbs().maxCoeff() > 1e-9 * C.cwiseAbs().maxCoeff()) {
    return "is not symmetric";
  }
  const Eigen::LLT<Eigen::MatrixXd> llt(0.5 * (C + C.transpose()));
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 0)) {
    return "is not positive definite";
  }
  return std::nullopt;
}

std::optional<MeasurementSet> ReadPlainJsonMeasurements(
    std::string_view text, const std::string& display,
    const std::function<Camera(std::string_view camera_json)>& read_camera) {
  const size_t start = text.find_first_not_of(" \t\n");
  if (start == std::string_view::npos || text[start] != '{' || !PlainText(text)) {
    return std::nullopt;
  }
  const char* furthest = text.data();
  Handler handler(text, display, &furthest);
  const bool parsed =
      nlohmann::json::sax_parse(CountingIterator(text.data(), &furthest),
                                CountingIterator(text.data() + text.size(), &furthest), &handler);
  if (handler.too_many) {
    throw InputError(LocationOfOffset(display, text, handler.points_offset),
                     fmt::format("more than {} points", kMaxMeasuredPoints));
  }
  if (!parsed || !handler.has_points) return std::nullopt;
  MeasurementSet set;
  set.source = display;
  if (handler.camera_range) {
    try {
      const auto [begin, end] = *handler.camera_range;
      set.camera = read_camera(text.substr(begin, end - begin));
    } catch (const InputError&) {
      return std::nullopt;
    }
  }
  if (handler.any_uv && !set.camera) return std::nullopt;
  set.points = std::move(handler.points);
  return set;
}

bool SameMeasurements(const MeasurementSet& a, const MeasurementSet& b) {
  const auto same_camera = [](const Camera& x, const Camera& y) {
    return x.model == y.model && x.fx == y.fx && x.fy == y.fy && x.cx == y.cx && x.cy == y.cy &&
           x.scale == y.scale && x.width == y.width && x.height == y.height &&
           x.distortion == y.distortion;
  };
  if (a.source != b.source || a.camera.has_value() != b.camera.has_value() ||
      (a.camera && !same_camera(*a.camera, *b.camera)) || a.points.size() != b.points.size()) {
    return false;
  }
  for (size_t i = 0; i < a.points.size(); ++i) {
    const MeasuredPoint &p = a.points[i], &q = b.points[i];
    if (p.is_3d != q.is_3d || p.xyz != q.xyz || p.cov3 != q.cov3 || p.uv != q.uv ||
        p.cov2 != q.cov2 || p.label != q.label || p.where.ToString() != q.where.ToString() ||
        p.where.element != q.where.element) {
      return false;
    }
  }
  return true;
}

}  // namespace cfuse
