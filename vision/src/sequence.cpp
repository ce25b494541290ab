#include "cfuse/vision/sequence.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "cfuse/constraints/forward_kinematics.h"
#include "cfuse/kernel/error.h"

namespace cfuse {

namespace {

// The first rigid component that is no joint's child, or -1.
int RootComponent(const ConstraintGraph& graph) {
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (!graph.components[c].rigid) continue;
    bool child = false;
    for (const Joint& j : graph.joints) child = child || j.child == static_cast<int>(c);
    if (!child) return static_cast<int>(c);
  }
  return -1;
}

// The realistic look of a standard scenario (StandardSequence's comment), from its seed.
void MakeRealistic(const Eigen::Vector3d& centre, const std::string& name,
                   std::shared_ptr<const std::vector<GrayImage>> photographs, SequenceSpec* spec) {
  RenderOptions& render = spec->render;
  render.style = RenderStyle::kRealistic;
  RealisticOptions& look = render.realistic;
  look.photographs = std::move(photographs);
  look.look_seed = render.seed;
  std::mt19937 rng(render.seed * 2246822519u + 3266489917u);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng);
  };
  // The camera as the root's frame sees it, mirrored about the top face's plane: a light there
  // puts the highlight on the top face; scattered about it, near its edge or off it.
  const Rigid3d root_from_camera = spec->start.Inverse();
  const Eigen::Vector3d eye = (root_from_camera.translation - centre).normalized();
  const Eigen::Vector3d mirror(-eye.x(), -eye.y(), eye.z());
  const Eigen::Vector3d towards =
      (mirror + Eigen::Vector3d(uniform(-0.3, 0.3), uniform(-0.3, 0.3), uniform(-0.1, 0.3)))
          .normalized();
  look.light = spec->start * Eigen::Vector3d(centre + uniform(1.2, 1.8) * towards);
  look.specular = uniform(0.35, 0.8);
  look.shininess = uniform(15, 60);
  look.ambient = 0.4;
  spec->shutter = 0.5;
  spec->shake = 2;
  if (name != "clutter") {
    render.clutter_lines = 8;
    render.clutter_blobs = 4;
  }
}

}  // namespace

Values SequencePose(const ConstraintGraph& graph, const SequenceSpec& spec, double i) {
  std::vector<JointValue> given;
  for (const auto& [name, wave] : spec.joints) {
    if (graph.FindJoint(name) < 0) {
      throw InputError(SourceLocation(), "the model has no joint '" + name + "'");
    }
    given.push_back(
        {name, wave.first + wave.second * std::sin(2 * M_PI * i / spec.joint_period), {}});
  }
  Values values = ForwardKinematics(graph, CompleteJointValues(graph, given));
  const int root = RootComponent(graph);
  if (root < 0) throw InputError(SourceLocation(), "the model has no rigid root component");
  // A closed chain (a loop, a relation that is no joint) closed at the configuration nearest
  // the joints' waves; its size for the tolerance: the farthest component from the root.
  const Eigen::Vector3d root_at = values.poses[graph.blocks[graph.components[root].block].index].translation;
  double size = 0.1;
  for (const Rigid3d& pose : values.poses) size = std::max(size, (pose.translation - root_at).norm());
  if (!CloseLoops(graph, {}, size, false, &values)) {
    throw InputError(SourceLocation(), "the model's constraints cannot all hold along the sequence");
  }
  const double t = i;
  const Eigen::Vector3d turn = spec.spin * t;
  const Eigen::Matrix3d R = ExpSO3<double>(turn) * spec.start.RotationMatrix();
  Eigen::Vector3d position = spec.start.translation + spec.velocity * t +
                             spec.wobble * std::sin(2 * M_PI * t / spec.wobble_period);
  // The knock falls between frames (half a frame before jump_frame): no shutter straddles it.
  if (spec.jump_frame >= 0 && i >= spec.jump_frame - 0.5) position += spec.jump;
  const Rigid3d camera_from_root(R, position);
  const Rigid3d root_from_model =
      values.poses[graph.blocks[graph.components[root].block].index].Inverse();
  const Rigid3d camera_from_model = camera_from_root * root_from_model;
  for (Rigid3d& pose : values.poses) pose = camera_from_model * pose;
  for (Eigen::Vector3d& p : values.points) p = camera_from_model * p;
  return values;
}

Rigid3d LookAt(const Eigen::Vector3d& target, double azimuth, double elevation, double distance) {
  const Eigen::Vector3d eye =
      target + distance * Eigen::Vector3d(std::sin(azimuth) * std::cos(elevation),
                                          -std::cos(azimuth) * std::cos(elevation),
                                          std::sin(elevation));
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d model_from_camera;
  model_from_camera << x, y, z;
  const Eigen::Matrix3d camera_from_model = model_from_camera.transpose();
  return Rigid3d(camera_from_model, -(camera_from_model * eye));
}

std::vector<std::string> StandardSequenceNames() {
  return {"steady", "fast", "occluded", "clutter", "jump", "hand"};
}

Camera StandardCamera() {
  Camera camera;
  camera.fx = camera.fy = 800;
  camera.cx = 320;
  camera.cy = 240;
  camera.width = 640;
  camera.height = 480;
  return camera;
}

SequenceSpec StandardSequence(const ConstraintGraph& graph, const std::string& name, int frames,
                              unsigned seed, RenderStyle style,
                              std::shared_ptr<const std::vector<GrayImage>> photographs) {
  const std::vector<std::string> names = StandardSequenceNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (size_t k = 0; k < names.size(); ++k) {
      known += (k == 0 ? "" : k + 1 == names.size() ? " or " : ", ") + names[k];
    }
    throw InputError(SourceLocation(), "no standard sequence '" + name + "' (" + known + ")");
  }
  const int root = RootComponent(graph);
  if (root < 0) throw InputError(SourceLocation(), "the model has no rigid root component");
  const Component& base = graph.components[root];
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const FeaturePoint& p : base.points) centre += p.position;
  if (!base.points.empty()) centre /= static_cast<double>(base.points.size());

  SequenceSpec spec;
  spec.frames = frames;
  spec.start = LookAt(centre, 0.35, 0.6, 1.3);
  spec.spin = Eigen::Vector3d(0.002, 0.004, 0.002);
  spec.wobble = Eigen::Vector3d(0.09, 0.03, 0.05);
  spec.wobble_period = 100;
  spec.joint_period = 80;
  for (const Joint& j : graph.joints) {
    if (!HasJointVariable(j.type)) continue;
    if (j.mimic) continue;  // it follows its leader
    if (j.limits) {
      const auto [lo, hi] = *j.limits;
      spec.joints[j.name] = {0.5 * (lo + hi), 0.4 * (hi - lo)};
    } else {
      spec.joints[j.name] = {j.nominal_position, 0.5};
    }
  }
  spec.render.seed = seed;
  if (name == "fast") {
    spec.wobble = Eigen::Vector3d(0.3, 0.02, 0.03);
    spec.wobble_period = 40;
  } else if (name == "occluded") {
    spec.occluder_width = 0.15;
  } else if (name == "clutter") {
    spec.render.clutter_lines = 150;
    spec.render.clutter_blobs = 40;
  } else if (name == "jump") {
    spec.jump = Eigen::Vector3d(0.054, -0.027, 0);
    spec.jump_frame = frames / 2;
  } else if (name == "hand") {
    const Eigen::Vector3d object = spec.start * centre;
    spec.hand_to = object + Eigen::Vector3d(0.03, 0.02, -0.35);
    spec.hand_from = spec.hand_to + Eigen::Vector3d(0.5, 0.45, 0);
    spec.hand_width = 0.09;
  }
  if (style == RenderStyle::kRealistic) MakeRealistic(centre, name, std::move(photographs), &spec);
  return spec;
}

double MedianImageMotion(const ConstraintGraph& graph, const std::vector<SequenceFrame>& frames,
                         const Camera& camera) {
  const int root = RootComponent(graph);
  if (root < 0 || frames.size() < 2) return 0;
  const Component& c = graph.components[root];
  const int index = graph.blocks[c.block].index;
  std::vector<double> motion;
  for (size_t i = 1; i < frames.size(); ++i) {
    for (const FeaturePoint& p : c.points) {
      motion.push_back((camera.Project<double>(frames[i].truth.poses[index] * p.position) -
                        camera.Project<double>(frames[i - 1].truth.poses[index] * p.position))
                           .norm());
    }
  }
  if (motion.empty()) return 0;
  std::nth_element(motion.begin(), motion.begin() + static_cast<long>(motion.size() / 2),
                   motion.end());
  return motion[motion.size() / 2];
}

namespace {

// The instants of frame i's exposure (SequenceSpec::shutter), their configurations; empty when
// the object moves too little in it to blur.
std::vector<Values> Exposure(const ConstraintGraph& graph, const Camera& camera,
                             const SequenceSpec& spec, int i) {
  if (spec.shutter <= 0 || spec.shutter_samples < 2) return {};
  const double open = i - 0.5 * spec.shutter, close = i + 0.5 * spec.shutter;
  const Values first = SequencePose(graph, spec, open), last = SequencePose(graph, spec, close);
  double motion = 0;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const int index = graph.blocks[c.block].index;
    for (const FeaturePoint& p : c.points) {
      const Eigen::Vector2d a = camera.Project<double>(first.poses[index] * p.position);
      const Eigen::Vector2d b = camera.Project<double>(last.poses[index] * p.position);
      if (a.allFinite() && b.allFinite()) motion = std::max(motion, (b - a).norm());
    }
  }
  // Instants 2 px apart at most: the optics' blur (0.8 px) smooths the steps between them.
  const int n = std::min(spec.shutter_samples, static_cast<int>(std::ceil(motion / 2)));
  std::vector<Values> out;
  if (n < 2) return out;
  for (int k = 0; k < n; ++k) {
    out.push_back(SequencePose(graph, spec, open + spec.shutter * (k + 0.5) / n));
  }
  return out;
}

// Frame i's hand (SequenceSpec::hand_from), in the image.
HandOccluder HandAt(const Camera& camera, const SequenceSpec& spec, int i) {
  const double reach = spec.frames > 1 ? std::sin(M_PI * i / (spec.frames - 1)) : 1.0;
  const Eigen::Vector3d palm = spec.hand_from + reach * (spec.hand_to - spec.hand_from);
  HandOccluder hand;
  hand.palm = camera.Project<double>(palm);
  const Eigen::Vector2d elbow = camera.Project<double>(spec.hand_from) - hand.palm;
  hand.arm_angle = elbow.norm() > 1e-9 ? std::atan2(elbow.y(), elbow.x()) : M_PI / 4;
  hand.width = spec.hand_width * (camera.model == Camera::Model::kOrthographic
                                      ? camera.scale
                                      : camera.fx / std::max(palm.z(), 1e-3));
  return hand;
}

}  // namespace

std::vector<SequenceFrame> RenderSequence(const ConstraintGraph& graph, const Camera& camera,
                                          const SequenceSpec& spec) {
  const bool realistic = spec.render.style == RenderStyle::kRealistic;
  RenderOptions base = spec.render;
  // Procedural cards once for the whole sequence rather than at every frame.
  if (realistic && (!base.realistic.photographs || base.realistic.photographs->empty())) {
    base.realistic.photographs = std::make_shared<const std::vector<GrayImage>>(
        ProceduralPhotographs(base.realistic.look_seed));
  }
  std::mt19937 phases(spec.render.seed * 1597334677u + 1u);
  std::uniform_real_distribution<double> phase(0, 2 * M_PI);
  const double p1 = phase(phases), p2 = phase(phases), p3 = phase(phases);
  std::vector<SequenceFrame> out;
  for (int i = 0; i < spec.frames; ++i) {
    SequenceFrame frame;
    frame.truth = SequencePose(graph, spec, i);
    RenderOptions options = base;
    options.seed = spec.render.seed + static_cast<unsigned>(i);
    if (spec.occluder_width > 0) {
      const double w = spec.occluder_width * camera.width;
      const double x = -w + (camera.width + w) * (i + 0.5) / spec.frames;
      options.occluders.push_back(
          {{x, -1.0}, {x + w, -1.0}, {x + w, camera.height + 1.0}, {x, camera.height + 1.0}});
    }
    if (spec.hand_width > 0) options.hands.push_back(HandAt(camera, spec, i));
    if (realistic) {
      options.realistic.exposure = Exposure(graph, camera, spec, i);
      options.realistic.camera_shake =
          Eigen::Vector3d(spec.shake * std::sin(2 * M_PI * i / 37 + p1),
                          spec.shake * std::sin(2 * M_PI * i / 53 + p2),
                          spec.shake / 400 * std::sin(2 * M_PI * i / 71 + p3));
    }
    frame.rendering = Render(graph, frame.truth, camera, options);
    out.push_back(std::move(frame));
  }
  return out;
}

}  // namespace cfuse
