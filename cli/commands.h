// The cfuse subcommands as testable functions: each takes its parsed options and the streams
// to write to, and returns the process exit status:
//   0  success
//   1  a search or solve found no acceptable answer (from the estimator issues on)
//   2  bad input: the message names the file and the place (cfuse/kernel/error.h)
//   3  internal error: a bug in cfuse (cfuse/kernel/check.h)
#pragma once

#include <iosfwd>
#include <string>

namespace cfuse::cli {

struct CheckCommandOptions {
  std::string model;
  bool json = false;
  // Labelled measurements: which components and joints they and the constraints leave
  // undetermined, from the rank of the stacked Jacobian at the solved estimate.
  std::string measurements;
};
int RunCheck(const CheckCommandOptions& options, std::ostream& out, std::ostream& err);

struct GraphCommandOptions {
  std::string model;
  std::string output;  // empty: stdout
};
int RunGraph(const GraphCommandOptions& options, std::ostream& out, std::ostream& err);

struct PlanCommandOptions {
  std::string model;
  bool image = false;  // plan for 2D measurements (seed sets of 4 points)
};
int RunPlan(const PlanCommandOptions& options, std::ostream& out, std::ostream& err);

struct SolveCommandOptions {
  std::string model;
  std::string measurements;
  std::string guess;   // results-format file of starting poses; empty: closed-form starts
  std::string output;  // empty: stdout
  // "fusion" (constraint fusion), "parametric" (Lowe's estimator on root poses and joint
  // variables: cfuse/interp/parametric.h) or "components" (each component alone, no constraints
  // between them): the baselines of docs/benchmarks.md.
  std::string method = "fusion";
};
int RunSolve(const SolveCommandOptions& options, std::ostream& out, std::ostream& err);

struct InterpretCommandOptions {
  std::string model;
  std::string measurements;
  std::string output;  // empty: stdout
  std::string tree;    // Graphviz file of the explored tree; empty: none
  double gate = 0.9999;
  long max_nodes = 20000;
};
int RunInterpret(const InterpretCommandOptions& options, std::ostream& out, std::ostream& err);

struct SimulateCommandOptions {
  std::string model;
  unsigned seed = 1;
  double noise = 0.002;
  double pixel_noise = 1.0;
  std::string camera;  // camera file; 2D measurements when given
  double clutter = 0;
  double occlusion = 0;
  bool labels = false;
  bool sample_joints = false;
  std::string output;  // measurements
  std::string truth;
};
int RunSimulate(const SimulateCommandOptions& options, std::ostream& out, std::ostream& err);

struct ImportCommandOptions {
  std::string model;   // a .urdf file (or any model file)
  std::string output;  // empty: stdout
};
int RunImport(const ImportCommandOptions& options, std::ostream& out, std::ostream& err);

struct FkCommandOptions {
  std::string model;
  std::string joints;  // joint values file; empty: every joint at 0
  std::string output;  // empty: stdout
};
int RunFk(const FkCommandOptions& options, std::ostream& out, std::ostream& err);

struct DemoCommandOptions {
  std::string picture = "cfuse-demo.png";  // PNG of the measurements and the fitted lamp
  // The tracking part's overlay frames (a directory, replaced); empty: none written.
  std::string track_overlay = "cfuse-demo-track";
};
int RunDemo(const DemoCommandOptions& options, std::ostream& out, std::ostream& err);

// The embedded copies of examples/lamp.yaml and examples/hinged-box.yaml used by `cfuse demo`
// (generated at build time).
extern const char* const kEmbeddedLampYaml;
extern const char* const kEmbeddedHingedBoxYaml;

}  // namespace cfuse::cli
