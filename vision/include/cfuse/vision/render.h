// Synthetic camera images of a model with their ground truth, for the detector's tests and
// benchmarks and the tracker's test sequences (`cfuse render`). Two styles.
//
// Plain (the default, what the detector's and tracker's tests were tuned on): a background of
// random grey levels with clutter (straight lines of 1-3 px and filled ellipses) drawn in dark
// greys (20-110), then every front face of the model filled with a z-buffer (each pixel takes
// the nearest face: parts hide each other), in light greys (140-240): a Lambertian shade under
// a light from the upper left, times an albedo that alternates between neighbouring faces so
// that every edge between two faces shows, as on a printed box. Then a Gaussian blur and
// Gaussian noise.
//
// Realistic (RealisticOptions): what defeats trackers on real imagery. In order:
//  - the background is a photograph (texture.h), zoomed 1-1.6 x beyond covering the image,
//    turned up to ±11 degrees, placed and dimmed by `look_seed`, displaced by `camera_shake`
//    (a sequence sways it a few pixels from frame to frame like a hand-held camera), with the
//    clutter drawn over it (drawn from `look_seed`: it stays put while `seed` advances);
//  - every front face z-buffered and printed with a photograph in perspective (texture.h), lit
//    by a point light. With the unit vectors n (the face's normal), l (to the light) and v (to
//    the camera) at each pixel's point on the face, and h = (l + v)/|l + v|:
//      radiance = white (albedo (ambient + (1 - ambient) max(0, n·l))
//                        + specular (n·h)^shininess [where n·l > 0]),   white = 235:
//    Lambert times the texture, plus Blinn-Phong's highlight, per pixel (v and l vary across a
//    face, so a glossy face washes out near the highlight and stays printed elsewhere); a face
//    turned away from the light keeps the ambient share, dark but not black;
//  - a soft shadow on the background: the object's silhouette moved away from the light by 6 %
//    of the object's size and blurred by 4 %;
//  - motion blur: with `exposure` (configurations while the shutter is open) the object's layer
//    is the mean of their renderings;
//  - hands (HandOccluder, in the plain style too), then the occluders, in front of everything;
//  - the optics' Gaussian blur (`blur`), then the sensor: each pixel's signal S (grey levels)
//    gets Gaussian noise of variance noise² + gain · S (read noise and shot noise, the
//    variance function σ²(S) = a S + b of Foi, Trimeche, Katkovnik and Egiazarian 2008,
//    "Practical Poissonian-Gaussian noise modeling and fitting for single-image raw-data"),
//    clipped to 0-255 and rounded to 8 bits.
//
// The truth, in both styles: each visible model edge (model_edges.h) sampled every half pixel
// against the z-buffer of `values`; the runs where it is the front surface, and where the image
// shows it (a contrast across it), are the visible segments. Plain: the clean image (before blur
// and noise) differs by `min_contrast` 2 px either side. Realistic: the clean, sharp image at
// `values` (before motion blur, optical blur and noise) differs by `min_contrast` between the
// means of six pixels either side (1.5 and 3 px off the edge, at three places 1.5 px apart
// along it), so that a single pixel of print beside an edge decides nothing. Edges inside the
// print are not model edges and never in the truth. The camera must be a pinhole without
// distortion, or orthographic (the faces are filled as straight-sided polygons).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cfuse/constraints/graph.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/kernel/measurements/camera.h"
#include "cfuse/vision/texture.h"

namespace cfuse {

enum class RenderStyle { kPlain, kRealistic };

// "plain" or "realistic"; nullopt for another name.
std::optional<RenderStyle> ParseRenderStyle(const std::string& name);
const char* RenderStyleName(RenderStyle style);

// A hand reaching into the image in front of everything: a palm with four fingers and a thumb
// pointing away from the forearm, which runs from the palm in direction `arm_angle` past the
// image's border. Each part a rounded limb in a skin tone (albedo 0.62), shaded across its
// width as a cylinder lit from the upper left, with a soft (anti-aliased) outline; it hides the
// edges behind it from the truth as an occluder does.
struct HandOccluder {
  Eigen::Vector2d palm = Eigen::Vector2d::Zero();  // px, the palm's centre
  double arm_angle = 0;  // rad, image direction from the palm to the elbow (x right, y down)
  double width = 80;     // px, across the palm
};

// The realistic style (the file's comment). `noise` and `blur` of RenderOptions are the read
// noise and the optics' blur.
struct RealisticOptions {
  // Photographs for the faces and the background, shared between frames. Null or empty: the
  // procedural cards of ProceduralPhotographs(look_seed), made anew at each call (give them
  // here to render many frames).
  std::shared_ptr<const std::vector<GrayImage>> photographs;
  // Chooses the photographs and crops of the faces and the background (FaceTextures) and the
  // background's brightness: a sequence keeps it while RenderOptions::seed advances by frame.
  unsigned look_seed = 1;
  Eigen::Vector3d light = Eigen::Vector3d(-0.5, -1.0, 0.3);  // point light, camera frame, m
  double ambient = 0.3;            // share of a face's brightness the light does not give
  double specular = 0.5;           // the highlight's peak, as a share of white
  double shininess = 40;           // Blinn-Phong's exponent: the highlight's tightness
  double texture_contrast = 0.16;  // the albedo's standard deviation over a face (0: plain)
  double shadow = 0.4;             // the soft shadow's depth at its darkest (0: none)
  double gain = 0.05;              // shot noise, grey levels per electron: variance gain · S
  // The background's displacement in the image (px right, px down, rad clockwise).
  Eigen::Vector3d camera_shake = Eigen::Vector3d::Zero();
  // Motion blur: the configurations the object passes through while the shutter is open, each
  // rendered and averaged (the background, hands and occluders stay sharp); empty: `values`
  // alone. The truth is always at `values`.
  std::vector<Values> exposure;
};

struct RenderOptions {
  RenderStyle style = RenderStyle::kPlain;
  unsigned seed = 1;  // the clutter's (plain style) and the noise's
  int clutter_lines = 30;
  int clutter_blobs = 12;
  double blur = 0.8;   // px, the Gaussian's sigma (0: none)
  double noise = 2.0;  // grey levels, the noise's sigma
  // Grey levels: a stretch of edge shows (and is true) where the image differs by this much
  // either side of it.
  double min_contrast = 15;
  // Polygons (pixels) drawn in front of everything in a dark grey: occluders, which hide the
  // edges behind them from the truth too.
  std::vector<std::vector<Eigen::Vector2d>> occluders;
  int occluder_grey = 45;
  std::vector<HandOccluder> hands;  // drawn before the occluders
  RealisticOptions realistic;       // the realistic style only
};

struct TruthSegment {
  int edge = -1;  // index into ModelEdges()
  Eigen::Vector2d a, b;
};

struct Rendering {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  // row-major, 8-bit grey
  std::vector<TruthSegment> truth;   // the visible parts of the model's edges
};

// Throws InputError (its location left to the caller, who knows the file) for a camera without a
// size, over 2^28 pixels, or with distortion, and for a photograph smaller than 32 x 32 pixels or
// without its pixels.
Rendering Render(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                 const RenderOptions& options = {});

// The PNG bytes of an 8-bit grey image.
std::vector<std::uint8_t> EncodePng(const std::vector<std::uint8_t>& pixels, int width, int height);

}  // namespace cfuse
