#include "yaml_numbers.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace cfuse {

double Number(const Document& doc, const YAML::Node& node, const std::string& what) {
  if (!node.IsScalar()) doc.Fail(node, fmt::format("{} must be a number", what));
  const std::string& s = node.Scalar();
  // A quoted scalar is a string in YAML and JSON alike: "0.5" is not taken for 0.5, which would
  // hide a file written by a program that meant something else.
  if (node.Tag() == "!") {
    doc.Fail(node, fmt::format("{} must be a number, got the string \"{}\"", what, s));
  }
  char* end = nullptr;
  errno = 0;
  double v = std::strtod(s.c_str(), &end);
  // YAML spells infinity and NaN .inf and .nan; JSON has neither, and both are refused.
  const bool yaml_special = s == ".nan" || s == ".NaN" || s == ".NAN" || s == ".inf" ||
                            s == ".Inf" || s == "+.inf" || s == "-.inf" || s == "-.Inf";
  if (yaml_special) {
    v = std::nan("");
  } else if (end == s.c_str() || *end != '\0') {
    doc.Fail(node, fmt::format("{} must be a number, got '{}'", what, s));
  }
  if (!std::isfinite(v)) doc.Fail(node, fmt::format("{} must be finite, got '{}'", what, s));
  return v;
}

Eigen::VectorXd Numbers(const Document& doc, const YAML::Node& node, int n,
                        const std::string& what) {
  if (!node.IsSequence() || static_cast<int>(node.size()) != n) {
    doc.Fail(node, fmt::format("{} must be a list of {} numbers{}", what, n,
                               node.IsSequence() ? fmt::format(", got {}", node.size()) : ""));
  }
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = Number(doc, node[i], what);
  return v;
}

}  // namespace cfuse
