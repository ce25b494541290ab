#include "bench/visp_tracker.h"

#include <visp3/core/vpCameraParameters.h>
#include <visp3/core/vpException.h>
#include <visp3/core/vpHomogeneousMatrix.h>
#include <visp3/core/vpImage.h>
#include <visp3/core/vpMath.h>
#include <visp3/core/vpPolygon3D.h>
#include <visp3/mbt/vpMbGenericTracker.h>
#include <visp3/me/vpMe.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace cfuse::bench {
namespace {

vpHomogeneousMatrix ToVisp(const Rigid3d& pose) {
  const Eigen::Matrix3d r = pose.RotationMatrix();
  vpHomogeneousMatrix m;  // identity: the bottom row stays [0 0 0 1]
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[i][j] = r(i, j);
    m[i][3] = pose.translation(i);
  }
  return m;
}

// A finite pose, or nullopt. ViSP keeps its rotation orthonormal to rounding; the quaternion is
// normalised all the same.
std::optional<Rigid3d> FromVisp(const vpHomogeneousMatrix& m) {
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r(i, j) = m[i][j];
    t(i) = m[i][3];
  }
  if (!r.allFinite() || !t.allFinite()) return std::nullopt;
  return Rigid3d(Eigen::Quaterniond(r).normalized(), t);
}

// ViSP's CAO reader writes a summary of the model ("> 8 points", ...) to std::cout even when not
// asked to be verbose; the benchmark's output is a table.
class SilenceCout {
 public:
  SilenceCout() : saved_(std::cout.rdbuf(sink_.rdbuf())) {}
  ~SilenceCout() { std::cout.rdbuf(saved_); }
  SilenceCout(const SilenceCout&) = delete;
  SilenceCout& operator=(const SilenceCout&) = delete;

 private:
  std::ostringstream sink_;
  std::streambuf* saved_;
};

void CopyFrame(const std::uint8_t* pixels, int width, int height, vpImage<unsigned char>* image) {
  std::memcpy(image->bitmap, pixels, static_cast<size_t>(width) * static_cast<size_t>(height));
}

}  // namespace

std::vector<PeerFrame> TrackWithVisp(const std::vector<const std::uint8_t*>& frames, int width,
                                     int height, const Camera& camera, const std::string& cao_path,
                                     const Rigid3d& initial, const VispOptions& options) {
  if (frames.empty()) throw std::invalid_argument("TrackWithVisp: no frames");
  if (width <= 0 || height <= 0) throw std::invalid_argument("TrackWithVisp: empty image size");
  if (camera.model != Camera::Model::kPinhole ||
      std::any_of(camera.distortion.begin(), camera.distortion.end(),
                  [](double d) { return d != 0; })) {
    throw std::invalid_argument("TrackWithVisp: the camera must be a pinhole without distortion");
  }
  if ((camera.width != 0 && camera.width != width) ||
      (camera.height != 0 && camera.height != height)) {
    throw std::invalid_argument("TrackWithVisp: the images' size is not the camera's");
  }
  if (!initial.rotation.coeffs().allFinite() || !initial.translation.allFinite()) {
    throw std::invalid_argument("TrackWithVisp: the initial pose is not finite");
  }
#ifdef _OPENMP
  if (options.threads > 0) omp_set_num_threads(options.threads);
#endif

  // The order of ViSP's tutorial-mb-generic-tracker-full.cpp: moving edges, angles, clipping,
  // camera, visibility test, then the model.
  vpMbGenericTracker tracker;
  tracker.setTrackerType(vpMbGenericTracker::EDGE_TRACKER);
  vpMe me;
  me.setMaskSize(static_cast<unsigned>(options.mask_size));
  me.setMaskNumber(static_cast<unsigned>(options.mask_number));
  me.setRange(static_cast<unsigned>(options.range));
  me.setThreshold(options.threshold);
  me.setMu1(options.mu1);
  me.setMu2(options.mu2);
  me.setSampleStep(options.sample_step);
  tracker.setMovingEdge(me);
  tracker.setAngleAppear(vpMath::rad(options.angle_appear_deg));
  tracker.setAngleDisappear(vpMath::rad(options.angle_disappear_deg));
  tracker.setNearClippingDistance(options.near_clipping);
  tracker.setFarClippingDistance(options.far_clipping);
  tracker.setClipping(tracker.getClipping() | vpPolygon3D::FOV_CLIPPING);
  vpCameraParameters cam;
  cam.initPersProjWithoutDistortion(camera.fx, camera.fy, camera.cx, camera.cy);
  tracker.setCameraParameters(cam);
  if (!options.config_file.empty()) {
    try {
      const SilenceCout quiet;
      tracker.loadConfigFile(options.config_file, false);
    } catch (const vpException& e) {
      throw std::runtime_error("ViSP cannot read '" + options.config_file +
                               "': " + e.getStringMessage());
    }
  }
  tracker.setOgreVisibilityTest(false);
  tracker.setScanLineVisibilityTest(options.scanline_visibility);
  try {
    const SilenceCout quiet;
    tracker.loadModel(cao_path);
  } catch (const vpException& e) {
    throw std::runtime_error("ViSP cannot read '" + cao_path + "': " + e.getStringMessage());
  }
  tracker.setDisplayFeatures(false);
  tracker.setGoodMovingEdgesRatioThreshold(options.good_moving_edges_ratio);

  vpImage<unsigned char> image(static_cast<unsigned>(height), static_cast<unsigned>(width));
  CopyFrame(frames[0], width, height, &image);
  vpHomogeneousMatrix last_good = ToVisp(initial);
  try {
    tracker.initFromPose(image, last_good);
  } catch (const vpException& e) {
    throw std::runtime_error("ViSP cannot start from the initial pose: " + e.getStringMessage());
  }

  std::vector<PeerFrame> out;
  out.reserve(frames.size());
  for (const std::uint8_t* pixels : frames) {
    CopyFrame(pixels, width, height, &image);
    PeerFrame f;
    const auto start = std::chrono::steady_clock::now();
    bool threw = false;
    try {
      tracker.track(image);
    } catch (const vpException&) {
      threw = true;
    }
    f.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::optional<Rigid3d> pose;
    if (!threw) {
      vpHomogeneousMatrix c_m_o;
      tracker.getPose(c_m_o);
      pose = FromVisp(c_m_o);
      if (pose) last_good = c_m_o;
    }
    f.ok = pose.has_value();
    f.camera_from_object = pose ? *pose : *FromVisp(last_good);
    if (!f.ok) {
      // Lost: start the next frame from the last good pose, as a user of ViSP would.
      try {
        tracker.initFromPose(image, last_good);
      } catch (const vpException&) {
      }
    }
    out.push_back(f);
  }
  return out;
}

std::vector<PeerFrame> TrackWithVispDepth(const std::vector<const std::uint8_t*>& frames, int width,
                                          int height, const Camera& camera,
                                          const std::string& cao_path, const Rigid3d& initial,
                                          const VispOptions& options,
                                          const std::vector<DepthCloud>& clouds,
                                          const std::string& depth_config,
                                          const Rigid3d& depth_from_color) {
  if (frames.empty() || clouds.size() != frames.size()) {
    throw std::invalid_argument("TrackWithVispDepth: one depth cloud per frame");
  }
#ifdef _OPENMP
  if (options.threads > 0) omp_set_num_threads(options.threads);
#endif
  vpMbGenericTracker tracker(
      std::vector<int>{vpMbGenericTracker::EDGE_TRACKER, vpMbGenericTracker::DEPTH_DENSE_TRACKER});
  try {
    const SilenceCout quiet;
    tracker.loadConfigFile(options.config_file, depth_config, false);
    tracker.loadModel(cao_path, cao_path);
  } catch (const vpException& e) {
    throw std::runtime_error("ViSP cannot read the settings or the model: " + e.getStringMessage());
  }
  (void)camera;
  tracker.setScanLineVisibilityTest(options.scanline_visibility);
  tracker.setDisplayFeatures(false);
  std::map<std::string, vpHomogeneousMatrix> transforms;
  transforms["Camera2"] = ToVisp(depth_from_color);
  tracker.setCameraTransformationMatrix(transforms);

  vpImage<unsigned char> image(static_cast<unsigned>(height), static_cast<unsigned>(width));
  CopyFrame(frames[0], width, height, &image);
  try {
    tracker.initFromPose(image, ToVisp(initial));
  } catch (const vpException& e) {
    throw std::runtime_error("ViSP cannot start from the initial pose: " + e.getStringMessage());
  }
  std::vector<PeerFrame> out;
  vpHomogeneousMatrix last_good = ToVisp(initial);
  std::vector<vpColVector> cloud;
  for (size_t i = 0; i < frames.size(); ++i) {
    CopyFrame(frames[i], width, height, &image);
    cloud.assign(clouds[i].points.size(), vpColVector(3, 0.0));
    for (size_t k = 0; k < cloud.size(); ++k) {
      for (int j = 0; j < 3; ++j) cloud[k][j] = clouds[i].points[k][j];
    }
    std::map<std::string, const vpImage<unsigned char>*> images{{"Camera1", &image}};
    std::map<std::string, const std::vector<vpColVector>*> points{{"Camera2", &cloud}};
    std::map<std::string, unsigned int> widths{{"Camera2", static_cast<unsigned>(clouds[i].width)}};
    std::map<std::string, unsigned int> heights{
        {"Camera2", static_cast<unsigned>(clouds[i].height)}};
    PeerFrame f;
    const auto start = std::chrono::steady_clock::now();
    bool threw = false;
    try {
      tracker.track(images, points, widths, heights);
    } catch (const vpException&) {
      threw = true;
    }
    f.ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::optional<Rigid3d> pose;
    if (!threw) {
      vpHomogeneousMatrix c_m_o;
      tracker.getPose(c_m_o);
      pose = FromVisp(c_m_o);
      if (pose) last_good = c_m_o;
    }
    f.ok = pose.has_value();
    f.camera_from_object = pose ? *pose : *FromVisp(last_good);
    out.push_back(f);
  }
  return out;
}

}  // namespace cfuse::bench
