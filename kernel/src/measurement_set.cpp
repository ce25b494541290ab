#include "cfuse/kernel/measurement_set.h"

#include <fmt/format.h>

#include "cfuse/kernel/check.h"

namespace cfuse {

void CheckMeasurementSet(const MeasurementSet& set) {
  for (size_t i = 0; i < set.points.size(); ++i) {
    const MeasuredPoint& m = set.points[i];
    if (m.is_3d) {
      CFUSE_CHECK_MSG(m.xyz.allFinite() && m.cov3.allFinite(),
                      fmt::format("measurement {}: a value or its covariance is not finite", i));
    } else {
      CFUSE_CHECK_MSG(set.camera.has_value(),
                      fmt::format("measurement {} is an image point and the set has no camera", i));
      CFUSE_CHECK_MSG(m.uv.allFinite() && m.cov2.allFinite(),
                      fmt::format("measurement {}: a value or its covariance is not finite", i));
    }
  }
}

}  // namespace cfuse
