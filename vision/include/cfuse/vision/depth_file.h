// A range sensor's frame as 3D points, and the raw depth files ViSP's RGB-D examples record
// (visp-images-data's mbt-depth/castel, a RealSense SR300).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "cfuse/kernel/rigid3.h"

namespace cfuse {

// One frame of a range sensor: its points as its image's rows (width x height), in metres in
// the grey camera's frame; a pixel without depth holds z <= 0 or NaN.
struct DepthFrame {
  int width = 0, height = 0;
  std::vector<Eigen::Vector3f> points;
};

// The depth camera: pinhole, and RealSense's deprojection distortion ("inverse Brown-Conrady":
// k1, k2, p1, p2, k3 applied to a pixel's normalised coordinates to undo the lens, as
// librealsense's rs2_deproject_pixel_to_point does; zero: none).
struct DepthIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 5> coefficients{};
};

// The depth camera of visp-images-data's mbt-depth/castel (a RealSense SR300) and its depth
// unit, as ViSP's example mbtGenericTrackingDepth.cpp gives them (its chateau_depth.xml has the
// pinhole only).
DepthIntrinsics CastelDepthIntrinsics();
constexpr double kCastelMetresPerUnit = 0.000124986647;

// A raw depth file: little-endian uint32 height and width, then height x width uint16 depths
// (0: none) in units of `metres_per_unit`, deprojected through `intrinsics` and moved into the
// grey camera's frame by `grey_from_depth`. Throws InputError naming the file for one that
// cannot be read, holds no image, or is shorter than its header says.
DepthFrame ReadRawDepth(const std::string& path, const DepthIntrinsics& intrinsics,
                        double metres_per_unit, const Rigid3d& grey_from_depth);

// A depth frame from a raw file (`.bin`, as above) or a 16-bit single-channel image (PNG, TIFF:
// RealSense's and most RGB-D recordings'), deprojected alike. Throws InputError naming the file
// for one that cannot be read or is not 16-bit depth.
DepthFrame ReadDepthFrame(const std::string& path, const DepthIntrinsics& intrinsics,
                          double metres_per_unit, const Rigid3d& grey_from_depth);

}  // namespace cfuse
