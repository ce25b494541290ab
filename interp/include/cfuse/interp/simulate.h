// Synthetic data for a model: a random configuration that satisfies every constraint, at a
// random pose, and its measurements with noise, clutter and occlusion.
//
// The configuration: the nominal geometry perturbed at random (positions by a fraction of the
// model's extent, rotations by a few tenths of a radian), then projected onto the constraint
// surface by the batch solver (the closest point in the perturbation's metric; inequalities and
// ranges hold through their slacks). With `sample_joints`, the joint variables are drawn
// inside their limits and forward kinematics places the components (constraints other than the
// joints' are then met by the same projection, from there). The pose: a rotation uniform over
// SO(3); without a camera a translation of the order of the model's size, with one a position in
// front of the camera where every model point projects inside the image. A model with `fixed:`
// entries is pinned to the world (the viewer's frame) and stays where they put it.
#pragma once

#include <optional>
#include <random>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurement_set.h"

namespace cfuse {

struct SimulateOptions {
  unsigned seed = 1;
  double noise = 0.002;          // 3D measurement sigma, metres
  double pixel_noise = 1.0;      // 2D sigma, pixels (with a camera)
  std::optional<Camera> camera;  // 2D measurements when given
  double clutter = 0;            // extra points, as a ratio of the real ones
  double occlusion = 0;          // fraction of the model points not measured
  bool labels = false;           // keep labels (and the model's order) on the real points
  double perturbation = 0.1;     // of the configuration, relative to the extent
  // Articulated models: each joint variable uniform over the middle 80 % of its limits (a
  // turn for a continuous joint, ±10 % of the extent for a prismatic joint without limits),
  // placed by forward kinematics, instead of the perturbed nominal geometry (which a model
  // without joint variables keeps).
  bool sample_joints = false;
};

struct Simulation {
  Values truth;  // satisfies every constraint
  MeasurementSet measurements;
  std::vector<std::string> matches;  // per measurement: the true label, "" for clutter
};

// Throws InputError (at the model) when no configuration satisfying the constraints is found
// or, with a camera, no pose puts the model inside the image.
Simulation Simulate(const ConstraintGraph& graph, const SimulateOptions& options);

// Whether an interpretation's label `found` for a measurement whose true label is `truth`
// ("" for clutter) is right: both empty, or model points at one place in `values` (the true
// configuration). Two model points can share a place, e.g. the corners a hinge joins, which no
// data can tell apart.
bool SameModelPlace(const ConstraintGraph& graph, const Values& values, const std::string& truth,
                    const std::string& found);

// Image data: how far apart, in pixels, `camera` sees the model points named `truth` and
// `found` in `values`; nullopt when either is "" or unknown. Points projecting within the noise
// of each other (a thin plate's two faces seen nearly edge-on) cannot be told apart by their
// measurements: the benchmark and tests count such a label right at 3 sigmas, beside the strict
// count.
std::optional<double> ImageSeparation(const ConstraintGraph& graph, const Values& values,
                                      const Camera& camera, const std::string& truth,
                                      const std::string& found);

}  // namespace cfuse
