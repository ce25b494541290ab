#include "cfuse/importers/urdf.h"

#include <console_bridge/console.h>
#include <fmt/format.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <vector>

#include "cfuse/constraints/model_builder.h"
#include "read_file.h"
#include "xml_document.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// urdfdom reports through console_bridge; its errors are collected while it parses (and the
// previous handler restored), to be shown in the InputError instead of on stderr.
class CollectedMessages : public console_bridge::OutputHandler {
 public:
  CollectedMessages() { console_bridge::useOutputHandler(this); }
  ~CollectedMessages() override { console_bridge::restorePreviousOutputHandler(); }
  CollectedMessages(const CollectedMessages&) = delete;
  CollectedMessages& operator=(const CollectedMessages&) = delete;

  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) errors.push_back(text);
  }
  std::vector<std::string> errors;
};

std::string Identifier(const std::string& name) {
  std::string out = name;
  for (char& c : out) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
  }
  if (out.empty() || std::isdigit(static_cast<unsigned char>(out[0]))) out = "_" + out;
  return out;
}

Rigid3d ToRigid(const urdf::Pose& p) {
  Eigen::Quaterniond q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
  return Rigid3d(q.normalized(), Eigen::Vector3d(p.position.x, p.position.y, p.position.z));
}

struct XmlJoint {
  std::string name, type, parent, child;
  const TiXmlElement* element = nullptr;
  const TiXmlElement* parent_element = nullptr;
  const TiXmlElement* child_element = nullptr;
  const TiXmlElement* mimic_element = nullptr;
  bool locked = false;  // revolute or prismatic with lower = upper
  double locked_at = 0;
};

class UrdfReader {
 public:
  UrdfReader(std::string file, std::string_view xml) : file_(std::move(file)), xml_(xml) {}

  ConstraintGraph Read() {
    CheckXml();
    const urdf::ModelInterfaceSharedPtr model = ParseWithUrdfdom();
    return Build(*model);
  }

 private:
  SourceLocation Loc(const TiXmlBase* node, const std::string& element = "") const {
    return SourceLocation(file_, node->Row(), node->Column(), element);
  }
  [[noreturn]] void Fail(const TiXmlBase* node, const std::string& element,
                         const std::string& message) const {
    throw InputError(Loc(node, element), message);
  }

  // `count` finite numbers separated by spaces in attribute `attribute` of `e`, or `fallback`
  // when the attribute is absent (nullopt: required).
  std::vector<double> Numbers(const TiXmlElement* e, const char* attribute, size_t count,
                              const std::string& element,
                              std::optional<std::vector<double>> fallback) const {
    const char* text = e->Attribute(attribute);
    if (!text) {
      if (fallback) return *fallback;
      Fail(e, element, fmt::format("<{}> needs the attribute '{}'", e->Value(), attribute));
    }
    std::vector<double> out;
    const char* p = text;
    for (;;) {
      while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
      if (!*p) break;
      char* end = nullptr;
      const double v = std::strtod(p, &end);
      if (end == p || !std::isfinite(v) ||
          (*end && *end != ' ' && *end != '\t' && *end != '\n' && *end != '\r')) {
        Fail(e, element,
             fmt::format("<{} {}=\"{}\">: not {} finite number{}", e->Value(), attribute, text,
                         count, count == 1 ? "" : "s"));
      }
      out.push_back(v);
      p = end;
    }
    if (out.size() != count) {
      Fail(e, element,
           fmt::format("<{} {}=\"{}\">: expected {} number{}, found {}", e->Value(), attribute,
                       text, count, count == 1 ? "" : "s", out.size()));
    }
    return out;
  }

  void CheckOrigin(const TiXmlElement* parent, const std::string& element) const {
    if (const TiXmlElement* o = parent->FirstChildElement("origin")) {
      Numbers(o, "xyz", 3, element, std::vector<double>(3, 0.0));
      Numbers(o, "rpy", 3, element, std::vector<double>(3, 0.0));
    }
  }

  // What urdfdom refuses without a location, and what a model cannot hold.
  void CheckXml() {
    ParseXml(file_, xml_, &doc_);
    robot_ = doc_.RootElement();
    if (!robot_) throw InputError(SourceLocation(file_), "not a URDF file: no root element");
    if (std::strcmp(robot_->Value(), "robot") != 0) {
      Fail(robot_, "",
           fmt::format("not a URDF file: the root element is <{}>, not <robot>", robot_->Value()));
    }
    if (!robot_->Attribute("name")) Fail(robot_, "", "<robot> needs a 'name'");
    CheckLinks();
    CheckJoints();
    CheckTree();
  }

  // Each <link>: a name no other link has, and the numbers of its visuals and collisions.
  void CheckLinks() {
    for (const TiXmlElement* e = robot_->FirstChildElement("link"); e;
         e = e->NextSiblingElement("link")) {
      const char* name = e->Attribute("name");
      if (!name || !*name) Fail(e, "", "a <link> needs a 'name'");
      const std::string element = fmt::format("link '{}'", name);
      if (link_index_.count(name)) {
        Fail(e, element,
             fmt::format("duplicate link name '{}', first defined at line {}", name,
                         links_[link_index_[name]]->Row()));
      }
      link_index_[name] = static_cast<int>(links_.size());
      links_.push_back(e);
      for (const char* kind : {"visual", "collision"}) {
        for (const TiXmlElement* g = e->FirstChildElement(kind); g;
             g = g->NextSiblingElement(kind)) {
          CheckOrigin(g, element);
          CheckGeometry(g, element);
        }
      }
    }
    if (links_.empty()) Fail(robot_, "", "the robot has no <link>");
  }

  // Each <joint> (CheckJoint), then the joint each <mimic> names, once all are known.
  void CheckJoints() {
    std::map<std::string, int> joint_index;
    for (const TiXmlElement* e = robot_->FirstChildElement("joint"); e;
         e = e->NextSiblingElement("joint")) {
      XmlJoint j = CheckJoint(e, joint_index);
      joint_index[j.name] = static_cast<int>(joints_.size());
      joints_.push_back(std::move(j));
    }
    for (const XmlJoint& j : joints_) {
      if (!j.mimic_element) continue;
      const std::string leader = j.mimic_element->Attribute("joint");
      const std::string element = fmt::format("joint '{}'", j.name);
      if (!joint_index.count(leader)) {
        Fail(j.mimic_element, element,
             fmt::format("mimics joint '{}', which does not exist", leader));
      }
      if (leader == j.name) Fail(j.mimic_element, element, "mimics itself");
    }
  }

  // One <joint>: a name no earlier joint has (`joint_index`), a known type, two different known
  // links, then its numbers (CheckJointNumbers).
  XmlJoint CheckJoint(const TiXmlElement* e, const std::map<std::string, int>& joint_index) const {
    XmlJoint j;
    j.element = e;
    const char* name = e->Attribute("name");
    if (!name || !*name) Fail(e, "", "a <joint> needs a 'name'");
    j.name = name;
    const std::string element = fmt::format("joint '{}'", j.name);
    if (joint_index.count(j.name)) {
      Fail(e, element,
           fmt::format("duplicate joint name '{}', first defined at line {}", j.name,
                       joints_[joint_index.at(j.name)].element->Row()));
    }
    const char* type = e->Attribute("type");
    if (!type) Fail(e, element, "a <joint> needs a 'type'");
    j.type = type;
    static const char* const kTypes[] = {"revolute", "continuous", "prismatic",
                                         "fixed",    "floating",   "planar"};
    if (std::none_of(std::begin(kTypes), std::end(kTypes),
                     [&](const char* t) { return j.type == t; })) {
      Fail(e, element,
           fmt::format("unknown joint type '{}'; the types are revolute, "
                       "continuous, prismatic, fixed, floating, planar",
                       j.type));
    }
    for (const char* role : {"parent", "child"}) {
      const TiXmlElement* r = e->FirstChildElement(role);
      if (!r) Fail(e, element, fmt::format("a <joint> needs a <{}>", role));
      const char* link = r->Attribute("link");
      if (!link) Fail(r, element, fmt::format("<{}> needs a 'link'", role));
      if (!link_index_.count(link)) {
        Fail(r, element, fmt::format("unknown {} link '{}'", role, link));
      }
      (std::strcmp(role, "parent") == 0 ? j.parent : j.child) = link;
      (std::strcmp(role, "parent") == 0 ? j.parent_element : j.child_element) = r;
    }
    if (j.parent == j.child) {
      Fail(j.child_element, element, fmt::format("joins link '{}' to itself", j.parent));
    }
    CheckJointNumbers(e, element, &j);
    return j;
  }

  // A joint's origin, axis, limits and mimic; a revolute or prismatic joint whose limits meet is
  // locked.
  void CheckJointNumbers(const TiXmlElement* e, const std::string& element, XmlJoint* j) const {
    CheckOrigin(e, element);
    const bool has_axis = j->type != "fixed" && j->type != "floating";
    if (const TiXmlElement* a = e->FirstChildElement("axis"); a && has_axis) {
      const std::vector<double> v = Numbers(a, "xyz", 3, element, std::nullopt);
      if (!(std::hypot(v[0], v[1], v[2]) > 1e-9)) {
        Fail(a, element, "the axis has zero length");
      }
    }
    const TiXmlElement* limit = e->FirstChildElement("limit");
    if (j->type == "revolute" || j->type == "prismatic") {
      if (!limit) Fail(e, element, fmt::format("a {} joint needs a <limit>", j->type));
      const double lower = Numbers(limit, "lower", 1, element, std::vector<double>{0})[0];
      const double upper = Numbers(limit, "upper", 1, element, std::vector<double>{0})[0];
      if (lower > upper) {
        Fail(limit, element,
             fmt::format("inverted limits: lower {} is above upper {}", lower, upper));
      }
      j->locked = lower == upper;
      j->locked_at = lower;
    }
    if (limit) {
      for (const char* attribute : {"effort", "velocity"}) {
        if (limit->Attribute(attribute)) Numbers(limit, attribute, 1, element, std::nullopt);
      }
    }
    if (const TiXmlElement* m = e->FirstChildElement("mimic")) {
      j->mimic_element = m;
      if (!m->Attribute("joint")) Fail(m, element, "<mimic> needs a 'joint'");
      Numbers(m, "multiplier", 1, element, std::vector<double>{1});
      Numbers(m, "offset", 1, element, std::vector<double>{0});
    }
  }

  // One tree: every link the child of at most one joint, one root, no cycle.
  void CheckTree() {
    parent_joint_.assign(links_.size(), -1);
    children_.assign(links_.size(), {});
    for (size_t i = 0; i < joints_.size(); ++i) {
      const XmlJoint& j = joints_[i];
      const int child = link_index_[j.child];
      if (parent_joint_[child] >= 0) {
        const XmlJoint& first = joints_[parent_joint_[child]];
        Fail(j.child_element, fmt::format("joint '{}'", j.name),
             fmt::format("link '{}' is already the child of joint '{}' (at line {}): a URDF is "
                         "a tree",
                         j.child, first.name, first.element->Row()));
      }
      parent_joint_[child] = static_cast<int>(i);
      children_[link_index_[j.parent]].push_back(static_cast<int>(i));
    }
    for (size_t l = 0; l < links_.size(); ++l) {
      if (parent_joint_[l] >= 0) continue;
      if (root_ >= 0) {
        Fail(links_[l], fmt::format("link '{}'", links_[l]->Attribute("name")),
             fmt::format("a second root link: '{}' (line {}) and '{}' are both no joint's "
                         "child; a URDF has one root",
                         links_[root_]->Attribute("name"), links_[root_]->Row(),
                         links_[l]->Attribute("name")));
      }
      root_ = static_cast<int>(l);
    }
    // Breadth first from the root; a link not reached hangs on a cycle.
    std::vector<bool> reached(links_.size(), false);
    if (root_ >= 0) {
      order_.push_back(root_);
      reached[root_] = true;
    }
    for (size_t k = 0; k < order_.size(); ++k) {
      for (int j : children_[order_[k]]) {
        const int child = link_index_[joints_[j].child];
        order_.push_back(child);
        reached[child] = true;
      }
    }
    for (size_t l = 0; l < links_.size(); ++l) {
      if (reached[l]) continue;
      const XmlJoint& j = joints_[parent_joint_[l]];
      Fail(j.element, fmt::format("joint '{}'", j.name),
           root_ < 0 ? std::string("every link is a joint's child: the joints form a cycle")
                     : fmt::format("joint '{}' is part of a cycle of joints", j.name));
    }
  }

  void CheckGeometry(const TiXmlElement* g, const std::string& element) const {
    const TiXmlElement* geometry = g->FirstChildElement("geometry");
    if (!geometry) return;  // urdfdom refuses it, with its own message
    const TiXmlElement* shape = geometry->FirstChildElement();
    if (!shape) Fail(geometry, element, "<geometry> has no shape");
    const std::string kind = shape->Value();
    auto positive = [&](const char* attribute, size_t count) {
      for (double v : Numbers(shape, attribute, count, element, std::nullopt)) {
        if (!(v >= 0)) Fail(shape, element, fmt::format("<{}> {} is negative", kind, attribute));
      }
    };
    if (kind == "box") {
      positive("size", 3);
    } else if (kind == "cylinder") {
      positive("radius", 1);
      positive("length", 1);
    } else if (kind == "sphere") {
      positive("radius", 1);
    } else if (kind != "mesh") {
      Fail(shape, element,
           fmt::format("unknown geometry <{}>: box, cylinder, sphere or mesh", kind));
    }
  }

  urdf::ModelInterfaceSharedPtr ParseWithUrdfdom() const {
    CollectedMessages messages;
    urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(std::string(xml_));
    if (!model) {
      std::string why;
      for (const std::string& e : messages.errors) why += (why.empty() ? "" : "; ") + e;
      throw InputError(UrdfdomLocation(why), fmt::format("urdfdom cannot read this URDF{}{}",
                                                         why.empty() ? "" : ": ", why));
    }
    return model;
  }

  // urdfdom names the joint or link it refuses ("... for joint [j]") but not its line: the
  // element of that name, else the file.
  SourceLocation UrdfdomLocation(const std::string& why) const {
    static const std::regex kNamed(R"((joint|link)\s*\[([^\]]*)\])", std::regex::icase);
    std::smatch m;
    if (!std::regex_search(why, m, kNamed)) return SourceLocation(file_);
    const std::string name = m[2].str();
    if (std::tolower(static_cast<unsigned char>(m[1].str()[0])) == 'j') {
      for (const XmlJoint& j : joints_) {
        if (j.name == name) return Loc(j.element, fmt::format("joint '{}'", name));
      }
    } else if (const auto it = link_index_.find(name); it != link_index_.end()) {
      return Loc(links_[it->second], fmt::format("link '{}'", name));
    }
    return SourceLocation(file_);
  }

  // Per link: the link whose component holds it (the nearest ancestor joined by a joint that
  // moves) and its frame in that component's.
  ConstraintGraph Build(const urdf::ModelInterface& model) {
    ModelBuilder builder(robot_->Attribute("name"), file_);
    const int n = static_cast<int>(links_.size());
    std::vector<int> rep(n, -1);
    std::vector<Rigid3d> rep_from_link(n);
    auto merged = [&](const XmlJoint& j) { return j.type == "fixed" || j.locked; };
    for (int l : order_) {
      const int pj = parent_joint_[l];
      if (pj < 0 || !merged(joints_[pj])) {
        rep[l] = l;
        continue;
      }
      const XmlJoint& j = joints_[pj];
      const urdf::JointConstSharedPtr uj = model.getJoint(j.name);
      const int parent = link_index_[j.parent];
      rep[l] = rep[parent];
      Rigid3d motion;
      if (j.locked) {
        const Eigen::Vector3d axis =
            Eigen::Vector3d(uj->axis.x, uj->axis.y, uj->axis.z).normalized();
        motion = JointMotion(j.type == "revolute" ? JointType::kRevolute : JointType::kPrismatic,
                             axis, j.locked_at);
      }
      rep_from_link[l] =
          rep_from_link[parent] * ToRigid(uj->parent_to_joint_origin_transform) * motion;
    }
    auto link_name = [&](int l) { return std::string(links_[l]->Attribute("name")); };
    auto link_where = [&](int l) { return Loc(links_[l], fmt::format("link '{}'", link_name(l))); };
    std::vector<int> component(n, -1);
    for (int l : order_) {
      if (rep[l] != l) continue;
      component[l] = builder.AddRigidComponent(
          Identifier(link_name(l)), l == root_ ? std::optional<Rigid3d>(Rigid3d()) : std::nullopt,
          link_where(l));
    }
    for (int l : order_) {
      const int c = component[rep[l]];
      const std::string prefix = rep[l] == l ? "" : Identifier(link_name(l)) + "_";
      if (rep[l] != l)
        builder.AddFrame(c, Identifier(link_name(l)), rep_from_link[l], link_where(l));
      builder.AddFeaturePoint(c, prefix + "origin", rep_from_link[l].translation, link_where(l));
      AddGeometryPoints(*model.getLink(link_name(l)), rep_from_link[l], prefix, c, link_where(l),
                        &builder);
    }
    for (int l : order_) {
      const int pj = parent_joint_[l];
      if (pj >= 0 && merged(joints_[pj])) {
        const XmlJoint& j = joints_[pj];
        builder.AddMergedJoint(Identifier(j.name),
                               j.locked ? std::optional<double>(j.locked_at) : std::nullopt,
                               Loc(j.element, fmt::format("joint '{}'", j.name)));
      }
    }
    for (int l : order_) {
      const int pj = parent_joint_[l];
      if (pj < 0 || merged(joints_[pj])) continue;
      const XmlJoint& j = joints_[pj];
      const urdf::JointConstSharedPtr uj = model.getJoint(j.name);
      const int parent = link_index_[j.parent];
      JointSpec spec;
      spec.name = Identifier(j.name);
      spec.where = Loc(j.element, fmt::format("joint '{}'", j.name));
      spec.type = *ParseJointType(j.type);
      spec.parent = component[rep[parent]];
      spec.child = component[l];
      spec.parent_from_joint =
          rep_from_link[parent] * ToRigid(uj->parent_to_joint_origin_transform);
      if (spec.type != JointType::kFloating) {
        spec.axis = Eigen::Vector3d(uj->axis.x, uj->axis.y, uj->axis.z);
      }
      // A mimic joint's own <limit> is not imposed: its variable follows its leader's, whose
      // limits hold. It is often copied from the leader's and then contradicts the mimic: PR2's
      // r_gripper_r_parallel_root_joint (multiplier -1, limits [0, 0.548]) would lock its
      // gripper at 0.
      if ((spec.type == JointType::kRevolute || spec.type == JointType::kPrismatic) && uj->limits &&
          !j.mimic_element) {
        spec.limits = std::make_pair(uj->limits->lower, uj->limits->upper);
      }
      builder.AddJoint(spec);
    }
    for (const XmlJoint& j : joints_) {
      if (!j.mimic_element) continue;
      const std::string element = fmt::format("joint '{}'", j.name);
      const urdf::JointConstSharedPtr uj = model.getJoint(j.name);
      const std::string leader = j.mimic_element->Attribute("joint");
      const int follower = builder.FindJoint(Identifier(j.name));
      const int lead = builder.FindJoint(Identifier(leader));
      if (follower < 0) {
        Fail(j.mimic_element, element,
             fmt::format("a {} joint cannot mimic: it has no variable",
                         j.locked ? "locked (lower = upper)" : j.type));
      }
      if (lead < 0) {
        Fail(j.mimic_element, element,
             fmt::format("mimics joint '{}', which has no variable (fixed, or locked by equal "
                         "limits)",
                         leader));
      }
      builder.AddMimic(follower, lead, uj->mimic ? uj->mimic->multiplier : 1.0,
                       uj->mimic ? uj->mimic->offset : 0.0, Loc(j.mimic_element, element));
    }
    ConstraintGraph graph = std::move(builder).Build();
    Respell(&graph);
    return graph;
  }

  // Links and joints go by the URDF's own names in results and look-ups; the identifiers they
  // were built under (which model files need, to refer to them) stay as aliases. A name that
  // would break a CSV column or a `name=value` list keeps its identifier, the URDF's spelling
  // then the alias.
  void Respell(ConstraintGraph* graph) const {
    std::map<std::string, std::string> spelling;  // identifier -> URDF name
    for (const TiXmlElement* link : links_) {
      const std::string name = link->Attribute("name");
      spelling.emplace(Identifier(name), name);
    }
    for (const XmlJoint& j : joints_) spelling.emplace(Identifier(j.name), j.name);
    auto respell = [&](auto& item) {
      const auto it = spelling.find(item.name);
      if (it == spelling.end() || it->second == item.name) return;
      const bool plain = std::none_of(it->second.begin(), it->second.end(), [](char c) {
        return std::isspace(static_cast<unsigned char>(c)) ||
               std::iscntrl(static_cast<unsigned char>(c)) || c == ',' || c == '"' || c == '=';
      });
      if (plain) {
        item.alias = item.name;
        item.name = it->second;
      } else {
        item.alias = it->second;
      }
    };
    for (Component& c : graph->components) {
      respell(c);
      for (ComponentFrame& f : c.frames) respell(f);
    }
    for (Joint& j : graph->joints) respell(j);
    for (MergedJoint& m : graph->merged_joints) respell(m);
  }

  // The link's points from its visual and collision geometry (see urdf.h), in the component's
  // frame.
  static void AddGeometryPoints(const urdf::Link& link, const Rigid3d& component_from_link,
                                const std::string& prefix, int component,
                                const SourceLocation& where, ModelBuilder* builder) {
    std::map<std::string, int> count;
    std::vector<std::pair<std::string, std::vector<Eigen::Vector3d>>> done;
    auto add = [&](const urdf::Pose& origin, const urdf::GeometrySharedPtr& geometry) {
      if (!geometry) return;
      const Rigid3d link_from_geometry = ToRigid(origin);
      std::string kind;
      std::vector<std::pair<std::string, Eigen::Vector3d>> points;
      switch (geometry->type) {
        case urdf::Geometry::BOX: {
          const auto& d = static_cast<const urdf::Box&>(*geometry).dim;
          kind = "box";
          for (int i = 0; i < 8; ++i) {
            points.emplace_back(
                fmt::format("_c{}", i),
                Eigen::Vector3d((i & 1 ? 0.5 : -0.5) * d.x, (i & 2 ? 0.5 : -0.5) * d.y,
                                (i & 4 ? 0.5 : -0.5) * d.z));
          }
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const double h = 0.5 * static_cast<const urdf::Cylinder&>(*geometry).length;
          kind = "cyl";
          points.emplace_back("_top", Eigen::Vector3d(0, 0, h));
          points.emplace_back("_bottom", Eigen::Vector3d(0, 0, -h));
          break;
        }
        case urdf::Geometry::SPHERE:
          kind = "sphere";
          points.emplace_back("", Eigen::Vector3d::Zero());
          break;
        case urdf::Geometry::MESH:
          return;  // referenced, not loaded
      }
      std::vector<Eigen::Vector3d> positions;
      for (auto& [suffix, p] : points) {
        p = component_from_link * (link_from_geometry * p);
        positions.push_back(p);
      }
      for (const auto& [k, earlier] : done) {
        if (k != kind) continue;
        bool same = true;
        for (size_t i = 0; i < positions.size() && same; ++i) {
          same = (positions[i] - earlier[i]).norm() <= 1e-12 * (1 + positions[i].norm());
        }
        if (same) return;  // the collision shape repeats the visual one
      }
      const int k = count[kind]++;
      std::vector<int> index;
      for (const auto& [suffix, p] : points) {
        index.push_back(builder->AddFeaturePoint(
            component, fmt::format("{}{}{}{}", prefix, kind, k, suffix), p, where));
      }
      if (kind == "box") {
        // Its six faces, counter-clockwise seen from outside (corner i has bit 0, 1, 2 for
        // +x, +y, +z): their sides are the edges the tracker matches.
        static constexpr std::array<std::pair<const char*, std::array<int, 4>>, 6> kFaces = {{
            {"_nx", {0, 4, 6, 2}},
            {"_px", {1, 3, 7, 5}},
            {"_ny", {0, 1, 5, 4}},
            {"_py", {2, 6, 7, 3}},
            {"_nz", {0, 2, 3, 1}},
            {"_pz", {4, 5, 7, 6}},
        }};
        for (const auto& [suffix, loop] : kFaces) {
          builder->AddFace(component, fmt::format("{}{}{}{}", prefix, kind, k, suffix),
                           {index[loop[0]], index[loop[1]], index[loop[2]], index[loop[3]]}, where);
        }
      }
      done.emplace_back(kind, std::move(positions));
    };
    for (const urdf::VisualSharedPtr& v : link.visual_array) {
      if (v) add(v->origin, v->geometry);
    }
    for (const urdf::CollisionSharedPtr& c : link.collision_array) {
      if (c) add(c->origin, c->geometry);
    }
  }

  std::string file_;
  std::string_view xml_;
  TiXmlDocument doc_;
  const TiXmlElement* robot_ = nullptr;
  std::vector<const TiXmlElement*> links_;
  std::map<std::string, int> link_index_;
  std::vector<XmlJoint> joints_;
  std::vector<int> parent_joint_;           // per link: the joint whose child it is, or -1
  std::vector<std::vector<int>> children_;  // per link: the joints whose parent it is
  int root_ = -1;
  std::vector<int> order_;  // links breadth first from the root
};

}  // namespace

ConstraintGraph ImportUrdfFromString(std::string_view xml, const std::string& display_name) {
  // TinyXML takes any bytes into names, which `cfuse import` would write into a model file that
  // no reader accepts (found by fuzz/urdf_fuzz.cpp).
  RequireText(display_name, xml, "URDF file");
  return UrdfReader(display_name, xml).Read();
}

ConstraintGraph ImportUrdf(const std::string& path, const SourceLocation& where) {
  return ImportUrdfFromString(ReadImportedFile(path, where, "URDF", kMaxUrdfFileBytes), path);
}

}  // namespace cfuse
