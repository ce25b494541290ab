#include "cli/commands.h"

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>

#include "cli/results.h"
#include "cli/summary.h"
#include "constraints/graphviz.h"
#include "dsl/measurement_reader.h"
#include "dsl/model_loader.h"
#include "interp/solve.h"
#include "kernel/check.h"
#include "kernel/error.h"
#include "vision/pnp.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;

// Runs a command, turning the error tiers into messages and exit statuses.
int Guarded(std::ostream& err, const std::function<int()>& body) {
  try {
    return body();
  } catch (const InputError& e) {
    err << e.what() << "\n";
    return 2;
  } catch (const InternalError& e) {
    err << "cfuse: " << e.what() << "\n";
    return 3;
  } catch (const std::bad_alloc&) {
    err << "cfuse: error: out of memory\n";
    return 3;
  } catch (const std::exception& e) {
    err << "cfuse: internal error: " << e.what() << "\n";
    return 3;
  }
}

ConstraintGraph LoadAnyModel(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".yaml" && ext != ".yml") {
    throw InputError(SourceLocation(path),
                     fmt::format("unsupported model format '{}': model files are .yaml or .yml",
                                 ext.empty() ? "(no extension)" : ext));
  }
  return dsl::LoadModel(path);
}

// Writes `content` to `path` through a temporary file in the same directory, so that a
// failure never leaves a half-written file.
void WriteFileAtomically(const std::string& path, const std::string& content) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(SourceLocation(path),
                     fmt::format("cannot write: directory '{}' does not exist", dir.string()));
  }
  if (fs::is_directory(target, ec)) {
    throw InputError(SourceLocation(path), "cannot write: it is a directory");
  }
  const fs::path temp = dir / fmt::format(".{}.tmp{}", target.filename().string(), ::getpid());
  {
    std::ofstream out(temp, std::ios::binary | std::ios::trunc);
    out << content;
    out.close();
    if (!out) {
      fs::remove(temp, ec);
      throw InputError(SourceLocation(path), "cannot write the file");
    }
  }
  fs::rename(temp, target, ec);
  if (ec) {
    fs::remove(temp, ec);
    throw InputError(SourceLocation(path), fmt::format("cannot write: {}", ec.message()));
  }
}

}  // namespace

int RunCheck(const CheckOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const ModelSummary summary = Summarize(graph);
    if (options.json) {
      out << SummaryJson(graph, summary).dump(2) << "\n";
    } else {
      PrintSummary(graph, summary, out);
    }
    return 0;
  });
}

int RunGraph(const GraphOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    std::ostringstream dot;
    WriteDot(graph, dot);
    if (options.output.empty()) {
      out << dot.str();
    } else {
      WriteFileAtomically(options.output, dot.str());
    }
    return 0;
  });
}

int RunSolve(const SolveCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    const ConstraintGraph graph = LoadAnyModel(options.model);
    const MeasurementSet set = dsl::ReadMeasurements(options.measurements);
    const auto start = std::chrono::steady_clock::now();
    SolveOptions solve_options;
    solve_options.pose_from_projections = &vision::PoseFromProjections;
    const Solution solution = Solve(graph, set, solve_options);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (solution.labels.empty()) {
      throw InputError(SourceLocation(options.measurements),
                       "no labelled points: solve needs labels (unlabelled points are for "
                       "`cfuse interpret`)");
    }
    const std::string text = SolutionJson(graph, set, solution, ms).dump(2) + "\n";
    if (options.output.empty()) {
      out << text;
    } else {
      WriteFileAtomically(options.output, text);
    }
    if (!solution.contradictions.empty()) {
      std::string names;
      for (const std::string& n : solution.contradictions) names += (names.empty() ? "" : ", ") + n;
      err << fmt::format("cfuse: contradictory constraints or measurements, not fused: {}\n",
                         names);
      return 1;
    }
    if (!solution.summary.converged) {
      err << fmt::format("cfuse: the constraints hold only to {:.3g} after {} passes\n",
                         solution.summary.max_constraint_residual, solution.summary.passes);
      return 1;
    }
    return 0;
  });
}

int RunDemo(std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    out << "cfuse demo: the desk lamp of Hel-Or & Werman (1994), built in\n\n";
    const ConstraintGraph graph =
        dsl::LoadModelFromString(kEmbeddedLampYaml, "built-in examples/lamp.yaml", ".");
    const ModelSummary summary = Summarize(graph);
    PrintSummary(graph, summary, out);
    out << "\nThe lamp's 23 points are single-point components (69 state variables); its\n"
           "distance, parallel and coplanar constraints leave the 5 internal degrees of\n"
           "freedom of the paper plus the 6 of the lamp's placement in the world.\n";
    return summary.violations.empty() ? 0 : 1;
  });
}

}  // namespace cfuse::cli
