// Closed-form poses: the starts that keep the linearising filter away from wrong basins, so
// that the result does not depend on how the object happens to be oriented.
//
//  - AbsoluteOrientation: 3D points, Umeyama's (1991) least squares without scale.
//  - OrthographicPose: image points under an orthographic camera (u = s x + cx, v = s y + cy).
//    Depth is invisible to such a camera, so the translation along the optical axis is not
//    measured: the caller says at which depth to put the points' centroid. Non-coplanar points
//    give the rotation uniquely: the affine camera fitted by least squares, its two rows
//    projected onto the nearest orthonormal pair (SVD), the third row their cross product.
//    Coplanar points fix the rotation only up to the mirror image about the image plane (the
//    Necker reversal, unavoidable under orthography); the solution whose plane normal points
//    towards the camera is returned.
// (Pinhole cameras: PnP and P3P in cfuse/geometry/pnp.h and cfuse/geometry/p3p.h.)
#pragma once

#include <Eigen/Core>
#include <vector>

#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/kernel/rigid3.h"

namespace cfuse {

// to_from_from with to ≈ R from + t, or false when the points do not fix a rotation (fewer
// than 3, or collinear).
bool AbsoluteOrientation(const std::vector<Eigen::Vector3d>& from,
                         const std::vector<Eigen::Vector3d>& to, Rigid3d* result);

// camera_from_object for an orthographic camera from n >= 4 correspondences (n >= 3 if
// coplanar), with the object points' centroid at `depth` along the optical axis; false for a
// pinhole camera, too few points, or points on a line.
bool OrthographicPose(const Camera& camera, const std::vector<Eigen::Vector3d>& object_points,
                      const std::vector<Eigen::Vector2d>& image_points, double depth,
                      Rigid3d* camera_from_object);

}  // namespace cfuse
