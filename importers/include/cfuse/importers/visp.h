// ViSP's files as ViSP writes them (docs/formats.md "Cameras" and "Poses"): the camera of its
// XML files and an object's pose as its tutorials save it.
//
//   Camera camera = ReadVispCamera("Config/chateau.xml");
//   Rigid3d camera_from_object = ReadVispPose("chateau.0.pos");
//
// CAMERAS. ViSP's pinhole camera (vpCameraParameters) maps normalised coordinates x = X/Z,
// y = Y/Z to pixels by
//
//   u = u0 + px x (1 + kud r²),   v = v0 + py y (1 + kud r²),   r² = x² + y²
//
// (perspectiveProjWithDistortion; perspectiveProjWithoutDistortion has kud = 0). That is cfuse's
// camera (cfuse/kernel/measurements/camera.h) with fx = px, fy = py, cx = u0, cy = v0, k1 = kud and
// every other coefficient 0. ViSP also stores kdu, the inverse map (pixels to normalised
// coordinates, u - u0 scaled by 1 + kdu r²): cfuse never needs it, so it is checked to be a number
// and not used. ViSP writes cameras in two XML forms:
//
//   - tracker settings (vpMbGenericTracker::loadConfigFile; ViSP's `mbt` data sets): root
//     <conf>, the camera in <camera> as <px>, <py>, <u0>, <v0> in any order; the tracker's own
//     blocks (<ecm>, <klt>, <face>, <depth_normal>, ...) are ignored. These files give no image
//     size: the camera's width and height are 0 (unknown) and the commands take the size from
//     their images (docs/formats.md).
//   - vpXmlParserCamera's files (ViSP's calibration tools): root <root>, a <camera> with <name>,
//     <image_width>, <image_height> and one or two <model>s, each a <type> and its parameters:
//     perspectiveProjWithoutDistortion with px, py, u0, v0; perspectiveProjWithDistortion with
//     px, py, u0, v0, kud (and kdu). <subsampling_width>, <subsampling_height>, <full_width>,
//     <full_height> and <additional_information> are notes and ignored. A size of 0 x 0, which
//     ViSP writes when it was given none, is unknown.
//
// Where ViSP's own reader asks its caller to choose (vpXmlParserCamera::parse takes a camera name,
// an image size and a model type), cfuse has no option to, and decides:
//   - a file with several cameras is refused, the message listing each one's name, size and
//     line: taking one would be a guess. Keep the one meant in a file of its own.
//   - a camera with both models is read with distortion: ViSP calibrates both from the same raw
//     images, the model with distortion describes them more exactly, and cfuse measures raw
//     pixels. (A camera without distortion is the pinhole that fits the same raw images best.)
//     Two models of one type in a camera are refused.
// Anything else inside <camera> or <model> is refused, naming what is read there (ViSP refuses a
// camera with an unknown element too); so is a <kud> in a model without distortion, which ViSP
// would refuse and a reader might think applied.
//
// The checks of cfuse/kernel/measurements/camera_checks.h apply: px and py positive, every value
// finite, the principal point within a whole image of a known size. Every problem is an InputError
// at FILE:LINE:COLUMN: the element at fault, the end of the file for XML left unfinished, TinyXML's
// place for other XML that is not well formed.
//
// POSES. ViSP's tutorials save an object's pose cMo (a vpPoseVector) as six numbers
//
//   tx ty tz θux θuy θuz
//
// separated by white space (ViSP writes one a line): the translation in metres and the rotation
// vector θu in radians, x_camera = Exp(θu) x_object + t (cfuse/kernel/so3.h ExpSO3). Such files end
// in `.pos` (`chateau.0.pos`: the object's pose at frame 0). Refused at their place: a token that
// is not a number, a value that is not finite, fewer or more than six numbers (saying how many), an
// empty file, and a rotation of more than 2π (ViSP writes angles in [0, π]; beyond 2π the numbers
// are not radians, and far beyond, the rotation is lost to rounding or overflow).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

inline constexpr size_t kMaxVispCameraFileBytes = 1u << 20;
inline constexpr size_t kMaxVispPoseFileBytes = 1u << 20;

// Whether the file is XML whose root element is <conf> or <root> (after the declaration and any
// comments, in its first 4 KiB). False for a file that cannot be read.
bool IsVispCameraFile(const std::string& path);

// The camera of a ViSP XML file (either form).
Camera ReadVispCamera(const std::string& path);
// The same from text in memory; `display_name` stands for the file in messages.
Camera ReadVispCameraFromString(std::string_view text, const std::string& display_name);

// MATRICES. A pose as ViSP's vpHomogeneousMatrix writes one (`depth_M_color.txt`: the colour
// camera's pose in the depth camera's frame): sixteen numbers, four rows of four, the rotation
// and the translation (metres), then 0 0 0 1. Refused at their place: a token that is not a
// finite number, fewer or more than sixteen numbers, a last row that is not 0 0 0 1, and an
// upper-left block that is no rotation (RᵀR off the identity by more than 1e-4, or a reflection).
Rigid3d ReadVispMatrixPose(const std::string& path);
Rigid3d ReadVispMatrixPoseFromString(std::string_view text, const std::string& display_name);

// camera_from_object of a ViSP pose file (.pos).
Rigid3d ReadVispPose(const std::string& path);
Rigid3d ReadVispPoseFromString(std::string_view text, const std::string& display_name);

}  // namespace cfuse
