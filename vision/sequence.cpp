#include "vision/sequence.h"

#include <cmath>
#include <stdexcept>

#include "constraints/forward_kinematics.h"

namespace cfuse::vision {

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
  // The root: the first rigid component that is no joint's child.
  int root = -1;
  for (size_t c = 0; c < graph.components.size() && root < 0; ++c) {
    if (!graph.components[c].rigid) continue;
    bool child = false;
    for (const Joint& j : graph.joints) child = child || j.child == static_cast<int>(c);
    if (!child) root = static_cast<int>(c);
  }
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
