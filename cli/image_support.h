// What the image commands share (segments, project, render, track): images read as 8-bit grey
// with errors that say why not, PNG bytes, and a model placed at the poses of a results file.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "cfuse/constraints/graph.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/pose_set.h"
#include "cfuse/kernel/values.h"

namespace cfuse::cli {

// An image as 8-bit grey (colour converted), or an InputError at the file saying why not.
cv::Mat ReadGrayImage(const std::string& path);

// Silences stderr (file descriptor 2) while it lives: libpng and the video back ends print their
// own lines there about a file that the InputError then describes in one located line.
class QuietStderr {
 public:
  QuietStderr();
  ~QuietStderr();
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

// A camera without an image size (ViSP's tracker settings give none) takes `image`'s, the image
// named `source` in messages; then checked as a camera file with that size would be
// (cfuse/kernel/measurements/camera_checks.h), refused at `camera_file` when its principal point is
// a whole image away.
void SizeCameraFromImage(const cv::Mat& image, const std::string& source,
                         const std::string& camera_file, Camera* camera);

// The PNG encoding of an image.
std::string PngBytes(const cv::Mat& image);

// The model at the poses of a results-format file: every rigid component placed there
// (itself, or through a frame on it), or an InputError naming the first one that is not. A
// `.pos` file is ViSP's pose of the object instead (cfuse/importers/visp.h): camera_from_object T
// places the model's frame, every component at T ∘ its nominal pose and every single point at
// T applied to its nominal position, so a model of several components moves rigidly.
Values PosedModel(const ConstraintGraph& graph, const std::string& pose_file);
// The same from poses already read; `source` names them in messages.
Values PosedModel(const ConstraintGraph& graph, const PoseSet& poses, const std::string& source);

}  // namespace cfuse::cli
