#include "vision/sequence.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "constraints/forward_kinematics.h"

namespace cfuse::vision {

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

}  // namespace

Values SequencePose(const ConstraintGraph& graph, const SequenceSpec& spec, int i) {
  std::vector<JointValue> given;
  for (const auto& [name, wave] : spec.joints) {
    if (graph.FindJoint(name) < 0) {
      throw std::invalid_argument("the model has no joint '" + name + "'");
    }
    given.push_back(
        {name, wave.first + wave.second * std::sin(2 * M_PI * i / spec.joint_period), {}});
  }
  Values values = ForwardKinematics(graph, CompleteJointValues(graph, given));
  const int root = RootComponent(graph);
  if (root < 0) throw std::invalid_argument("the model has no rigid root component");
  const double t = static_cast<double>(i);
  const Eigen::Vector3d turn = spec.spin * t;
  const Eigen::Matrix3d R = ExpSO3<double>(turn) * spec.start.RotationMatrix();
  Eigen::Vector3d position = spec.start.translation + spec.velocity * t +
                             spec.wobble * std::sin(2 * M_PI * t / spec.wobble_period);
  if (spec.jump_frame >= 0 && i >= spec.jump_frame) position += spec.jump;
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
  return {"steady", "fast", "occluded", "clutter", "jump"};
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
                              unsigned seed) {
  const std::vector<std::string> names = StandardSequenceNames();
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    throw std::invalid_argument("no standard sequence '" + name +
                                "' (steady, fast, occluded, clutter or jump)");
  }
  const int root = RootComponent(graph);
  if (root < 0) throw std::invalid_argument("the model has no rigid root component");
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
  }
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

std::vector<SequenceFrame> RenderSequence(const ConstraintGraph& graph, const Camera& camera,
                                          const SequenceSpec& spec) {
  std::vector<SequenceFrame> out;
  for (int i = 0; i < spec.frames; ++i) {
    SequenceFrame frame;
    frame.truth = SequencePose(graph, spec, i);
    RenderOptions options = spec.render;
    options.seed = spec.render.seed + static_cast<unsigned>(i);
    if (spec.occluder_width > 0) {
      const double w = spec.occluder_width * camera.width;
      const double x = -w + (camera.width + w) * (i + 0.5) / spec.frames;
      options.occluders.push_back(
          {{x, -1.0}, {x + w, -1.0}, {x + w, camera.height + 1.0}, {x, camera.height + 1.0}});
    }
    frame.rendering = Render(graph, frame.truth, camera, options);
    out.push_back(std::move(frame));
  }
  return out;
}

}  // namespace cfuse::vision
