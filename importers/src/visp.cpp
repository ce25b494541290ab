#include "cfuse/importers/visp.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <vector>

#include "cfuse/kernel/error.h"
#include "cfuse/kernel/measurements/camera_checks.h"
#include "read_file.h"
#include "xml_document.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kWithoutDistortion = "perspectiveProjWithoutDistortion";
constexpr std::string_view kWithDistortion = "perspectiveProjWithDistortion";

enum class NumberKind { kNumber, kNotANumber, kNotFinite };

// A decimal number as ViSP writes them ([+-]digits[.digits][e[+-]digits]); "nan", "inf" and
// numbers beyond double's range are numbers, but not finite ones.
NumberKind ParseNumber(std::string_view token, double* value) {
  size_t i = 0;
  if (i < token.size() && (token[i] == '+' || token[i] == '-')) ++i;
  std::string word(token.substr(i));
  std::transform(word.begin(), word.end(), word.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (word == "nan" || word == "inf" || word == "infinity") return NumberKind::kNotFinite;
  auto digits = [&] {
    const size_t from = i;
    while (i < token.size() && std::isdigit(static_cast<unsigned char>(token[i]))) ++i;
    return i - from;
  };
  size_t mantissa = digits();
  if (i < token.size() && token[i] == '.') {
    ++i;
    mantissa += digits();
  }
  if (mantissa == 0) return NumberKind::kNotANumber;
  if (i < token.size() && (token[i] == 'e' || token[i] == 'E')) {
    ++i;
    if (i < token.size() && (token[i] == '+' || token[i] == '-')) ++i;
    if (digits() == 0) return NumberKind::kNotANumber;
  }
  if (i != token.size()) return NumberKind::kNotANumber;
  *value = std::strtod(std::string(token).c_str(), nullptr);
  return std::isfinite(*value) ? NumberKind::kNumber : NumberKind::kNotFinite;
}

// A token quoted for a message, cut short (at a character's start) if long.
std::string Quoted(std::string_view token) {
  if (token.size() <= 40) return fmt::format("'{}'", token);
  size_t cut = 37;
  while (cut > 0 && (static_cast<unsigned char>(token[cut]) & 0xC0) == 0x80) --cut;
  return fmt::format("'{}...'", token.substr(0, cut));
}

// ---------------------------------------------------------------------------------------------
// Cameras.

// px, py, u0, v0 and kud, each with the element it came from (for a later check's message).
struct Intrinsics {
  double px = 0, py = 0, u0 = 0, v0 = 0, kud = 0;
  const TiXmlElement *px_at = nullptr, *py_at = nullptr, *u0_at = nullptr, *v0_at = nullptr;
};

class VispCameraReader {
 public:
  VispCameraReader(const std::string& file, std::string_view text) : file_(file), text_(text) {}

  Camera Read() {
    ParseXml(file_, text_, &doc_);
    const TiXmlElement* root = doc_.RootElement();
    if (!root) {
      throw InputError(LocationOfOffset(file_, text_, text_.size()),
                       "not a ViSP camera file: it has no root element (ViSP's tracker settings "
                       "have <conf>, vpXmlParserCamera's files <root>)");
    }
    const std::string_view name = root->Value();
    if (name == "conf") return FromTrackerSettings(root);
    if (name == "root") return FromParserCamera(root);
    Fail(root, fmt::format("not a camera file cfuse reads: the root element is <{}>; ViSP's "
                           "tracker settings have <conf>, vpXmlParserCamera's files <root> (and "
                           "OpenCV's calibration files <opencv_storage>)",
                           name));
  }

 private:
  SourceLocation Loc(const TiXmlNode* node) const {
    return SourceLocation(file_, node->Row(), node->Column());
  }
  [[noreturn]] void Fail(const TiXmlNode* node, const std::string& message) const {
    throw InputError(Loc(node), message);
  }

  static std::vector<const TiXmlElement*> Children(const TiXmlElement* parent, const char* name) {
    std::vector<const TiXmlElement*> out;
    for (const TiXmlElement* e = parent->FirstChildElement(name); e;
         e = e->NextSiblingElement(name)) {
      out.push_back(e);
    }
    return out;
  }

  // Refuses a child element of `parent` that is not one of `known`.
  void OnlyKnownChildren(const TiXmlElement* parent, std::initializer_list<std::string_view> known,
                         const std::string& what) const {
    for (const TiXmlElement* e = parent->FirstChildElement(); e; e = e->NextSiblingElement()) {
      if (std::find(known.begin(), known.end(), std::string_view(e->Value())) != known.end()) {
        continue;
      }
      std::string list;
      for (const std::string_view k : known)
        list += fmt::format("{}<{}>", list.empty() ? "" : ", ", k);
      Fail(e, fmt::format("unknown element <{}> in {}: it holds {}", e->Value(), what, list));
    }
  }

  // The one child named `name`: nullptr when absent, a failure when given twice.
  const TiXmlElement* Optional(const TiXmlElement* parent, const char* name) const {
    const std::vector<const TiXmlElement*> found = Children(parent, name);
    if (found.size() > 1) {
      Fail(found[1], fmt::format("<{}> given twice in <{}> (first at line {})", name,
                                 parent->Value(), found[0]->Row()));
    }
    return found.empty() ? nullptr : found[0];
  }
  const TiXmlElement* Required(const TiXmlElement* parent, const char* name,
                               const std::string& what) const {
    const TiXmlElement* e = Optional(parent, name);
    if (!e) Fail(parent, fmt::format("{} needs <{}>", what, name));
    return e;
  }

  // The element's text, without the white space around it.
  std::string_view Text(const TiXmlElement* e) const {
    if (const TiXmlElement* inner = e->FirstChildElement()) {
      Fail(inner,
           fmt::format("<{}> holds an element <{}>: it holds a value", e->Value(), inner->Value()));
    }
    const char* text = e->GetText();
    std::string_view s = text ? text : "";
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
    while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
    return s;
  }

  double Number(const TiXmlElement* e) const {
    const std::string_view text = Text(e);
    if (text.empty()) Fail(e, fmt::format("<{}> is empty: it holds a number", e->Value()));
    double value = 0;
    switch (ParseNumber(text, &value)) {
      case NumberKind::kNumber:
        return value;
      case NumberKind::kNotANumber:
        Fail(e, fmt::format("<{}> must be a number, found {}", e->Value(), Quoted(text)));
      case NumberKind::kNotFinite:
        Fail(e, fmt::format("<{}> must be finite, found {}", e->Value(), Quoted(text)));
    }
    return value;
  }

  // px, py, u0, v0 of a camera block (<camera> of tracker settings, or a <model>).
  Intrinsics ReadIntrinsics(const TiXmlElement* block, const std::string& what) const {
    Intrinsics in;
    in.px_at = Required(block, "px", what);
    in.py_at = Required(block, "py", what);
    in.u0_at = Required(block, "u0", what);
    in.v0_at = Required(block, "v0", what);
    in.px = Number(in.px_at);
    in.py = Number(in.py_at);
    in.u0 = Number(in.u0_at);
    in.v0 = Number(in.v0_at);
    return in;
  }

  // The camera, after the checks every camera reader applies.
  Camera Make(const Intrinsics& in, int width, int height) const {
    const double K[9] = {in.px, 0, in.u0, 0, in.py, in.v0, 0, 0, 1};
    if (const auto problem = CameraMatrixProblem(K)) {
      const TiXmlElement* at = problem->index == 4   ? in.py_at
                               : problem->index == 2 ? in.u0_at
                               : problem->index == 5 ? in.v0_at
                                                     : in.px_at;
      Fail(at, fmt::format("<{}>: {}", at->Value(), problem->message));
    }
    const double coefficients[5] = {in.kud, 0, 0, 0, 0};
    if (const auto problem = DistortionProblem(coefficients)) {
      Fail(in.px_at, fmt::format("kud: {}", problem->message));
    }
    if (width > 0) {
      if (const auto problem = PrincipalPointProblem(in.u0, in.v0, width, height)) {
        const TiXmlElement* at = problem->index == 0 ? in.u0_at : in.v0_at;
        Fail(at, fmt::format("<{}>: {}", at->Value(), problem->message));
      }
    }
    Camera camera;
    camera.model = Camera::Model::kPinhole;
    camera.fx = in.px;
    camera.fy = in.py;
    camera.cx = in.u0;
    camera.cy = in.v0;
    camera.distortion[0] = in.kud;
    camera.width = width;  // 0: unknown
    camera.height = height;
    return camera;
  }

  // <conf>: vpMbGenericTracker's settings, the camera's four numbers in <camera>.
  Camera FromTrackerSettings(const TiXmlElement* conf) const {
    const std::vector<const TiXmlElement*> cameras = Children(conf, "camera");
    if (cameras.empty()) {
      Fail(conf,
           "these ViSP tracker settings have no <camera> (<camera> with <px>, <py>, <u0>, "
           "<v0>): ViSP's tracker would take its default camera, cfuse needs the real one");
    }
    if (cameras.size() > 1) {
      Fail(cameras[1], fmt::format("a second <camera> in the tracker settings (the first at line "
                                   "{}): which one is meant?",
                                   cameras[0]->Row()));
    }
    const TiXmlElement* camera = cameras[0];
    OnlyKnownChildren(camera, {"px", "py", "u0", "v0"}, "the tracker settings' <camera>");
    return Make(ReadIntrinsics(camera, "<camera>"), 0, 0);
  }

  // One side of a vpXmlParserCamera camera's image: whole pixels, or 0 (unknown).
  int ImageSide(const TiXmlElement* e) const {
    const double v = Number(e);
    if (v != 0 && !IsImageSide(v)) {
      Fail(e, fmt::format("<{}> must be a whole number of pixels from 1 to 10^6 (or 0 for an "
                          "unknown size), found {}",
                          e->Value(), Quoted(Text(e))));
    }
    return static_cast<int>(v);
  }

  // A one-line summary of a vpXmlParserCamera <camera>, for the message listing them.
  std::string Summary(const TiXmlElement* camera) const {
    const TiXmlElement* name = camera->FirstChildElement("name");
    const TiXmlElement* width = camera->FirstChildElement("image_width");
    const TiXmlElement* height = camera->FirstChildElement("image_height");
    return fmt::format("'{}' {} x {} (line {})", name ? Text(name) : "", width ? Text(width) : "?",
                       height ? Text(height) : "?", camera->Row());
  }

  // <root>: vpXmlParserCamera's cameras.
  Camera FromParserCamera(const TiXmlElement* root) const {
    OnlyKnownChildren(root, {"camera"}, "vpXmlParserCamera's <root>");
    const std::vector<const TiXmlElement*> cameras = Children(root, "camera");
    if (cameras.empty()) {
      Fail(root,
           "this vpXmlParserCamera file has no <camera> (<camera> with <name>, "
           "<image_width>, <image_height> and a <model>)");
    }
    if (cameras.size() > 1) {
      std::string list;
      for (const TiXmlElement* c : cameras) list += (list.empty() ? "" : ", ") + Summary(c);
      Fail(cameras[1], fmt::format("the file has {} cameras: {}; cfuse reads a file with one "
                                   "camera (ViSP's reader is told a name and an image size): "
                                   "keep the one meant in a file of its own",
                                   cameras.size(), list));
    }
    const TiXmlElement* camera = cameras[0];
    OnlyKnownChildren(
        camera,
        {"name", "image_width", "image_height", "subsampling_width", "subsampling_height",
         "full_width", "full_height", "model", "additional_information"},
        "vpXmlParserCamera's <camera>");
    Optional(camera, "name");
    const TiXmlElement* width_at = Optional(camera, "image_width");
    const TiXmlElement* height_at = Optional(camera, "image_height");
    if ((width_at == nullptr) != (height_at == nullptr)) {
      Fail(camera, fmt::format("<camera> has <{}> but no <{}>: give both sides of the image",
                               width_at ? "image_width" : "image_height",
                               width_at ? "image_height" : "image_width"));
    }
    const int width = width_at ? ImageSide(width_at) : 0;
    const int height = height_at ? ImageSide(height_at) : 0;
    if ((width == 0) != (height == 0)) {
      Fail(width == 0 ? width_at : height_at,
           fmt::format("the image is {} x {}: a side of 0 (unknown) needs the other 0 too", width,
                       height));
    }

    const std::vector<const TiXmlElement*> models = Children(camera, "model");
    if (models.empty()) {
      Fail(camera, fmt::format("<camera> has no <model> (<type>{}</type> or <type>{}</type> with "
                               "<px>, <py>, <u0>, <v0>)",
                               kWithoutDistortion, kWithDistortion));
    }
    const TiXmlElement* without = nullptr;
    const TiXmlElement* with = nullptr;
    for (const TiXmlElement* model : models) {
      OnlyKnownChildren(model, {"type", "px", "py", "u0", "v0", "kud", "kdu"}, "<model>");
      const TiXmlElement* type_at = Required(model, "type", "<model>");
      const std::string_view type = Text(type_at);
      const TiXmlElement** slot = type == kWithDistortion      ? &with
                                  : type == kWithoutDistortion ? &without
                                                               : nullptr;
      if (!slot) {
        Fail(type_at, fmt::format("unknown camera model {}: ViSP's pinhole models are {} and {}{}",
                                  Quoted(type), kWithoutDistortion, kWithDistortion,
                                  type == "ProjWithKannalaBrandtDistortion"
                                      ? " (Kannala-Brandt is a fisheye model, which cfuse's "
                                        "camera does not have)"
                                      : ""));
      }
      if (*slot) {
        Fail(model, fmt::format("a second {} <model> in the camera (the first at line {})", type,
                                (*slot)->Row()));
      }
      *slot = model;
    }
    // Both models describe the same raw images; the one with distortion does so more exactly.
    const TiXmlElement* model = with ? with : without;
    Intrinsics in = ReadIntrinsics(
        model, fmt::format("the {} <model>", with ? kWithDistortion : kWithoutDistortion));
    if (with) {
      in.kud = Number(Required(model, "kud", fmt::format("the {} <model>", kWithDistortion)));
      if (const TiXmlElement* kdu = Optional(model, "kdu")) Number(kdu);  // checked, not needed
    } else {
      for (const char* k : {"kud", "kdu"}) {
        if (const TiXmlElement* e = Optional(model, k)) {
          Fail(e, fmt::format("<{}> in a {} model: its distortion would not be applied (make the "
                              "type {})",
                              k, kWithoutDistortion, kWithDistortion));
        }
      }
    }
    // The other model is checked too: a file ViSP would refuse is refused.
    if (with && without) {
      ReadIntrinsics(without, fmt::format("the {} <model>", kWithoutDistortion));
      for (const char* k : {"kud", "kdu"}) {
        if (const TiXmlElement* e = Optional(without, k)) {
          Fail(e, fmt::format("<{}> in a {} model", k, kWithoutDistortion));
        }
      }
    }
    return Make(in, width, height);
  }

  const std::string& file_;
  std::string_view text_;
  TiXmlDocument doc_;
};

// ---------------------------------------------------------------------------------------------
// Poses.

bool IsPoseSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

constexpr const char* kPoseForm =
    "a ViSP pose is six numbers tx ty tz tux tuy tuz (metres, then the rotation vector in "
    "radians)";

constexpr const char* kMatrixForm =
    "a ViSP homogeneous matrix is sixteen numbers, four rows of four: the rotation and the "
    "translation (metres), then 0 0 0 1";

// The white-space separated numbers of a pose file, with each one's offset, and the offset just
// after the last; a token that is not a finite number is refused at its place, `form` saying
// what the file should hold.
struct PoseNumbers {
  std::vector<double> values;
  std::vector<size_t> offsets;
  size_t end = 0;
};

PoseNumbers ReadPoseNumbers(std::string_view text, const std::string& display_name,
                            const char* form) {
  PoseNumbers out;
  for (size_t i = 0; i < text.size();) {
    if (IsPoseSpace(text[i])) {
      ++i;
      continue;
    }
    const size_t from = i;
    while (i < text.size() && !IsPoseSpace(text[i])) ++i;
    const std::string_view token = text.substr(from, i - from);
    double value = 0;
    switch (ParseNumber(token, &value)) {
      case NumberKind::kNumber:
        break;
      case NumberKind::kNotANumber:
        throw InputError(LocationOfOffset(display_name, text, from),
                         fmt::format("expected a number, found {}: {}", Quoted(token), form));
      case NumberKind::kNotFinite:
        throw InputError(LocationOfOffset(display_name, text, from),
                         fmt::format("{} is not a finite number: {}", Quoted(token), form));
    }
    out.values.push_back(value);
    out.offsets.push_back(from);
    out.end = i;
  }
  if (out.values.empty()) {
    throw InputError(LocationOfOffset(display_name, text, 0),
                     fmt::format("the file is empty: {}", form));
  }
  return out;
}

}  // namespace

bool IsVispCameraFile(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::string head(4096, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  std::string_view s(head);
  if (s.starts_with("\xEF\xBB\xBF")) s.remove_prefix(3);
  // Past the declaration, comments and other markup before the root element.
  for (;;) {
    const size_t start = s.find_first_not_of(" \t\r\n");
    if (start == std::string_view::npos) return false;
    s.remove_prefix(start);
    const std::string_view end = s.starts_with("<?")     ? "?>"
                                 : s.starts_with("<!--") ? "-->"
                                 : s.starts_with("<!")   ? ">"
                                                         : "";
    if (end.empty()) break;
    const size_t at = s.find(end, 2);
    if (at == std::string_view::npos) return false;
    s.remove_prefix(at + end.size());
  }
  for (const std::string_view root : {"<conf", "<root"}) {
    if (s.starts_with(root) && s.size() > root.size() &&
        (std::isspace(static_cast<unsigned char>(s[root.size()])) || s[root.size()] == '>' ||
         s[root.size()] == '/')) {
      return true;
    }
  }
  return false;
}

Camera ReadVispCamera(const std::string& path) {
  return ReadVispCameraFromString(
      ReadImportedFile(path, SourceLocation(), "ViSP camera", kMaxVispCameraFileBytes), path);
}

Camera ReadVispCameraFromString(std::string_view text, const std::string& display_name) {
  if (text.size() > kMaxVispCameraFileBytes) {
    throw InputError(SourceLocation(display_name),
                     fmt::format("file is larger than the {} MiB limit for ViSP camera files",
                                 kMaxVispCameraFileBytes >> 20));
  }
  RequireText(display_name, text, "ViSP camera file");
  return VispCameraReader(display_name, text).Read();
}

Rigid3d ReadVispPose(const std::string& path) {
  return ReadVispPoseFromString(
      ReadImportedFile(path, SourceLocation(), "ViSP pose", kMaxVispPoseFileBytes), path);
}

Rigid3d ReadVispPoseFromString(std::string_view text, const std::string& display_name) {
  if (text.size() > kMaxVispPoseFileBytes) {
    throw InputError(SourceLocation(display_name),
                     fmt::format("file is larger than the {} MiB limit for ViSP pose files",
                                 kMaxVispPoseFileBytes >> 20));
  }
  RequireText(display_name, text, "ViSP pose file");
  const PoseNumbers numbers = ReadPoseNumbers(text, display_name, kPoseForm);
  const size_t count = numbers.values.size();
  if (count != 6) {
    throw InputError(
        LocationOfOffset(display_name, text, count < 6 ? numbers.end : numbers.offsets[6]),
        fmt::format("{}, found {}", kPoseForm, count));
  }
  const std::vector<double>& v = numbers.values;
  const size_t fourth = numbers.offsets[3];
  const Eigen::Vector3d t(v[0], v[1], v[2]), theta_u(v[3], v[4], v[5]);
  // ViSP writes angles in [0, π]; beyond 2π the numbers are not radians (degrees?), and a
  // rotation vector whose norm overflows has no rotation (found by fuzz/poses_fuzz.cpp).
  if (!(theta_u.norm() <= 2 * M_PI)) {
    throw InputError(LocationOfOffset(display_name, text, fourth),
                     fmt::format("the rotation vector θu = ({:g}, {:g}, {:g}) turns by {:g} rad, "
                                 "more than 2π: θu is in radians (ViSP writes angles up to π); "
                                 "are these degrees?",
                                 v[3], v[4], v[5], theta_u.norm()));
  }
  return Rigid3d(ExpSO3<double>(theta_u), t);
}

Rigid3d ReadVispMatrixPose(const std::string& path) {
  return ReadVispMatrixPoseFromString(
      ReadImportedFile(path, SourceLocation(), "ViSP matrix", kMaxVispPoseFileBytes), path);
}

Rigid3d ReadVispMatrixPoseFromString(std::string_view text, const std::string& display_name) {
  if (text.size() > kMaxVispPoseFileBytes) {
    throw InputError(SourceLocation(display_name),
                     fmt::format("file is larger than the {} MiB limit for ViSP pose files",
                                 kMaxVispPoseFileBytes >> 20));
  }
  RequireText(display_name, text, "ViSP matrix file");
  const PoseNumbers numbers = ReadPoseNumbers(text, display_name, kMatrixForm);
  const size_t count = numbers.values.size();
  if (count != 16) {
    throw InputError(
        LocationOfOffset(display_name, text, count < 16 ? numbers.end : numbers.offsets[16]),
        fmt::format("{}, found {} numbers", kMatrixForm, count));
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = numbers.values[4 * r + c];
  }
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    throw InputError(LocationOfOffset(display_name, text, numbers.offsets[12]),
                     fmt::format("the last row is {:g} {:g} {:g} {:g}: {}", m(3, 0), m(3, 1),
                                 m(3, 2), m(3, 3), kMatrixForm));
  }
  // Written to ten digits or so: a rotation to about 1e-6, never a scaled or sheared one.
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  const double off = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(off <= 1e-4) || R.determinant() <= 0) {
    throw InputError(LocationOfOffset(display_name, text, numbers.offsets[0]),
                     fmt::format("the upper-left 3 x 3 block is no rotation (RᵀR departs from "
                                 "the identity by {:.2g}, det R = {:.4g}): {}",
                                 off, R.determinant(), kMatrixForm));
  }
  return Rigid3d(Eigen::Quaterniond(R).normalized(), m.topRightCorner<3, 1>());
}

}  // namespace cfuse
