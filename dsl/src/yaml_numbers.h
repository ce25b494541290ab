// Numbers in input files: finite, located when they are not. Internal to dsl/.
#pragma once

#include <Eigen/Core>
#include <string>

#include "yaml_document.h"

namespace cfuse {

// A finite number; NaN and infinity (YAML's .nan and .inf) are refused.
double Number(const Document& doc, const YAML::Node& node, const std::string& what);
// A list of exactly n finite numbers.
Eigen::VectorXd Numbers(const Document& doc, const YAML::Node& node, int n,
                        const std::string& what);

}  // namespace cfuse
