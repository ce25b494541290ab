// A fast path for large measurement files in plain JSON. Internal to dsl/.
//
// yaml-cpp builds a node per value: a file of 10^6 points (46 MB) took 96 s and 4.2 GB to read.
// This reader streams the file through nlohmann::json's SAX parser into the measurements, with
// no tree, and only accepts the plain shape of docs/formats.md: an object of `points` (and
// `camera`) whose entries hold `xyz` or `uv`, `sigma` or `cov`, and a `label`, in ASCII
// without escapes. For anything else it returns nullopt (the one error it reports itself is
// a file over kMaxMeasuredPoints), and the YAML reader reads the file and says what is wrong,
// so messages come from one place. What it accepts, the YAML reader accepts with the same
// values and locations: tests/dsl/measurement_reader_test.cpp and the measurements fuzz target
// check that.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "cfuse/kernel/measurement_set.h"

namespace cfuse {

// Why a covariance matrix is refused ("is not symmetric", "is not positive definite"), or
// nullopt; both readers' test.
std::optional<std::string> CovarianceProblem(const Eigen::MatrixXd& C);

// Why a standard deviation is refused ("must be positive"), or nullopt; both readers' test.
// Its square is the variance, which must be a positive finite number: a sigma of 1e200
// would make every off-diagonal entry inf * 0 = NaN.
std::optional<std::string> SigmaProblem(double sigma);

// `read_camera` reads the camera object's text (a fragment of the file); it may throw
// InputError, which makes the fast path give up.
std::optional<MeasurementSet> ReadPlainJsonMeasurements(
    std::string_view text, const std::string& display,
    const std::function<Camera(std::string_view camera_json)>& read_camera);

// Equal sources, cameras, and points with equal values, labels and locations: the two readers'
// agreement, as the tests and the measurements fuzz target check it.
bool SameMeasurements(const MeasurementSet& a, const MeasurementSet& b);

}  // namespace cfuse
