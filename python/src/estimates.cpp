// solve and interpret: the answer as the CLI's JSON (a dict) with its verdict.
#include <pybind11/stl.h>

#include <optional>

#include "bindings.h"
#include "cfuse/dsl/pose_reader.h"
#include "cfuse/kernel/error.h"
#include "cli/answers.h"

namespace cfuse::python {
namespace {

// A guess: a path to a results file, or a dict in the results format.
std::optional<PoseSet> Guess(const py::object& guess) {
  if (guess.is_none()) return std::nullopt;
  if (py::isinstance<py::str>(guess) || py::hasattr(guess, "__fspath__")) {
    return ReadPoses(py::str(guess).cast<std::string>());
  }
  return ReadPosesFromString(FromPython(guess, "guess").dump(), "guess");
}

py::tuple Answer(const nlohmann::json& result, const cli::Verdict& verdict) {
  return py::make_tuple(ToPython(result), verdict.status, py::cast(verdict.lines));
}

}  // namespace

void BindEstimates(py::module_& m) {
  m.def(
      "_solve",
      [](const Model& model, const MeasurementSet& set, const py::object& guess,
         const std::string& method) {
        const std::optional<PoseSet> poses = Guess(guess);
        cli::SolveAnswer answer;
        {
          py::gil_scoped_release release;
          answer = cli::SolveAndJudge(*model.graph, set, method, poses ? &*poses : nullptr);
        }
        return Answer(answer.result, answer.verdict);
      },
      py::arg("model"), py::arg("measurements"), py::arg("guess"), py::arg("method"),
      "cfuse.solve's work: (the result's dict, the exit status, the verdict's lines).");

  m.def(
      "_interpret",
      [](const Model& model, const MeasurementSet& set, double gate, long max_nodes) {
        if (!(gate > 0 && gate < 1)) {
          throw InputError(SourceLocation("gate"), "must be a probability in (0, 1)");
        }
        if (max_nodes < 1) throw InputError(SourceLocation("max_nodes"), "must be at least 1");
        InterpretOptions options;
        options.gate_confidence = gate;
        options.max_nodes = max_nodes;
        cli::InterpretAnswer answer;
        {
          py::gil_scoped_release release;
          answer = cli::InterpretAndJudge(*model.graph, set, options);
        }
        return Answer(answer.result, answer.verdict);
      },
      py::arg("model"), py::arg("measurements"), py::arg("gate"), py::arg("max_nodes"),
      "cfuse.interpret's work: (the result's dict or None, the exit status, the lines).");
}

}  // namespace cfuse::python
