#include "cfuse/dsl/model_loader.h"

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <span>
#include <sstream>

#include "cfuse/constraints/joint_model.h"
#include "cfuse/constraints/kinds/equality.h"
#include "cfuse/constraints/model_builder.h"
#include "cfuse/kernel/did_you_mean.h"
#include "cfuse/kernel/evaluate.h"
#include "lower.h"
#include "units.h"
#include "yaml_document.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

const FileKind kModelFile{"model", "a model needs components or points", kMaxModelFileBytes};

// ---------------------------------------------------------------------------------------------

struct FileUnits {
  double length = 1.0;  // factor of a bare number to metres
  double angle = 1.0;   // factor of a bare number to radians
  std::string length_name = "m", angle_name = "rad";
};

class Loader {
 public:
  // `include_stack` holds the files being read (for cycles and depth); `files_read` counts
  // every file of this load (for include fan-out).
  Loader(const LoadOptions& options, std::vector<std::string>* include_stack, int* files_read)
      : options_(options), stack_(include_stack), files_read_(files_read) {}

  ConstraintGraph Load(const std::string& display, const std::string& canonical,
                       const std::string& text, const std::string& base_dir);

 private:
  double Quantity1(const Document& doc, const YAML::Node& node, Quantity q, const char* what) const;
  Eigen::Vector3d Vector(const Document& doc, const YAML::Node& node, Quantity q,
                         const char* what) const;
  Rigid3d Pose(const Document& doc, const YAML::Node& node, const char* what) const;
  void ReadUnits(const Document& doc, const YAML::Node& node);
  void ReadIncludes(const Document& doc, const YAML::Node& node, const std::string& base_dir);
  void ReadComponents(const Document& doc, const YAML::Node& node);
  void ReadPoints(const Document& doc, const YAML::Node& node);
  void ReadMarkers(const Document& doc, const YAML::Node& node);
  void ReadJoints(const Document& doc, const YAML::Node& node);
  // A joint read but not yet added: joints are added parents first, and mimics once all exist.
  struct PendingJoint {
    JointSpec spec;
    YAML::Node key;
    YAML::Node mimic;
  };
  PendingJoint ReadJoint(const Document& doc, const YAML::Node& key, const YAML::Node& value,
                         const std::vector<PendingJoint>& pending) const;
  void ReadJointEnds(const Document& doc,
                     const std::vector<std::pair<YAML::Node, YAML::Node>>& entries,
                     const YAML::Node& value, const std::string& what,
                     const std::vector<PendingJoint>& pending, JointSpec* spec) const;
  void ReadJointMotion(const Document& doc,
                       const std::vector<std::pair<YAML::Node, YAML::Node>>& entries,
                       const YAML::Node& value, const std::string& what,
                       const std::string& type_name, JointSpec* spec) const;
  void AddJointsParentsFirst(const Document& doc, const std::vector<PendingJoint>& pending);
  void ReadMimic(const Document& doc, const PendingJoint& p);
  void ReadFixed(const Document& doc, const YAML::Node& node);
  void ReadConstraints(const Document& doc, const YAML::Node& node);
  int RequireComponent(const Document& doc, const YAML::Node& name_node, const char* role) const;

  const LoadOptions& options_;
  std::vector<std::string>* stack_;
  int* files_read_;
  std::unique_ptr<ModelBuilder> builder_;
  FileUnits units_;
};

double Loader::Quantity1(const Document& doc, const YAML::Node& node, Quantity q,
                         const char* what) const {
  const std::string s = doc.Scalar(node, what);
  // A bare number is in the file's units.
  const char* begin = s.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end != begin && *end == '\0' && errno == 0) {
    if (!std::isfinite(v)) doc.Fail(node, fmt::format("invalid {}: '{}' is not finite", what, s));
    // Dimensionless (quaternions, axes) as written; m/rad (a mimic multiplier) scaled by both.
    return v * std::pow(units_.length, q.length) * std::pow(units_.angle, q.angle);
  }
  const Lowerer lower(*builder_, doc.Origin(node));
  return lower.LowerConstantScalar(s, q, what);
}

Eigen::Vector3d Loader::Vector(const Document& doc, const YAML::Node& node, Quantity q,
                               const char* what) const {
  if (!node.IsSequence() || node.size() != 3) {
    doc.Fail(node, fmt::format("{} must be a list of 3 numbers [x, y, z]", what));
  }
  return {Quantity1(doc, node[0], q, what), Quantity1(doc, node[1], q, what),
          Quantity1(doc, node[2], q, what)};
}

Rigid3d Loader::Pose(const Document& doc, const YAML::Node& node, const char* what) const {
  const auto entries = doc.Entries(node, what, {"xyz", "rpy", "quaternion"});
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  if (YAML::Node n = Document::Find(entries, "xyz"); Present(n)) {
    xyz = Vector(doc, n, Quantity::Length(), "xyz");
  }
  const YAML::Node rpy = Document::Find(entries, "rpy");
  const YAML::Node quat = Document::Find(entries, "quaternion");
  if (Present(rpy) && Present(quat)) doc.Fail(quat, "give either rpy or quaternion, not both");
  if (Present(quat)) {
    if (!quat.IsSequence() || quat.size() != 4) {
      doc.Fail(quat, "quaternion must be a list of 4 numbers [w, x, y, z]");
    }
    double q[4];
    for (int i = 0; i < 4; ++i) q[i] = Quantity1(doc, quat[i], Quantity{}, "quaternion");
    Eigen::Quaterniond qq(q[0], q[1], q[2], q[3]);
    if (std::abs(qq.norm() - 1.0) > 1e-6) {
      doc.Fail(quat, fmt::format("quaternion [w, x, y, z] must have unit norm, it has {:.6g}",
                                 qq.norm()));
    }
    return Rigid3d(qq.normalized(), xyz);
  }
  Eigen::Vector3d angles = Eigen::Vector3d::Zero();
  if (Present(rpy)) angles = Vector(doc, rpy, Quantity::Angle(), "rpy");
  return Rigid3d::FromXyzRpy(xyz, angles);
}

void Loader::ReadUnits(const Document& doc, const YAML::Node& node) {
  for (const auto& [key, value] : doc.Entries(node, "units", {"length", "angle"})) {
    const std::string name = doc.Scalar(value, "a unit");
    const Unit* u = FindUnit(name);
    const bool length = key.Scalar() == "length";
    if (!u) doc.Fail(value, fmt::format("unknown unit '{}' (units: {})", name, KnownUnits()));
    if (!(u->quantity == (length ? Quantity::Length() : Quantity::Angle()))) {
      doc.Fail(value, fmt::format("'{}' is not a unit of {}", name, length ? "length" : "angle"));
    }
    (length ? units_.length : units_.angle) = u->factor;
    (length ? units_.length_name : units_.angle_name) = name;
  }
}

void Loader::ReadIncludes(const Document& doc, const YAML::Node& node,
                          const std::string& base_dir) {
  std::vector<YAML::Node> items;
  if (node.IsScalar() || node.IsMap()) {
    items.push_back(node);
  } else {
    if (!node.IsSequence()) {
      doc.Fail(node, "include takes a file name, a {file, prefix} mapping, or a list of them");
    }
    for (const YAML::Node& item : node) items.push_back(item);
  }
  for (const YAML::Node& item : items) {
    YAML::Node file_node = item;
    std::string prefix;
    if (item.IsMap()) {
      const auto entries = doc.Entries(item, "an include", {"file", "prefix"});
      // reset, not =: assigning to a YAML::Node writes through to the node it refers to, which
      // would turn `item` itself into the missing 'file' and lose its place for the message.
      file_node.reset(Document::Find(entries, "file"));
      if (!Present(file_node)) doc.Fail(item, "an include needs 'file'");
      if (YAML::Node p = Document::Find(entries, "prefix"); Present(p)) {
        prefix = doc.Scalar(p, "prefix");
        if (!ModelBuilder::IsIdentifier(prefix)) {
          doc.Fail(p, fmt::format("invalid prefix '{}': letters, digits and '_'", prefix));
        }
      }
    }
    const std::string relative = doc.Scalar(file_node, "an include's file");
    if (relative.empty()) doc.Fail(file_node, "an include's file name is empty");
    const SourceLocation where = doc.Loc(file_node);
    const std::string display = (fs::path(base_dir) / relative).lexically_normal().string();
    std::string ext = fs::path(relative).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));

    ConstraintGraph included;
    if (ext == ".yaml" || ext == ".yml") {
      if (++*files_read_ > kMaxIncludedFiles) {
        throw InputError(
            where, fmt::format("the model includes more than {} files in all", kMaxIncludedFiles));
      }
      if (static_cast<int>(stack_->size()) >= kMaxIncludeDepth) {
        throw InputError(where,
                         fmt::format("includes are nested more than {} deep", kMaxIncludeDepth));
      }
      std::error_code ec;
      const std::string canonical = fs::weakly_canonical(display, ec).string();
      for (const std::string& open : *stack_) {
        if (open == canonical) {
          std::string chain;
          for (const std::string& s : *stack_) chain += s + " -> ";
          throw InputError(where, fmt::format("include cycle: {}{}", chain, canonical));
        }
      }
      const std::string text = ReadTextFile(display, where, kModelFile);
      Loader child(options_, stack_, files_read_);
      included = child.Load(display, canonical, text, fs::path(display).parent_path().string());
    } else {
      const auto handler = options_.include_handlers.find(ext);
      if (handler == options_.include_handlers.end()) {
        throw InputError(where, fmt::format("cannot include '{}': no importer is registered for "
                                            "'{}' files (model files are .yaml or .yml)",
                                            relative, ext.empty() ? "extension-less" : ext));
      }
      // With an error code: a name too long for the file system would otherwise throw.
      if (std::error_code ec; !fs::exists(display, ec)) {
        throw InputError(where, fmt::format("cannot open '{}': {}", display,
                                            ec ? ec.message() : "no such file"));
      }
      included = handler->second(display, where);
    }
    builder_->Merge(included, prefix, where);
  }
}

void Loader::ReadComponents(const Document& doc, const YAML::Node& node) {
  for (const auto& [key, value] : doc.Entries(node, "components", {})) {
    const std::string name = key.Scalar();
    const std::string what = fmt::format("component '{}'", name);
    if (value.IsNull()) {
      doc.Fail(key, fmt::format("{} has no definition: give it points (or write '{}: {{}}' for a "
                                "component without feature points)",
                                what, name));
    }
    const auto entries = doc.Entries(value, what, {"pose", "points", "edges", "faces", "frames"});
    ModelBuilder::RequireIdentifier(name, "component", doc.Loc(key));
    std::optional<Rigid3d> pose;
    if (YAML::Node n = Document::Find(entries, "pose"); Present(n)) pose = Pose(doc, n, "pose");
    const int c = builder_->AddRigidComponent(name, pose, doc.Loc(key));

    if (YAML::Node frames = Document::Find(entries, "frames"); Present(frames)) {
      for (const auto& [fk, fv] : doc.Entries(frames, what + " frames", {})) {
        builder_->AddFrame(c, fk.Scalar(), Pose(doc, fv, "a frame"), doc.Loc(fk));
      }
    }
    if (YAML::Node points = Document::Find(entries, "points"); Present(points)) {
      for (const auto& [pk, pv] : doc.Entries(points, what + " points", {})) {
        builder_->AddFeaturePoint(c, pk.Scalar(),
                                  Vector(doc, pv, Quantity::Length(), "a point's coordinates"),
                                  doc.Loc(pk));
      }
    }
    auto point_index = [&](const YAML::Node& n) {
      const std::string p = doc.Scalar(n, "a point name");
      const int i = builder_->graph().components[c].FindPoint(p);
      if (i < 0) {
        std::vector<std::string> names;
        for (const FeaturePoint& fp : builder_->graph().components[c].points)
          names.push_back(fp.name);
        const std::string s = Suggest(p, names);
        doc.Fail(n, fmt::format("component '{}' has no point '{}'{}", name, p,
                                s.empty() ? "" : fmt::format(" (did you mean '{}'?)", s)));
      }
      return i;
    };
    if (YAML::Node edges = Document::Find(entries, "edges"); Present(edges)) {
      for (const auto& [ek, ev] : doc.Entries(edges, what + " edges", {})) {
        if (!ev.IsSequence() || ev.size() != 2) doc.Fail(ev, "an edge is a pair of points [a, b]");
        builder_->AddEdge(c, ek.Scalar(), point_index(ev[0]), point_index(ev[1]), doc.Loc(ek));
      }
    }
    if (YAML::Node faces = Document::Find(entries, "faces"); Present(faces)) {
      for (const auto& [fk, fv] : doc.Entries(faces, what + " faces", {})) {
        doc.RequireSequence(fv, "a face");
        std::vector<int> loop;
        for (const YAML::Node& p : fv) loop.push_back(point_index(p));
        builder_->AddFace(c, fk.Scalar(), std::move(loop), doc.Loc(fk));
      }
    }
  }
}

void Loader::ReadPoints(const Document& doc, const YAML::Node& node) {
  for (const auto& [key, value] : doc.Entries(node, "points", {})) {
    if (value.IsNull()) {
      doc.Fail(key, fmt::format("point '{}' has no coordinates [x, y, z]", key.Scalar()));
    }
    builder_->AddPointComponent(key.Scalar(),
                                Vector(doc, value, Quantity::Length(), "a point's coordinates"),
                                doc.Loc(key));
  }
}

// Named points fixed on a rigid component or on a frame of one (a URDF link merged into its
// parent's component), as from motion-capture markers: feature points of that component.
void Loader::ReadMarkers(const Document& doc, const YAML::Node& node) {
  for (const auto& [key, value] : doc.Entries(node, "markers", {})) {
    const std::string name = key.Scalar();
    const std::string what = fmt::format("marker '{}'", name);
    if (value.IsNull()) doc.Fail(key, fmt::format("{} needs 'link' and 'xyz'", what));
    const auto entries = doc.Entries(value, what, {"link", "xyz"});
    const YAML::Node link = Document::Find(entries, "link");
    const YAML::Node xyz = Document::Find(entries, "xyz");
    if (!Present(link)) doc.Fail(value, fmt::format("{} needs a 'link'", what));
    if (!Present(xyz))
      doc.Fail(value, fmt::format("{} needs 'xyz', its position on the link", what));
    const std::string frame = doc.Scalar(link, "a link");
    const auto found = builder_->FindFrame(frame);
    if (!found) {
      std::vector<std::string> names;
      for (const Component& c : builder_->graph().components) {
        if (!c.rigid) continue;
        names.push_back(c.name);
        for (const ComponentFrame& f : c.frames) names.push_back(f.name);
      }
      const std::string s = Suggest(frame, names);
      doc.Fail(link, fmt::format("{}: no rigid component or frame '{}'{}", what, frame,
                                 s.empty() ? "" : fmt::format(" (did you mean '{}'?)", s)));
    }
    const auto& [component, component_from_frame] = *found;
    builder_->AddFeaturePoint(
        component, name,
        component_from_frame * Vector(doc, xyz, Quantity::Length(), "a marker's position"),
        doc.Loc(key));
  }
}

int Loader::RequireComponent(const Document& doc, const YAML::Node& name_node,
                             const char* role) const {
  const std::string name = doc.Scalar(name_node, role);
  const int c = builder_->FindComponent(name);
  if (c < 0) {
    std::vector<std::string> names;
    for (const Component& comp : builder_->graph().components) names.push_back(comp.name);
    const std::string s = Suggest(name, names);
    doc.Fail(name_node, fmt::format("unknown component '{}'{}", name,
                                    s.empty() ? "" : fmt::format(" (did you mean '{}'?)", s)));
  }
  return c;
}

void Loader::ReadJoints(const Document& doc, const YAML::Node& node) {
  std::vector<PendingJoint> pending;
  for (const auto& [key, value] : doc.Entries(node, "joints", {})) {
    pending.push_back(ReadJoint(doc, key, value, pending));
  }
  AddJointsParentsFirst(doc, pending);
  // Mimics, once every joint exists.
  for (const PendingJoint& p : pending) {
    if (Present(p.mimic)) ReadMimic(doc, p);
  }
}

// One joint's entry; `pending`, the joints read before it.
Loader::PendingJoint Loader::ReadJoint(const Document& doc, const YAML::Node& key,
                                       const YAML::Node& value,
                                       const std::vector<PendingJoint>& pending) const {
  const std::string name = key.Scalar();
  const std::string what = fmt::format("joint '{}'", name);
  if (value.IsNull())
    doc.Fail(key, fmt::format("{} has no definition: it needs a type, a parent and a child", what));
  const auto entries = doc.Entries(
      value, what, {"type", "parent", "child", "origin", "axis", "limits", "position", "mimic"});
  JointSpec spec;
  spec.name = name;
  spec.where = doc.Loc(key);
  const YAML::Node type = Document::Find(entries, "type");
  if (!Present(type)) doc.Fail(value, fmt::format("{} needs a 'type'", what));
  const std::string type_name = doc.Scalar(type, "a joint type");
  const std::optional<JointType> t = ParseJointType(type_name);
  if (!t) {
    doc.Fail(type, fmt::format("unknown joint type '{}'; the types are revolute, continuous, "
                               "prismatic, spherical, fixed, planar, floating",
                               type_name));
  }
  spec.type = *t;
  ReadJointEnds(doc, entries, value, what, pending, &spec);
  if (YAML::Node n = Document::Find(entries, "origin"); Present(n)) {
    spec.parent_from_joint = Pose(doc, n, "origin");
  }
  ReadJointMotion(doc, entries, value, what, type_name, &spec);
  const YAML::Node mimic = Document::Find(entries, "mimic");
  if (Present(mimic) && !HasJointVariable(spec.type)) {
    doc.Fail(mimic, fmt::format("a {} joint has no variable to mimic with", type_name));
  }
  return {spec, key, mimic};
}

// The parent and the child: rigid components, the child not the parent and the child of no
// other joint (a kinematic loop is closed with a constraint).
void Loader::ReadJointEnds(const Document& doc,
                           const std::vector<std::pair<YAML::Node, YAML::Node>>& entries,
                           const YAML::Node& value, const std::string& what,
                           const std::vector<PendingJoint>& pending, JointSpec* spec) const {
  for (const char* role : {"parent", "child"}) {
    const YAML::Node n = Document::Find(entries, role);
    if (!Present(n)) doc.Fail(value, fmt::format("{} needs a '{}' component", what, role));
    const int c = RequireComponent(doc, n, role);
    // Refused here, at the component's name; ModelBuilder::AddJoint checks the same.
    const Component& comp = builder_->graph().components[c];
    if (!comp.rigid) {
      doc.Fail(n, fmt::format("{}: '{}' is a single-point component; joints connect rigid "
                              "components",
                              what, comp.name));
    }
    if (std::string(role) == "parent") {
      spec->parent = c;
      continue;
    }
    if (c == spec->parent) doc.Fail(n, fmt::format("{} connects '{}' to itself", what, comp.name));
    std::vector<std::pair<std::string, SourceLocation>> joints;  // earlier ones, with children
    for (const Joint& j : builder_->graph().joints) {
      if (j.child == c) joints.emplace_back(j.name, j.where);
    }
    for (const PendingJoint& p : pending) {
      if (p.spec.child == c) joints.emplace_back(p.spec.name, p.spec.where);
    }
    if (!joints.empty()) {
      doc.Fail(n, fmt::format("{}: component '{}' is already the child of joint '{}' (at {}); "
                              "close a kinematic loop with a constraint instead",
                              what, comp.name, joints[0].first, joints[0].second.ToString()));
    }
    spec->child = c;
  }
}

// The axis, limits and position, each where the joint's type has it.
void Loader::ReadJointMotion(const Document& doc,
                             const std::vector<std::pair<YAML::Node, YAML::Node>>& entries,
                             const YAML::Node& value, const std::string& what,
                             const std::string& type_name, JointSpec* spec) const {
  const bool has_variable = HasJointVariable(spec->type);
  const Quantity q = ModelOf(spec->type).VariableIsLength() ? Quantity::Length() : Quantity::Angle();
  const YAML::Node axis = Document::Find(entries, "axis");
  if (has_variable || spec->type == JointType::kPlanar) {
    if (!Present(axis)) doc.Fail(value, fmt::format("{} ({}) needs an 'axis'", what, type_name));
    spec->axis = Vector(doc, axis, Quantity{}, "axis");
    if (!(spec->axis.norm() > 1e-9))
      doc.Fail(axis, fmt::format("{}: the axis has zero length", what));
  } else if (Present(axis)) {
    doc.Fail(axis, fmt::format("a {} joint has no axis", type_name));
  }
  if (YAML::Node n = Document::Find(entries, "limits"); Present(n)) {
    if (!has_variable || spec->type == JointType::kContinuous) {
      doc.Fail(n, fmt::format("a {} joint has no limits{}", type_name,
                              spec->type == JointType::kContinuous ? " (use revolute)" : ""));
    }
    if (!n.IsSequence() || n.size() != 2) doc.Fail(n, "limits must be a list [lower, upper]");
    const double lo = Quantity1(doc, n[0], q, "lower limit");
    const double hi = Quantity1(doc, n[1], q, "upper limit");
    if (!(lo < hi))
      doc.Fail(n, fmt::format("{}: the lower limit is not below the upper limit", what));
    // [-90, 90] in a file whose angles are radians: degrees meant. Two turns either way is
    // beyond any revolute joint's travel (a joint that turns freely is continuous).
    if (spec->type == JointType::kRevolute && std::max(std::abs(lo), std::abs(hi)) > 4 * M_PI) {
      doc.Fail(n, fmt::format("{}: limits [{:g}, {:g}] rad are more than two turns from zero: "
                              "degrees meant? write them with 'deg' or declare units: {{angle: "
                              "deg}} (a joint that turns freely is continuous)",
                              what, lo, hi));
    }
    spec->limits = std::make_pair(lo, hi);
  }
  if (YAML::Node n = Document::Find(entries, "position"); Present(n)) {
    if (!has_variable) doc.Fail(n, fmt::format("a {} joint has no position", type_name));
    spec->position = Quantity1(doc, n, q, "joint position");
  }
}

// Parents first: a child's nominal pose may derive from its parent's.
void Loader::AddJointsParentsFirst(const Document& doc, const std::vector<PendingJoint>& pending) {
  std::vector<bool> done(pending.size(), false);
  for (size_t added = 0; added < pending.size();) {
    bool progress = false;
    for (size_t i = 0; i < pending.size(); ++i) {
      if (done[i]) continue;
      bool parent_ready = true;
      for (size_t j = 0; j < pending.size(); ++j) {
        if (!done[j] && j != i && pending[j].spec.child == pending[i].spec.parent)
          parent_ready = false;
      }
      if (!parent_ready) continue;
      builder_->AddJoint(pending[i].spec);
      done[i] = true;
      ++added;
      progress = true;
    }
    if (!progress) {
      // Walk up from any joint left: after pending.size() steps the walk is on the cycle.
      size_t i = 0;
      while (done[i]) ++i;
      for (size_t step = 0; step < pending.size(); ++step) {
        for (size_t j = 0; j < pending.size(); ++j) {
          if (!done[j] && pending[j].spec.child == pending[i].spec.parent) {
            i = j;
            break;
          }
        }
      }
      doc.Fail(pending[i].key,
               fmt::format("joint '{}' is part of a cycle of joints", pending[i].spec.name));
    }
  }
}

// A joint's mimic: q = multiplier * q_leader + offset.
void Loader::ReadMimic(const Document& doc, const PendingJoint& p) {
  const std::string what = fmt::format("joint '{}'", p.spec.name);
  const auto entries = doc.Entries(p.mimic, what + " mimic", {"joint", "multiplier", "offset"});
  const YAML::Node leader = Document::Find(entries, "joint");
  if (!Present(leader)) doc.Fail(p.mimic, fmt::format("{}: mimic needs a 'joint'", what));
  const std::string leader_name = doc.Scalar(leader, "a joint name");
  const int lead = builder_->FindJoint(leader_name);
  if (lead < 0) {
    std::vector<std::string> names;
    for (const Joint& j : builder_->graph().joints) names.push_back(j.name);
    const std::string s = Suggest(leader_name, names);
    doc.Fail(leader, fmt::format("{} mimics joint '{}', which does not exist{}", what, leader_name,
                                 s.empty() ? "" : fmt::format(" (did you mean '{}'?)", s)));
  }
  auto quantity = [](JointType t) {
    return ModelOf(t).VariableIsLength() ? Quantity::Length() : Quantity::Angle();
  };
  double multiplier = 1, offset = 0;
  if (YAML::Node m = Document::Find(entries, "multiplier"); Present(m)) {
    // In the follower's unit per the leader's: a number between two revolute joints.
    multiplier =
        Quantity1(doc, m, quantity(p.spec.type) / quantity(builder_->graph().joints[lead].type),
                  "mimic multiplier");
  }
  if (YAML::Node o = Document::Find(entries, "offset"); Present(o)) {
    offset = Quantity1(doc, o, quantity(p.spec.type), "mimic offset");
  }
  builder_->AddMimic(builder_->FindJoint(p.spec.name), lead, multiplier, offset, doc.Loc(p.mimic));
}

void Loader::ReadFixed(const Document& doc, const YAML::Node& node) {
  doc.RequireSequence(node, "fixed");
  for (const YAML::Node& item : node) {
    if (item.IsScalar()) {
      const int c = RequireComponent(doc, item, "a component");
      const Component& comp = builder_->graph().components[c];
      if (comp.rigid) {
        builder_->FixComponent(
            c, true, true,
            builder_->graph().nominal.poses[builder_->graph().blocks[comp.block].index],
            doc.Loc(item));
      } else {
        const Eigen::Vector3d p =
            builder_->graph().nominal.points[builder_->graph().blocks[comp.block].index];
        builder_->AddConstraint(builder_->UniqueConstraintName("fixed_" + comp.name),
                                ConstraintKind::kFixed, "fixed point",
                                EqualityResidual::Create(MakePointRef(comp.block),
                                                         MakeVectorConstant(p, Quantity::Length()),
                                                         builder_->Context()),
                                doc.Loc(item));
      }
      continue;
    }
    const auto entries = doc.Entries(item, "a fixed entry", {"component", "point", "fix", "at"});
    const YAML::Node comp_node = Document::Find(entries, "component");
    const YAML::Node point_node = Document::Find(entries, "point");
    const YAML::Node at = Document::Find(entries, "at");
    if (Present(comp_node) == Present(point_node)) {
      doc.Fail(item, "a fixed entry names either a 'component' or a 'point'");
    }
    if (Present(point_node)) {
      if (Present(Document::Find(entries, "fix"))) doc.Fail(item, "'fix' applies to components");
      const std::string ref = doc.Scalar(point_node, "a point");
      const Lowerer lower(*builder_, doc.Origin(point_node));
      std::unique_ptr<AstNode> ast;
      try {
        ast = ParseExpression(ref);
      } catch (const ExprSyntaxError& e) {
        const TextOrigin o = doc.Origin(point_node);
        throw InputError(o.At(e.offset()), SyntaxMessageInFile(e, o.line, o.column, o.exact));
      }
      if (ast->kind != AstNode::Kind::kRef)
        doc.Fail(point_node, "'point' names a point, e.g. lid.c3");
      const ExprPtr p = lower.Lower(*ast, nullptr);
      Eigen::Vector3d target;
      if (Present(at)) {
        target = Vector(doc, at, Quantity::Length(), "at");
      } else {
        // The point's nominal position: its expression bound to slots, at the nominal values.
        std::vector<ExprPtr> bound = {p};
        const std::vector<int> blocks = BindSlots(&bound);
        const std::vector<BlockState<double>> states =
            GatherStates(builder_->graph().blocks, blocks, builder_->graph().nominal);
        target = Evaluate<double>(*bound[0], std::span<const BlockState<double>>(states));
      }
      builder_->AddConstraint(
          builder_->UniqueConstraintName("fixed_" + std::string(ast->name) +
                                         (ast->member.empty() ? "" : "_" + ast->member)),
          ConstraintKind::kFixed, "fixed point",
          EqualityResidual::Create(p, MakeVectorConstant(target, Quantity::Length()),
                                   builder_->Context()),
          doc.Loc(item));
      continue;
    }
    const int c = RequireComponent(doc, comp_node, "a component");
    const Component& comp = builder_->graph().components[c];
    if (!comp.rigid) {
      doc.Fail(comp_node, fmt::format("'{}' is a single-point component: fix it with 'point: {}'",
                                      comp.name, comp.name));
    }
    std::string fix = "pose";
    if (YAML::Node f = Document::Find(entries, "fix"); Present(f)) {
      fix = doc.Scalar(f, "fix");
      if (fix != "pose" && fix != "position" && fix != "orientation") {
        doc.Fail(f, fmt::format("unknown fix '{}': pose, position or orientation", fix));
      }
    }
    Rigid3d target = builder_->graph().nominal.poses[builder_->graph().blocks[comp.block].index];
    if (Present(at)) target = Pose(doc, at, "at");
    builder_->FixComponent(c, fix != "orientation", fix != "position", target, doc.Loc(item));
  }
}

void Loader::ReadConstraints(const Document& doc, const YAML::Node& node) {
  doc.RequireSequence(node, "constraints");
  int index = 0;
  for (const YAML::Node& item : node) {
    ++index;
    YAML::Node expr = item;
    std::string name;
    if (item.IsMap()) {
      const auto entries = doc.Entries(item, "a constraint", {"name", "expr"});
      expr.reset(Document::Find(entries, "expr"));  // not =, which writes through to `item`
      if (!Present(expr)) doc.Fail(item, "a constraint needs 'expr'");
      if (YAML::Node n = Document::Find(entries, "name"); Present(n)) {
        name = doc.Scalar(n, "a constraint name");
        ModelBuilder::RequireIdentifier(name, "constraint", doc.Loc(n));
        // Refused here, at the name, rather than where the constraint's expression is.
        if (const int k = builder_->FindConstraint(name); k >= 0) {
          const SourceLocation& first = builder_->graph().constraints[k].where;
          doc.Fail(n, fmt::format("duplicate constraint name '{}', first defined{}", name,
                                  first.known() ? " (at " + first.ToString() + ")" : ""));
        }
      }
    }
    if (!expr.IsScalar()) {
      doc.Fail(expr, "a constraint is an expression string, e.g. 'distance(a, b) == 30 mm'");
    }
    if (name.empty()) {
      // cN, unless a point or component has that name (a box's corners c000..c111, a lamp's
      // c1): messages would then name two different things alike.
      std::string automatic = fmt::format("c{}", index);
      if (builder_->FindComponent(automatic) >= 0 || !builder_->FindBarePoint(automatic).empty() ||
          builder_->FindFrame(automatic)) {
        automatic = fmt::format("constraint_{}", index);
      }
      name = builder_->UniqueConstraintName(automatic);
    }
    const Lowerer lower(*builder_, doc.Origin(expr));
    lower.AddConstraint(builder_.get(), expr.Scalar(), name);
  }
}

ConstraintGraph Loader::Load(const std::string& display, const std::string& canonical,
                             const std::string& text, const std::string& base_dir) {
  CheckText(display, text, kModelFile);
  // Without a byte-order mark, yaml-cpp's offsets index the text (see Document::Origin).
  const bool bom = text.compare(0, 3, "\xEF\xBB\xBF") == 0;
  const Document doc(display, bom ? text.substr(3) : text, kModelFile);
  const YAML::Node root = doc.Parse();
  if (!root.IsMap()) {
    if (root.IsNull())
      throw InputError(SourceLocation(display),
                       "file is empty: a model needs components or points");
    doc.Fail(root,
             "a model file is a mapping with keys such as components, points, joints, constraints");
  }
  const auto entries = doc.Entries(root, "the model",
                                   {"name", "units", "include", "components", "points", "markers",
                                    "joints", "fixed", "constraints"});
  std::string name = fs::path(display).stem().string();
  if (YAML::Node n = Document::Find(entries, "name"); Present(n)) name = doc.Scalar(n, "name");
  builder_ = std::make_unique<ModelBuilder>(name, display);
  stack_->push_back(canonical);

  if (YAML::Node n = Document::Find(entries, "units"); Present(n)) ReadUnits(doc, n);
  if (YAML::Node n = Document::Find(entries, "include"); Present(n)) ReadIncludes(doc, n, base_dir);
  if (YAML::Node n = Document::Find(entries, "components"); Present(n)) ReadComponents(doc, n);
  if (YAML::Node n = Document::Find(entries, "points"); Present(n)) ReadPoints(doc, n);
  if (YAML::Node n = Document::Find(entries, "markers"); Present(n)) ReadMarkers(doc, n);
  if (YAML::Node n = Document::Find(entries, "joints"); Present(n)) ReadJoints(doc, n);
  if (YAML::Node n = Document::Find(entries, "fixed"); Present(n)) ReadFixed(doc, n);
  if (YAML::Node n = Document::Find(entries, "constraints"); Present(n)) ReadConstraints(doc, n);

  if (builder_->graph().components.empty()) {
    throw InputError(SourceLocation(display), "the model has no components or points");
  }
  stack_->pop_back();
  return std::move(*builder_).Build();
}

}  // namespace

ConstraintGraph LoadModel(const std::string& path, const LoadOptions& options) {
  const std::string text = ReadTextFile(path, SourceLocation(), kModelFile);
  std::error_code ec;
  const std::string canonical = fs::weakly_canonical(path, ec).string();
  std::vector<std::string> stack;
  int files_read = 0;
  Loader loader(options, &stack, &files_read);
  return loader.Load(path, canonical, text, fs::path(path).parent_path().string());
}

ConstraintGraph LoadModelFromString(std::string_view text, const std::string& display_name,
                                    const std::string& base_directory, const LoadOptions& options) {
  std::vector<std::string> stack;
  int files_read = 0;
  Loader loader(options, &stack, &files_read);
  return loader.Load(display_name, display_name, std::string(text), base_directory);
}

}  // namespace cfuse
