// `cfuse detect`: the model found in one image with no pose given (cfuse/track/detector.h).
//
//   cfuse detect MODEL --camera CAM --image IMAGE [-o RESULT.json] [--overlay OUT.png]
//                [--max-results N]
//
// The result (JSON, stdout by default) lists every object found, best first: each component's
// pose in the results format (`components`, usable as `cfuse track --init`), the fit of its
// matched edges, the verification of its outline, and the other poses that draw the same outline
// (a symmetric model). Nothing found is exit status 1, with the reason and the best candidates
// refused; bad input (an unreadable image, a camera of another size, a model without edges) is
// exit status 2 with nothing written.
#pragma once

#include <iosfwd>
#include <string>

namespace cfuse::cli {

struct DetectCommandOptions {
  std::string model;
  std::string camera;
  std::string image;
  std::string output;   // RESULT.json; empty: stdout
  std::string overlay;  // OUT.png
  int max_results = 1;
};

int RunDetect(const DetectCommandOptions& options, std::ostream& out, std::ostream& err);

}  // namespace cfuse::cli
