// Photographs for the realistic renderer (render.h): reading them, the procedural stand-ins
// used when there are none, and how each face of a model is printed with them.
//
// A face's texture is a crop of one photograph laid flat on the face, as print on a box. The
// point at face coordinates (s, t) (metres, FaceFrame below) shows the photograph's pixel
//   q = photo_from_face (s, t, 1)ᵀ,
// an affine map chosen from a seed: a rotation by a multiple of 90 degrees (print runs along a
// box's sides), a scale of 500-1100 photograph pixels per metre (about one photograph pixel
// per image pixel at a metre or two; less where the face is too large for the photograph),
// and a shift that keeps the face inside the photograph. The renderer finds each pixel's
// (s, t) by intersecting the pixel's ray with the face's plane, so the texture is mapped in
// perspective (the homography from the image to the face's plane), not interpolated across
// the image.
//
// The face's albedo (its reflectance, 0-1) is
//   albedo = clamp(base + gain (photo(q) - mean), 0.02, 0.98),
// with `mean` the crop's mean grey level and `gain` scaling the crop's standard deviation to
// `contrast` (0.16 in the renderer: print whose strong internal edges, ink against card, are
// as strong as the face's boundary against its neighbour or the background, as on a real
// printed box). A crop that is flat (standard deviation under 2 grey levels) gives a plain face.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"

namespace cfuse {

// An 8-bit grey image held in memory: row-major, `width` bytes a row, pixel centres at integer
// coordinates.
struct GrayImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;
};

// Reads photographs as 8-bit grey (colour converted): each path an image file, or a directory
// whose image files (by extension: .png, .jpg, .jpeg, .pgm, .ppm, .pnm, .bmp, .tif, .tiff) are
// read in name order, not recursing. Throws InputError at the path for a file that is missing,
// unreadable, larger than 512 MiB, or smaller than 32 x 32 pixels, and for a directory without
// images.
std::vector<GrayImage> LoadPhotographs(const std::vector<std::string>& paths);

// Debian's `visp-images-data` package installs its test images here.
inline constexpr const char* kVispImagesDirectory = "/usr/share/visp-images-data/ViSP-images";

// The photographs among the package's images under `root`: a painting (Klimt), a group
// photograph (Solvay 1927), three desks seen by a camera (AprilTag, mbt/cube, castle), two
// cluttered scenes (cube, mire-2) and a calibration grid. Those present, in that order; empty
// when the package is not installed.
std::vector<std::string> VispPhotographPaths(const std::string& root = kVispImagesDirectory);

// Stand-ins for photographs when none are given: `count` 512 x 512 images of printed card,
// each a light or dark ground with blocks of flat grey, lines of large and small text (OpenCV's
// Hershey fonts), rules, a disc and paper grain; a pure function of `seed`.
std::vector<GrayImage> ProceduralPhotographs(unsigned seed, int count = 4);

// A face's own frame, in its component's frame: the origin at its first corner, `s` along its
// first side, `normal` the outward normal (right-hand rule on the loop, by Newell's method) and
// `t` = normal × s, in the face's plane. All zero for a face of fewer than three corners or
// without area.
struct FacePlane {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d s = Eigen::Vector3d::Zero(), t = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  bool valid = false;
};
FacePlane FaceFrame(const Component& component, int face);

// How one face is printed (the file's comment).
struct FaceTexture {
  int component = -1, face = -1;  // indices into ConstraintGraph::components, Component::faces
  int photograph = -1;            // index into the photographs; -1: no texture (a plain face)
  Eigen::Matrix<double, 2, 3> photo_from_face = Eigen::Matrix<double, 2, 3>::Zero();
  double base = 0.6;  // the albedo at the crop's mean grey level
  double mean = 0;    // grey levels
  double gain = 0;    // albedo per grey level
};

// Every face of every rigid component, in model order, printed with `photographs` as chosen by
// `seed` (each face its own photograph and crop; `contrast` 0: plain faces of albedo `base`).
// CFUSE_CHECKs that the photographs are at least 32 x 32 pixels.
std::vector<FaceTexture> FaceTextures(const ConstraintGraph& graph,
                                      const std::vector<GrayImage>& photographs, unsigned seed,
                                      double contrast);

}  // namespace cfuse
