#include "cli/track_command.h"

#include <fmt/format.h>
#include <fnmatch.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>
#include <optional>
#include <ostream>
#include <set>

#include "cfuse/importers/visp.h"
#include "cfuse/interp/joint_estimates.h"
#include "cfuse/interp/solve.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/error.h"
#include "cfuse/track/auto_tracker.h"
#include "cfuse/track/tracker.h"
#include "cfuse/vision/depth_file.h"
#include "cli/command_support.h"
#include "cli/image_support.h"
#include "cli/track_overlay.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool HasExtension(const fs::path& path, const std::set<std::string>& extensions) {
  return extensions.count(Lower(path.extension().string())) > 0;
}

const std::set<std::string> kImageExtensions = {".png",  ".jpg", ".jpeg", ".bmp", ".tif",
                                                ".tiff", ".pgm", ".ppm",  ".pnm", ".webp"};
const std::set<std::string> kVideoExtensions = {".avi", ".mp4",  ".mkv", ".mov", ".webm",
                                                ".mpg", ".mpeg", ".m4v", ".wmv", ".ogv"};

// The files `spec` names when it is a glob (wildcards in the file name only) or a directory (its
// files with one of `extensions`, `what` naming them in the error), sorted by name; nothing
// when it is neither (one file, or a video).
std::vector<std::string> ListedFiles(const std::string& spec,
                                     const std::set<std::string>& extensions, const char* what) {
  const SourceLocation where(spec);
  const fs::path path(spec);
  std::error_code ec;
  std::vector<std::string> files;
  if (spec.find_first_of("*?[") == std::string::npos) {
    if (!fs::is_directory(path, ec)) return files;
    for (const fs::directory_entry& e : fs::directory_iterator(path, ec)) {
      if (e.is_regular_file(ec) && HasExtension(e.path(), extensions)) {
        files.push_back(e.path().string());
      }
    }
    if (files.empty()) throw InputError(where, fmt::format("the directory holds no {}", what));
  } else {
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    const std::string pattern = path.filename().string();
    if (dir.string().find_first_of("*?[") != std::string::npos) {
      throw InputError(
          where, "wildcards are allowed in the file name only, not in '" + dir.string() + "'");
    }
    if (!fs::is_directory(dir, ec)) {
      throw InputError(where, "no such directory '" + dir.string() + "'");
    }
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      if (!e.is_regular_file(ec)) continue;
      if (fnmatch(pattern.c_str(), e.path().filename().c_str(), 0) == 0) {
        files.push_back(e.path().string());
      }
    }
    if (files.empty()) throw InputError(where, "no file matches the pattern");
  }
  std::sort(files.begin(), files.end());
  return files;
}

// The frames to track: image files (a glob's matches or a directory's images, sorted by name)
// or a video. Frame i is the i-th file, or the video's i-th frame.
class FrameSource {
 public:
  explicit FrameSource(const std::string& spec) : spec_(spec) {
    const SourceLocation where(spec);
    std::error_code ec;
    files_ = ListedFiles(spec, kImageExtensions, "images (.png, .jpg, .bmp, .tif, ...)");
    if (files_.empty()) {
      if (!fs::exists(spec, ec)) {
        throw InputError(where, "cannot open: no such file or directory");
      } else if (HasExtension(spec, kVideoExtensions)) {
        // Said here: the video back ends fail alike on a file they may not read.
        if (!std::ifstream(spec, std::ios::binary)) {
          throw InputError(where, fmt::format("cannot open: {}", std::strerror(errno)));
        }
        if (!OpenVideoFile(spec)) {
          throw InputError(where, "cannot open the video (no decoder for it, or damaged)");
        }
        const double count = video_.get(cv::CAP_PROP_FRAME_COUNT);
        expected_ = count > 0 && count < 1e9 ? static_cast<int>(count) : 0;
        return;
      }
      files_.push_back(spec);  // one image
    }
    expected_ = static_cast<int>(files_.size());
  }

  // Frames expected (a video may not say: 0).
  int expected() const { return expected_; }
  bool is_video() const { return video_.isOpened(); }

  // The next frame as 8-bit grey into `image`; false at the end. A frame that cannot be read
  // throws InputError (the source goes on with the next).
  bool Next(cv::Mat* image, std::string* name) {
    const int i = next_++;
    if (is_video()) {
      cv::Mat frame;
      bool read = false;
      {
        const QuietStderr quiet;  // a decoder's complaints about a damaged frame
        read = video_.read(frame);
      }
      if (!read || frame.empty()) return false;
      *name = fmt::format("{} frame {}", spec_, i);
      if (frame.channels() == 3) {
        cv::cvtColor(frame, *image, cv::COLOR_BGR2GRAY);
      } else if (frame.channels() == 1 && frame.depth() == CV_8U) {
        *image = frame;
      } else {
        throw InputError(
            SourceLocation(spec_),
            fmt::format("frame {}: {} channels, not 8-bit grey or colour", i, frame.channels()));
      }
      return true;
    }
    if (i >= static_cast<int>(files_.size())) return false;
    *name = files_[i];
    *image = ReadGrayImage(files_[i]);
    return true;
  }

 private:
  // Tries OpenCV's stream back ends in its order of priority, as CAP_ANY would, but not
  // gphoto2: a file is not a camera, and gphoto2 would probe the USB bus for one (slow, and
  // libgphoto2 leaks what it allocates there).
  bool OpenVideoFile(const std::string& spec) {
    const QuietStderr quiet;  // each back end tried logs its failure there
    for (const cv::VideoCaptureAPIs api : cv::videoio_registry::getStreamBackends()) {
      if (api == cv::CAP_GPHOTO2) continue;
      if (video_.open(spec, api) && video_.isOpened()) return true;
    }
    return false;
  }

  std::string spec_;
  std::vector<std::string> files_;
  cv::VideoCapture video_;
  int expected_ = 0;
  int next_ = 0;
};

const std::set<std::string> kDepthExtensions = {".bin", ".png", ".tif", ".tiff", ".pgm"};

// The depth files of `cfuse track --depth`, frame i the i-th, read into the grey camera's frame.
class DepthSource {
 public:
  // Nothing without --depth. Throws InputError for what the options name and cannot be read.
  static std::optional<DepthSource> Open(const TrackCommandOptions& options) {
    if (options.depth.empty()) return std::nullopt;
    DepthSource source;
    source.files_ = ListedFiles(options.depth, kDepthExtensions,
                                "depth files (.bin, or 16-bit .png, .tif, .pgm)");
    if (source.files_.empty()) {
      if (std::error_code ec; !fs::exists(options.depth, ec)) {
        throw InputError(SourceLocation(options.depth), "cannot open: no such file or directory");
      }
      source.files_.push_back(options.depth);
    }
    const Camera camera = LoadAnyCamera(options.depth_camera);
    if (camera.model != Camera::Model::kPinhole) {
      throw InputError(SourceLocation(options.depth_camera),
                       "the depth camera must be a pinhole camera");
    }
    source.intrinsics_.fx = camera.fx;
    source.intrinsics_.fy = camera.fy;
    source.intrinsics_.cx = camera.cx;
    source.intrinsics_.cy = camera.cy;
    if (!options.depth_distortion.empty()) {
      if (options.depth_distortion.size() != 5) {
        throw InputError(SourceLocation("--depth-distortion"),
                         fmt::format("{} coefficients given, 5 needed (k1, k2, p1, p2, k3)",
                                     options.depth_distortion.size()));
      }
      std::copy(options.depth_distortion.begin(), options.depth_distortion.end(),
                source.intrinsics_.coefficients.begin());
    }
    if (!(options.depth_scale > 0) || !std::isfinite(options.depth_scale)) {
      throw InputError(SourceLocation("--depth-scale"),
                       fmt::format("{:g} metres a depth unit: a positive number is needed",
                                   options.depth_scale));
    }
    source.metres_per_unit_ = options.depth_scale;
    if (!options.depth_pose.empty()) {
      source.grey_from_depth_ = ReadVispMatrixPose(options.depth_pose).Inverse();
    }
    return source;
  }

  int count() const { return static_cast<int>(files_.size()); }

  // Frame i's depth (InputError for a file that cannot be read, or none for the frame).
  DepthFrame Read(int i) const {
    if (i >= count()) {
      throw InputError(SourceLocation(files_.back()),
                       fmt::format("no depth file for frame {}: {} given", i, count()));
    }
    return ReadDepthFrame(files_[i], intrinsics_, metres_per_unit_, grey_from_depth_);
  }

 private:
  std::vector<std::string> files_;
  DepthIntrinsics intrinsics_;
  double metres_per_unit_ = 0.001;
  Rigid3d grey_from_depth_;
};

// "[#####.....]  123/456 frames  1.2 ms/frame" redrawn in place.
class ProgressBar {
 public:
  ProgressBar(std::ostream& err, bool enabled, int total)
      : err_(err), enabled_(enabled), total_(total), start_(Clock::now()) {}
  ~ProgressBar() { Finish(); }
  // Clears the bar's line, for what is printed next.
  void Finish() {
    if (shown_) err_ << "\r" << std::string(72, ' ') << "\r" << std::flush;
    shown_ = false;
  }
  void Update(int done, double median_ms) {
    if (!enabled_) return;
    const auto now = Clock::now();
    // Only for runs longer than a second, redrawn ten times a second.
    if (now - start_ < std::chrono::seconds(1) || now - last_ < std::chrono::milliseconds(100)) {
      return;
    }
    last_ = now;
    shown_ = true;
    constexpr int kWidth = 30;
    const int filled = total_ > 0 ? std::min(kWidth, kWidth * done / total_) : 0;
    err_ << "\r[" << std::string(filled, '#') << std::string(kWidth - filled, '.') << "] "
         << (total_ > 0 ? fmt::format("{}/{} frames", done, total_)
                        : fmt::format("{} frames", done))
         << fmt::format("  {:.1f} ms/frame", median_ms) << std::flush;
  }

 private:
  std::ostream& err_;
  bool enabled_;
  int total_;
  Clock::time_point start_, last_;
  bool shown_ = false;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Frame numbers as ranges: "3, 7-9, 12".
std::string Ranges(const std::vector<int>& frames, size_t max_items = 8) {
  std::string out;
  size_t items = 0;
  for (size_t i = 0; i < frames.size();) {
    size_t j = i;
    while (j + 1 < frames.size() && frames[j + 1] == frames[j] + 1) ++j;
    if (items == max_items) return out + ", ...";
    if (!out.empty()) out += ", ";
    out += j == i ? std::to_string(frames[i]) : fmt::format("{}-{}", frames[i], frames[j]);
    ++items;
    i = j + 1;
  }
  return out;
}

}  // namespace

std::string TrackCsvHeader(const ConstraintGraph& graph, bool fit) {
  std::string out = "frame,time_ms,verified";
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    for (const char* field : {"x", "y", "z", "qw", "qx", "qy", "qz"}) {
      out += fmt::format(",{}.{}", c.name, field);
    }
  }
  for (const Joint& j : graph.joints) {
    if (HasJointVariable(j.type)) out += "," + j.name;
  }
  if (fit) out += ",support,sigma_mm,chi2,dof,p_value";
  return out + "\n";
}

std::string TrackCsvRow(const ConstraintGraph& graph, int frame, double time_ms, bool verified,
                        const Values& values, const TrackedFrame* fit) {
  std::string out = fmt::format("{},{:.3f},{}", frame, time_ms, verified ? 1 : 0);
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const Rigid3d& pose = values.poses[graph.blocks[c.block].index];
    const Eigen::Quaterniond& q = pose.rotation;
    // Micrometres and 1e-7 of a unit quaternion: below any tracker's precision.
    out += fmt::format(",{:.6f},{:.6f},{:.6f},{:.7f},{:.7f},{:.7f},{:.7f}", pose.translation.x(),
                       pose.translation.y(), pose.translation.z(), q.w(), q.x(), q.y(), q.z());
  }
  const Eigen::VectorXd joints = JointValues(graph, values);
  for (Eigen::Index k = 0; k < joints.size(); ++k) out += fmt::format(",{:.6f}", joints[k]);
  if (fit) {
    out += fmt::format(",{:.3f},{:.2f}", fit->verification.share, 1000 * fit->position_sigma);
    // Empty when lost: no set of matches was accepted to have a fit.
    if (verified) {
      const double p = fit->fit_dof > 0 ? 1 - ChiSquareCdf(fit->chi2, fit->fit_dof) : 1.0;
      out += fmt::format(",{:.3f},{},{:.3g}", fit->chi2, fit->fit_dof, p);
    } else {
      out += ",,,";
    }
  }
  return out + "\n";
}

// What a track did, frame by frame, for its report.
struct TrackTally {
  int frames = 0, verified = 0;
  std::vector<int> lost, unreadable;
  // The lost frames' refusals by kind: how many, and the first one's words.
  std::map<int, std::pair<int, std::string>> why_lost;
  std::vector<double> ms;
  FrameTimes sum;
  std::vector<int> detected;  // frames found by detection with no pose given
};

// The summary after the track (on stderr when the track itself went to stdout), and the exit
// status: 2 when frames could not be read, 1 when none was verified.
int ReportTrack(const TrackCommandOptions& options, const ConstraintGraph& graph,
                const TrackTally& t, std::ostream& out, std::ostream& err) {
  std::ostream& report = options.output.empty() ? err : out;
  const double n = std::max(1, t.frames);
  report << fmt::format("track: '{}', {} frames: {} verified ({:.1f} %){}\n", graph.name, t.frames,
                        t.verified, 100.0 * t.verified / n,
                        t.lost.empty() ? "" : ", lost: " + Ranges(t.lost));
  if (!t.detected.empty()) {
    report << fmt::format("found by detection with no pose given: frame{} {}\n",
                          t.detected.size() == 1 ? "" : "s", Ranges(t.detected));
  }
  if (!t.why_lost.empty()) {
    // The reason most lost frames gave (a refusal says why).
    const auto most = std::max_element(
        t.why_lost.begin(), t.why_lost.end(),
        [](const auto& a, const auto& b) { return a.second.first < b.second.first; });
    report << fmt::format("lost, most often ({} of {}): {}\n", most->second.first, t.lost.size(),
                          most->second.second);
  }
  if (!t.ms.empty()) {
    report << fmt::format(
        "time per frame: median {:.2f} ms, worst {:.2f} ms (mean: edges {:.2f}, prediction "
        "{:.2f}, search {:.2f}, estimation {:.2f}, verification {:.2f}{})\n",
        Median(t.ms), *std::max_element(t.ms.begin(), t.ms.end()), t.sum.segments / n,
        t.sum.prediction / n, t.sum.search / n, t.sum.estimation / n, t.sum.verification / n,
        t.sum.detection > 0 ? fmt::format(", detection {:.2f}", t.sum.detection / n) : "");
  }
  if (!options.output.empty()) report << fmt::format("track -> {}\n", options.output);
  if (!options.overlay.empty()) report << fmt::format("overlays -> {}/\n", options.overlay);
  if (!t.unreadable.empty()) {
    err << fmt::format("cfuse track: {} frame(s) could not be read ({}), see above\n",
                       t.unreadable.size(), Ranges(t.unreadable));
    return 2;
  }
  return t.verified > 0 ? 0 : 1;
}

int RunTrack(const TrackCommandOptions& options, std::ostream& out, std::ostream& err) {
  return Guarded(err, [&] {
    // Refused before any frame is tracked, so that a bad track path leaves no overlays behind.
    if (!options.output.empty()) RequireWritable(options.output);
    if (std::error_code ec; !options.overlay.empty() && fs::exists(options.overlay, ec) &&
                            !fs::is_directory(options.overlay, ec)) {
      throw InputError(SourceLocation(options.overlay), "cannot write: it is not a directory");
    }
    const ConstraintGraph graph = LoadAnyModel(options.model);
    RequireEstimable(graph);
    // A camera without an image size (ViSP's tracker settings give none) takes the first frame's;
    // one with a size must match it.
    Camera camera = LoadAnyCamera(options.camera);
    const bool camera_sized = camera.width > 0 && camera.height > 0;
    // Without a start, the first frame is detected (cfuse/track/auto_tracker.h).
    std::optional<Values> initial;
    if (!options.init.empty()) initial = PosedModel(graph, options.init);
    RequireEdges(graph, options.model, "track");
    FrameSource source(options.images);
    const std::optional<DepthSource> depth = DepthSource::Open(options);
    if (depth && source.expected() > 0 && depth->count() != source.expected()) {
      throw InputError(SourceLocation(options.depth),
                       fmt::format("{} depth files for {} frames: one a frame is needed",
                                   depth->count(), source.expected()));
    }

    TrackerOptions tracker_options;
    tracker_options.max_branches = options.max_branches;
    // Made with the first frame that is read, whose size it needs; frames skipped before it are
    // counted so that the prediction spans them all the same.
    std::optional<AutoTracker> tracker;
    int skipped_before_first = 0;
    std::string csv = TrackCsvHeader(graph, true);
    TrackTally tally;
    std::vector<double>& ms = tally.ms;
    std::vector<int>&lost = tally.lost, &unreadable = tally.unreadable;
    auto& why_lost = tally.why_lost;
    FrameTimes& sum = tally.sum;
    int &frames = tally.frames, &verified = tally.verified;
    ProgressBar progress(err, options.progress, source.expected());
    // A frame whose image or depth cannot be read is reported and skipped: the prediction
    // spans it.
    auto skip = [&](int frame, const InputError& e) {
      err << e.what() << ": skipped, the track goes on\n";
      unreadable.push_back(frame);
      if (tracker) {
        tracker->Skip();
      } else {
        ++skipped_before_first;
      }
    };
    for (int frame = 0;; ++frame) {
      cv::Mat image;
      std::string name;
      bool more = false;
      try {
        more = source.Next(&image, &name);
      } catch (const InputError& e) {
        skip(frame, e);
        continue;
      }
      if (!more) break;
      std::optional<DepthFrame> depth_frame;
      try {
        if (depth) depth_frame = depth->Read(frame);
      } catch (const InputError& e) {
        skip(frame, e);
        continue;
      }
      if (!tracker && !camera_sized) SizeCameraFromImage(image, name, options.camera, &camera);
      if (image.cols != camera.width || image.rows != camera.height) {
        const std::string why =
            camera_sized
                ? fmt::format("the image is {} x {}, the camera's ({}) {} x {}", image.cols,
                              image.rows, options.camera, camera.width, camera.height)
                : fmt::format(
                      "the image is {} x {}, the first frame's {} x {} (the camera, {}, "
                      "gives no size)",
                      image.cols, image.rows, camera.width, camera.height, options.camera);
        // The first frame decides whether the camera fits the sequence; a later odd one out is
        // skipped like an unreadable one.
        if (!tracker) throw InputError(SourceLocation(name), why);
        err << InputError(SourceLocation(name), why).what() << ": skipped, the track goes on\n";
        unreadable.push_back(frame);
        tracker->Skip();
        continue;
      }
      if (!tracker) {
        AutoTrackerOptions auto_options;
        auto_options.tracker = tracker_options;
        tracker.emplace(graph, camera, initial, auto_options);
        for (int k = 0; k < skipped_before_first; ++k) tracker->Skip();
      }
      const GrayView view{image.data, image.cols, image.rows, static_cast<int>(image.step)};
      const TrackedFrame f =
          depth_frame ? tracker->Track(view, *depth_frame) : tracker->Track(view);
      ++frames;
      verified += f.verified ? 1 : 0;
      if (f.detected) tally.detected.push_back(frame);
      if (!f.verified) {
        lost.push_back(frame);
        // Grouped by the test that failed, with the first frame's words for it.
        auto& [count, words] = why_lost[static_cast<int>(f.verification.refusal)];
        if (count++ == 0) {
          words = f.verification.why;
        }
      }
      ms.push_back(f.times.Total());
      sum += f.times;
      csv += TrackCsvRow(graph, frame, f.times.Total(), f.verified, f.estimate.mean, &f);
      if (!options.overlay.empty()) {
        if (frames == 1) {
          // (created with the first frame tracked: an input error before leaves nothing behind)
          std::error_code ec;
          fs::create_directories(options.overlay, ec);
          if (!fs::is_directory(options.overlay, ec)) {
            throw InputError(SourceLocation(options.overlay),
                             "cannot create the overlay directory");
          }
        }
        OverlayOptions overlay;
        overlay.caption = fmt::format("frame {}  {}  {} matches  {:.1f} ms", frame,
                                      f.verified ? "verified" : "LOST", f.matches, f.times.Total());
        WriteFileAtomically(
            (fs::path(options.overlay) / fmt::format("frame_{:05d}.png", frame)).string(),
            PngBytes(DrawOverlay(view, graph, camera, f, overlay)));
      }
      progress.Update(frame + 1, Median(ms));
    }
    progress.Finish();
    // Not one frame tracked: bad input, with nothing written (not a track of a header only).
    if (frames == 0) {
      throw InputError(SourceLocation(options.images),
                       unreadable.empty() ? std::string("the video holds no frames")
                                          : fmt::format("none of the {} frame(s) could be read",
                                                        unreadable.size()));
    }

    if (options.output.empty()) {
      out << csv;
    } else {
      WriteFileAtomically(options.output, csv);
    }
    return ReportTrack(options, graph, tally, out, err);
  });
}

}  // namespace cfuse::cli
