// Every command's error paths (issue 8), through the Run*() functions and through the `cfuse`
// program itself: a missing input, a directory, a file of another format, an unreadable file,
// an output that cannot be written, an unknown option. Each exits 2 with one message naming the
// file (and the line and column, or the element, where the format has them) and writes nothing:
// no output, no temporary file, not one output of several. A solve that finds no acceptable
// answer exits 1.
#include <fmt/format.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/image_commands.h"
#include "cli/track_command.h"
#include "test_util.h"

namespace cfuse::cli {
namespace {

namespace fs = std::filesystem;
using Catch::Matchers::StartsWith;

// A directory of the test case's own (ctest runs test cases in parallel) with good inputs, bad
// ones, and `out/` for outputs.
class Workspace {
 public:
  explicit Workspace(const std::string& name)
      : dir_(fs::temp_directory_path() / fmt::format("cfuse_errors_{}_{}", name, ::getpid())) {
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "out");
    Write("camera.json",
          R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640, "height": 480})");
    Write("pose.json", R"({"components": {
        "box": {"position": [-0.15, -0.1, 1.2], "quaternion": [1, 0, 0, 0]},
        "lid": {"position": [-0.15, 0.15, 1.4], "quaternion": [1, 0, 0, 0]}}})");
    Write("joints.json", R"({"hinge": 0.3})");
    cv::Mat image(480, 640, CV_8U, cv::Scalar(60));
    cv::rectangle(image, cv::Rect(200, 150, 240, 180), cv::Scalar(200), cv::FILLED);
    cv::imwrite(Path("image.png"), image);
    fs::create_directories(dir_ / "frames");
    fs::copy_file(Path("image.png"), Path("frames/frame_00000.png"));
    // Bad inputs.
    fs::create_directories(dir_ / "dir.yaml");
    fs::create_directories(dir_ / "dir.json");
    fs::create_directories(dir_ / "no_images");
    Write("notes.txt", "not a model\n");
    Write("binary.yaml", std::string("points:\n\0\x01\x02", 11));
    Write("list.yaml", "- a\n- b\n");
    Write("text.png", "not a picture\n");
    std::ifstream png(Path("image.png"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(png)), std::istreambuf_iterator<char>());
    Write("truncated.png", bytes.substr(0, 100));
    Write("fake.avi", "not a video\n");
    Write("cv_syntax.yml", "%YAML:1.0\n---\nimage_width: 640\nimage_height 480\n");
    Write("cv_truncated.yml", "%YAML:1.0\n---\nimage_width: [640\n");
  }
  ~Workspace() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  Workspace(const Workspace&) = delete;
  Workspace& operator=(const Workspace&) = delete;

  std::string Path(const std::string& relative) const { return (dir_ / relative).string(); }
  std::string Write(const std::string& relative, const std::string& bytes) const {
    std::ofstream(dir_ / relative, std::ios::binary) << bytes;
    return Path(relative);
  }
  // Every file and directory in the workspace: what a refused command must leave unchanged.
  std::set<std::string> Listing() const {
    std::set<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir_)) out.insert(e.path().string());
    return out;
  }

 private:
  fs::path dir_;
};

using Runner = std::function<int(std::ostream&, std::ostream&)>;

// The command refuses: `status`, stderr starting with `message` in `lines` lines, nothing on
// stdout, nothing new in the workspace.
void ExpectRefused(const Workspace& ws, const Runner& run, const std::string& message,
                   int lines = 1) {
  const std::set<std::string> before = ws.Listing();
  std::ostringstream out, err;
  INFO("expected: " << message);
  CHECK(run(out, err) == 2);
  const std::string text = err.str();
  CHECK_THAT(text, StartsWith(message));
  CHECK(std::count(text.begin(), text.end(), '\n') == lines);
  CHECK(out.str().empty());
  CHECK(ws.Listing() == before);
}

const std::string kBox = testing::SourcePath("examples/hinged-box.yaml");
const std::string kLamp = testing::SourcePath("examples/lamp.yaml");
const std::string kLampMeasurements = testing::SourcePath("tests/data/lamp-measurements.json");

// Every command that reads a model, with good other inputs and outputs, for `model`.
std::vector<std::pair<std::string, std::function<Runner(const std::string&)>>> ModelCommands(
    const Workspace& ws) {
  return {
      {"check",
       [](const std::string& m) -> Runner {
         return [m](auto& out, auto& err) { return RunCheck({m, true, {}}, out, err); };
       }},
      {"graph",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           return RunGraph({m, ws.Path("out/g.dot")}, out, err);
         };
       }},
      {"plan",
       [](const std::string& m) -> Runner {
         return [m](auto& out, auto& err) { return RunPlan({m, false}, out, err); };
       }},
      {"solve",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           SolveCommandOptions o;
           o.model = m;
           o.measurements = kLampMeasurements;
           o.output = ws.Path("out/r.json");
           return RunSolve(o, out, err);
         };
       }},
      {"interpret",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           InterpretCommandOptions o;
           o.model = m;
           o.measurements = kLampMeasurements;
           o.output = ws.Path("out/r.json");
           o.tree = ws.Path("out/tree.dot");
           return RunInterpret(o, out, err);
         };
       }},
      {"simulate",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           SimulateCommandOptions o;
           o.model = m;
           o.output = ws.Path("out/m.json");
           o.truth = ws.Path("out/t.json");
           return RunSimulate(o, out, err);
         };
       }},
      {"import",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           return RunImport({m, ws.Path("out/m.yaml")}, out, err);
         };
       }},
      {"fk",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           return RunFk({m, "", ws.Path("out/p.json")}, out, err);
         };
       }},
      {"project",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           ProjectCommandOptions o;
           o.model = m;
           o.camera = ws.Path("camera.json");
           o.pose = ws.Path("pose.json");
           o.output = ws.Path("out/e.json");
           return RunProject(o, out, err);
         };
       }},
      {"render",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           RenderCommandOptions o;
           o.model = m;
           o.camera = ws.Path("camera.json");
           o.pose = ws.Path("pose.json");
           o.output = ws.Path("out/r.png");
           return RunRender(o, out, err);
         };
       }},
      {"track",
       [&ws](const std::string& m) -> Runner {
         return [&ws, m](auto& out, auto& err) {
           TrackCommandOptions o;
           o.model = m;
           o.camera = ws.Path("camera.json");
           o.images = ws.Path("frames/*.png");
           o.init = ws.Path("pose.json");
           o.output = ws.Path("out/t.csv");
           o.overlay = ws.Path("out/overlays");
           return RunTrack(o, out, err);
         };
       }},
  };
}

TEST_CASE("errors: every command refuses a bad model file with status 2", "[cli][errors]") {
  const Workspace ws("model");
  const std::string unreadable = ws.Write("unreadable.yaml", "points: {p: [0, 0, 0]}\n");
  fs::permissions(unreadable, fs::perms::none);
  const bool can_deny = !std::ifstream(unreadable);  // root reads it anyway
  for (const auto& [command, make] : ModelCommands(ws)) {
    INFO("cfuse " << command);
    ExpectRefused(ws, make(ws.Path("none.yaml")),
                  ws.Path("none.yaml") + ": error: cannot open: no such file");
    ExpectRefused(ws, make(ws.Path("none.urdf")),
                  ws.Path("none.urdf") + ": error: cannot open: no such file");
    ExpectRefused(ws, make(ws.Path("dir.yaml")),
                  ws.Path("dir.yaml") + ": error: is a directory, not a model file");
    ExpectRefused(ws, make(ws.Path("no_images")),
                  ws.Path("no_images") + ": error: is a directory, not a model file");
    ExpectRefused(ws, make(ws.Path("notes.txt")),
                  ws.Path("notes.txt") + ": error: unsupported model format '.txt'");
    ExpectRefused(ws, make(ws.Path("binary.yaml")),
                  ws.Path("binary.yaml") + ": error: is a binary file, not a YAML model");
    ExpectRefused(ws, make(ws.Path("list.yaml")),
                  ws.Path("list.yaml") + ":1:1: error: a model file is a mapping");
    if (can_deny) {
      ExpectRefused(ws, make(unreadable), unreadable + ": error: cannot open: Permission denied");
    }
  }
  fs::permissions(unreadable, fs::perms::owner_all);
}

TEST_CASE("errors: measurement, pose, camera and joint files refused with status 2",
          "[cli][errors]") {
  const Workspace ws("inputs");
  auto solve = [&](const std::string& measurements, const std::string& guess) -> Runner {
    return [=, &ws](auto& out, auto& err) {
      SolveCommandOptions o;
      o.model = kLamp;
      o.measurements = measurements;
      o.guess = guess;
      o.output = ws.Path("out/r.json");
      return RunSolve(o, out, err);
    };
  };
  auto interpret = [&](const std::string& measurements) -> Runner {
    return [=, &ws](auto& out, auto& err) {
      InterpretCommandOptions o;
      o.model = kLamp;
      o.measurements = measurements;
      o.output = ws.Path("out/r.json");
      return RunInterpret(o, out, err);
    };
  };
  for (const auto& run : {std::function<Runner(const std::string&)>(
                              [&](const std::string& m) { return solve(m, ""); }),
                          std::function<Runner(const std::string&)>(interpret)}) {
    ExpectRefused(ws, run(ws.Path("none.json")),
                  ws.Path("none.json") + ": error: cannot open: no such file");
    ExpectRefused(ws, run(ws.Path("dir.json")),
                  ws.Path("dir.json") + ": error: is a directory, not a measurement file");
    ExpectRefused(ws, run(ws.Path("binary.yaml")),
                  ws.Path("binary.yaml") + ": error: is a binary file, not a YAML measurement");
    ExpectRefused(ws, run(ws.Path("list.yaml")),
                  ws.Path("list.yaml") + ":1:1: error: a measurement file is a mapping");
    ExpectRefused(ws, run(kBox),
                  kBox +
                      ":5:1: error: unknown key 'name' in the measurements; expected one of: "
                      "camera, points");
  }

  // Poses: solve --guess, project --pose, render --pose, track --init.
  const std::vector<std::function<Runner(const std::string&)>> pose_readers = {
      [&](const std::string& p) { return solve(kLampMeasurements, p); },
      [&](const std::string& p) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          ProjectCommandOptions o;
          o.model = kBox;
          o.camera = ws.Path("camera.json");
          o.pose = p;
          return RunProject(o, out, err);
        };
      },
      [&](const std::string& p) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          RenderCommandOptions o;
          o.model = kBox;
          o.camera = ws.Path("camera.json");
          o.pose = p;
          o.output = ws.Path("out/r.png");
          return RunRender(o, out, err);
        };
      },
      [&](const std::string& p) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          TrackCommandOptions o;
          o.model = kBox;
          o.camera = ws.Path("camera.json");
          o.images = ws.Path("frames/*.png");
          o.init = p;
          return RunTrack(o, out, err);
        };
      }};
  for (const auto& run : pose_readers) {
    ExpectRefused(ws, run(ws.Path("none.json")),
                  ws.Path("none.json") + ": error: cannot open: no such file");
    ExpectRefused(ws, run(ws.Path("dir.json")),
                  ws.Path("dir.json") + ": error: is a directory, not a pose file");
    ExpectRefused(ws, run(ws.Path("camera.json")),
                  ws.Path("camera.json") + ":1:1: error: a pose file needs 'components'");
  }

  // Cameras: simulate, project, render, track.
  const std::vector<std::function<Runner(const std::string&)>> camera_readers = {
      [&](const std::string& c) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          SimulateCommandOptions o;
          o.model = kBox;
          o.camera = c;
          o.output = ws.Path("out/m.json");
          o.truth = ws.Path("out/t.json");
          return RunSimulate(o, out, err);
        };
      },
      [&](const std::string& c) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          ProjectCommandOptions o;
          o.model = kBox;
          o.camera = c;
          o.pose = ws.Path("pose.json");
          return RunProject(o, out, err);
        };
      },
      [&](const std::string& c) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          RenderCommandOptions o;
          o.model = kBox;
          o.camera = c;
          o.pose = ws.Path("pose.json");
          o.output = ws.Path("out/r.png");
          return RunRender(o, out, err);
        };
      },
      [&](const std::string& c) -> Runner {
        return [=, &ws](auto& out, auto& err) {
          TrackCommandOptions o;
          o.model = kBox;
          o.camera = c;
          o.images = ws.Path("frames/*.png");
          o.init = ws.Path("pose.json");
          return RunTrack(o, out, err);
        };
      }};
  for (const auto& run : camera_readers) {
    ExpectRefused(ws, run(ws.Path("none.json")),
                  ws.Path("none.json") + ": error: cannot open: no such file");
    ExpectRefused(ws, run(ws.Path("dir.json")),
                  ws.Path("dir.json") + ": error: is a directory, not a camera file");
    ExpectRefused(ws, run(ws.Path("pose.json")),
                  ws.Path("pose.json") + ":1:2: error: unknown key 'components' in camera");
    ExpectRefused(
        ws, run(ws.Path("cv_syntax.yml")),
        ws.Path("cv_syntax.yml") + ":4: error: syntax error (cv::FileStorage): Missing ':'");
    // Refused before cv::FileStorage parses it (vision/src/file_storage_screen.h).
    ExpectRefused(ws, run(ws.Path("cv_truncated.yml")),
                  ws.Path("cv_truncated.yml") +
                      ":4:1: error: expected ']' to close the flow sequence opened at 3:14, found "
                      "the end of the file");
  }

  // Joint values: fk --joints.
  auto fk = [&](const std::string& joints) -> Runner {
    return [=](auto& out, auto& err) { return RunFk({kBox, joints, ""}, out, err); };
  };
  ExpectRefused(ws, fk(ws.Path("none.json")),
                ws.Path("none.json") + ": error: cannot open: no such file");
  ExpectRefused(ws, fk(ws.Path("dir.json")),
                ws.Path("dir.json") + ": error: is a directory, not a joint values file");
  ExpectRefused(ws, fk(ws.Path("list.yaml")),
                ws.Path("list.yaml") + ":1:1: error: a joint-values file is a mapping");
  ExpectRefused(ws, fk(ws.Path("camera.json")),
                ws.Path("camera.json") + ":1:2: joint 'fx': error: 'fx' is not a joint of model");
}

TEST_CASE("errors: a file that may not be read, of every kind", "[cli][errors]") {
  const Workspace ws("unreadable");
  auto locked = [&](const std::string& name, const std::string& from) {
    const std::string path = ws.Path(name);
    fs::copy_file(from, path);
    fs::permissions(path, fs::perms::none);
    return path;
  };
  const std::string urdf = locked("robot.urdf", testing::SourcePath("tests/data/urdf/arm.urdf"));
  if (std::ifstream(urdf)) {
    WARN("skipped: this user (root) reads files whatever their permissions");
    return;
  }
  const std::string cao = locked("cube.cao", testing::SourcePath("tests/data/cao/cube.cao"));
  const std::string measurements = locked("m.json", kLampMeasurements);
  const std::string pose = locked("p.json", ws.Path("pose.json"));
  const std::string camera = locked("c.json", ws.Path("camera.json"));
  const std::string opencv =
      locked("c.yml", testing::SourcePath("tests/data/cameras/opencv_calibration.yml"));
  const std::string joints = locked("q.json", ws.Path("joints.json"));
  const std::string image = locked("i.png", ws.Path("image.png"));
  const std::string video = locked("v.avi", ws.Path("fake.avi"));
  const std::string denied = ": error: cannot open: Permission denied";
  for (const std::string& model : {urdf, cao}) {
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          return RunCheck({model, false, {}}, o, e);
        },
        model + denied);
  }
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        SolveCommandOptions s;
        s.model = kLamp;
        s.measurements = measurements;
        return RunSolve(s, o, e);
      },
      measurements + denied);
  for (const std::string& c : {camera, opencv}) {
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          ProjectCommandOptions s;
          s.model = kBox;
          s.camera = c;
          s.pose = ws.Path("pose.json");
          return RunProject(s, o, e);
        },
        c + denied);
  }
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        ProjectCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.pose = pose;
        return RunProject(s, o, e);
      },
      pose + denied);
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        return RunFk({kBox, joints, ""}, o, e);
      },
      joints + denied);
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        SegmentsCommandOptions s;
        s.image = image;
        return RunSegments(s, o, e);
      },
      image + denied);
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        TrackCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.images = video;
        s.init = ws.Path("pose.json");
        return RunTrack(s, o, e);
      },
      video + denied);
  for (const auto& entry : fs::directory_iterator(ws.Path(""))) {
    fs::permissions(entry.path(), fs::perms::owner_all, fs::perm_options::add);
  }
}

TEST_CASE("errors: images, frames and videos refused with status 2", "[cli][errors]") {
  const Workspace ws("images");
  auto segments = [&](const std::string& image) -> Runner {
    return [=, &ws](auto& out, auto& err) {
      SegmentsCommandOptions o;
      o.image = image;
      o.output = ws.Path("out/s.json");
      o.overlay = ws.Path("out/s.png");
      return RunSegments(o, out, err);
    };
  };
  auto project = [&](const std::string& image) -> Runner {
    return [=, &ws](auto& out, auto& err) {
      ProjectCommandOptions o;
      o.model = kBox;
      o.camera = ws.Path("camera.json");
      o.pose = ws.Path("pose.json");
      o.output = ws.Path("out/e.json");
      o.overlay = ws.Path("out/e.png");
      o.image = image;
      return RunProject(o, out, err);
    };
  };
  for (const auto& run : {std::function<Runner(const std::string&)>(segments),
                          std::function<Runner(const std::string&)>(project)}) {
    ExpectRefused(ws, run(ws.Path("none.png")),
                  ws.Path("none.png") + ": error: cannot open: no such file");
    ExpectRefused(ws, run(ws.Path("dir.json")),
                  ws.Path("dir.json") + ": error: cannot open: it is a directory");
    ExpectRefused(ws, run(ws.Path("text.png")),
                  ws.Path("text.png") + ": error: cannot read the image: not in a format");
    ExpectRefused(ws, run(ws.Path("truncated.png")),
                  ws.Path("truncated.png") + ": error: cannot read the image: not in a format");
  }
  // An image over the size limit is refused before it is read (a sparse file: no disk used).
  const std::string huge = ws.Write("huge.png", "");
  fs::resize_file(huge, (512ull << 20) + 1);
  ExpectRefused(ws, segments(huge),
                huge + ": error: the file is larger than the 512 MiB limit for images");
  fs::remove(huge);

  auto track = [&](const std::string& images) -> Runner {
    return [=, &ws](auto& out, auto& err) {
      TrackCommandOptions o;
      o.model = kBox;
      o.camera = ws.Path("camera.json");
      o.images = images;
      o.init = ws.Path("pose.json");
      o.output = ws.Path("out/t.csv");
      o.overlay = ws.Path("out/overlays");
      return RunTrack(o, out, err);
    };
  };
  ExpectRefused(ws, track(ws.Path("none.png")),
                ws.Path("none.png") + ": error: cannot open: no such file or directory");
  ExpectRefused(ws, track(ws.Path("no_images")),
                ws.Path("no_images") + ": error: the directory holds no images");
  ExpectRefused(ws, track(ws.Path("fr*/*.png")),
                ws.Path("fr*/*.png") + ": error: wildcards are allowed in the file name only");
  ExpectRefused(ws, track(ws.Path("fake.avi")),
                ws.Path("fake.avi") +
                    ": error: cannot open the video (no decoder for it, or "
                    "damaged)");
  // No frame readable: the frame's message, then the sequence's; no track of a header only.
  ExpectRefused(ws, track(ws.Path("text.png")),
                ws.Path("text.png") + ": error: cannot read the image", 2);
  std::ostringstream out, err;
  track(ws.Path("text.png"))(out, err);
  CHECK_THAT(err.str(),
             Catch::Matchers::EndsWith(ws.Path("text.png") +
                                       ": error: none of the 1 frame(s) could be read\n"));
}

TEST_CASE("errors: an output that cannot be written is refused, and nothing is written",
          "[cli][errors]") {
  const Workspace ws("outputs");
  // Where an output cannot go: a directory that does not exist, a directory itself, a path
  // under a file.
  const std::vector<std::pair<std::string, std::string>> bad_outputs = {
      {ws.Path("missing/x.out"),
       ": error: cannot write: directory '" + ws.Path("missing") + "' does not exist"},
      {ws.Path("out"), ": error: cannot write: it is a directory"},
      {ws.Path("notes.txt/x.out"),
       ": error: cannot write: '" + ws.Path("notes.txt") + "' is not a directory"},
  };
  const std::string good = ws.Path("out/good.out");
  for (const auto& [bad, why] : bad_outputs) {
    INFO("output " << bad);
    const std::string message = bad + why;
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          return RunGraph({kBox, bad}, o, e);
        },
        message);
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          return RunImport({kBox, bad}, o, e);
        },
        message);
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          return RunFk({kBox, "", bad}, o, e);
        },
        message);
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          SolveCommandOptions s;
          s.model = kLamp;
          s.measurements = kLampMeasurements;
          s.output = bad;
          return RunSolve(s, o, e);
        },
        message);
    // Two outputs, one good: neither is written.
    for (const bool tree_bad : {false, true}) {
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            InterpretCommandOptions s;
            s.model = kLamp;
            s.measurements = kLampMeasurements;
            s.output = tree_bad ? good : bad;
            s.tree = tree_bad ? bad : good;
            return RunInterpret(s, o, e);
          },
          message);
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            SimulateCommandOptions s;
            s.model = kLamp;
            s.output = tree_bad ? good : bad;
            s.truth = tree_bad ? bad : good;
            return RunSimulate(s, o, e);
          },
          message);
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            SegmentsCommandOptions s;
            s.image = ws.Path("image.png");
            s.output = tree_bad ? good : bad;
            s.overlay = tree_bad ? bad : good;
            return RunSegments(s, o, e);
          },
          message);
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            ProjectCommandOptions s;
            s.model = kBox;
            s.camera = ws.Path("camera.json");
            s.pose = ws.Path("pose.json");
            s.image = ws.Path("image.png");
            s.output = tree_bad ? good : bad;
            s.overlay = tree_bad ? bad : good;
            return RunProject(s, o, e);
          },
          message);
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            RenderCommandOptions s;
            s.model = kBox;
            s.camera = ws.Path("camera.json");
            s.pose = ws.Path("pose.json");
            s.output = tree_bad ? good : bad;
            s.truth = tree_bad ? bad : good;
            return RunRender(s, o, e);
          },
          message);
    }
    // track: refused before the first frame, so no overlay is left either.
    ExpectRefused(
        ws,
        [&](auto& o, auto& e) {
          TrackCommandOptions s;
          s.model = kBox;
          s.camera = ws.Path("camera.json");
          s.images = ws.Path("frames/*.png");
          s.init = ws.Path("pose.json");
          s.output = bad;
          s.overlay = ws.Path("out/overlays");
          return RunTrack(s, o, e);
        },
        message);
  }
  // A file where an overlay directory goes: refused before anything runs, the file kept.
  const std::string file = ws.Path("notes.txt");
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        TrackCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.images = ws.Path("frames/*.png");
        s.init = ws.Path("pose.json");
        s.output = good;
        s.overlay = file;
        return RunTrack(s, o, e);
      },
      file + ": error: cannot write: it is not a directory");
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        return RunDemo({ws.Path("out/demo.png"), file}, o, e);
      },
      file + ": error: cannot write: it is not a directory");
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        return RunDemo({ws.Path("missing/demo.png"), ws.Path("out/demo")}, o, e);
      },
      ws.Path("missing/demo.png") + ": error: cannot write: directory");
  // An overlay directory that cannot be created (under a file): the track's at its first
  // frame, the demo's before it renders; the demo's picture is not left behind either.
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        TrackCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.images = ws.Path("frames/*.png");
        s.init = ws.Path("pose.json");
        s.output = good;
        s.overlay = file + "/overlays";
        return RunTrack(s, o, e);
      },
      file + "/overlays: error: cannot create the overlay directory");
  {
    const std::set<std::string> before = ws.Listing();
    std::ostringstream out, err;
    CHECK(RunDemo({ws.Path("out/demo.png"), file + "/overlays"}, out, err) == 2);
    CHECK(err.str() == file + "/overlays: error: cannot create the directory: Not a directory\n");
    CHECK(ws.Listing() == before);
  }
  // A write that fails after the checks (here /proc, where no file can be created): the other
  // output, already staged, is not left behind.
  if (fs::is_directory("/proc")) {
    for (const bool truth_bad : {false, true}) {
      const std::string bad = "/proc/cfuse_error_paths_test.json";
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            SimulateCommandOptions s;
            s.model = kLamp;
            s.output = truth_bad ? good : bad;
            s.truth = truth_bad ? bad : good;
            return RunSimulate(s, o, e);
          },
          bad + ": error: cannot write: ");
    }
  }
  // render --sequence: a new directory in an existing one.
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        RenderCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.sequence = "steady";
        s.frames = 2;
        s.output = ws.Path("missing/deeper/seq");
        return RunRender(s, o, e);
      },
      ws.Path("missing/deeper/seq") + ": error: cannot write: directory '" +
          ws.Path("missing/deeper") + "' does not exist");
}

TEST_CASE("errors: what the inputs cannot do, at the input", "[cli][errors]") {
  const Workspace ws("semantics");
  // A camera whose image is too large to render, before any allocation.
  const std::string big = ws.Write(
      "big.json",
      R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 1000000, "height": 1000000})");
  const std::string distorted =
      ws.Write("distorted.json", R"({"fx": 800, "fy": 800, "cx": 320, "cy": 240, "width": 640,
                            "height": 480, "dist": [-0.2, 0.05, 0, 0, 0]})");
  for (const bool sequence : {false, true}) {
    for (const auto& [camera, message] :
         {std::pair{big,
                    ": error: the camera's image, 1000000 x 1000000 pixels, is larger than "
                    "the renderer's limit"},
          std::pair{distorted, ": error: the renderer draws undistorted images"}}) {
      ExpectRefused(
          ws,
          [&](auto& o, auto& e) {
            RenderCommandOptions s;
            s.model = kBox;
            s.camera = camera;
            if (sequence) {
              s.sequence = "steady";
              s.frames = 2;
              s.output = ws.Path("out/seq");
            } else {
              s.pose = ws.Path("pose.json");
              s.output = ws.Path("out/r.png");
            }
            return RunRender(s, o, e);
          },
          camera + message);
    }
  }
  // render needs a pose or a sequence; a sequence needs a rigid component to move.
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        RenderCommandOptions s;
        s.model = kBox;
        s.camera = ws.Path("camera.json");
        s.output = ws.Path("out/r.png");
        return RunRender(s, o, e);
      },
      kBox + ": error: give --pose (or --sequence NAME)");
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        RenderCommandOptions s;
        s.model = kLamp;
        s.camera = ws.Path("camera.json");
        s.sequence = "steady";
        s.output = ws.Path("out/seq");
        return RunRender(s, o, e);
      },
      kLamp + ": error: the model has no rigid root component");
  // import of a model whose constraints are not joints: at the first one.
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        return RunImport({kLamp, ws.Path("out/m.yaml")}, o, e);
      },
      kLamp + ":45:5: error: cannot write constraint 'c1'");
  // track of a model without edges.
  const std::string edgeless =
      ws.Write("edgeless.yaml", "components:\n  box: {points: {a: [0, 0, 0], b: [1, 0, 0]}}\n");
  const std::string box_pose =
      ws.Write("box_pose.json",
               R"({"components": {"box": {"position": [0, 0, 1], "quaternion": [1, 0, 0, 0]}}})");
  ExpectRefused(
      ws,
      [&](auto& o, auto& e) {
        TrackCommandOptions s;
        s.model = edgeless;
        s.camera = ws.Path("camera.json");
        s.images = ws.Path("frames/*.png");
        s.init = box_pose;
        return RunTrack(s, o, e);
      },
      edgeless + ": error: model 'edgeless' has no edges to track");
}

TEST_CASE("errors: a solve that finds no acceptable answer exits 1, its result written",
          "[cli][errors]") {
  const Workspace ws("status1");
  // Two constraints no geometry meets.
  const std::string model = ws.Write("contradiction.yaml",
                                     "points: {a: [0, 0, 0], b: [1, 0, 0]}\nconstraints:\n"
                                     "  - distance(a, b) == 1 m\n  - distance(a, b) == 2 m\n");
  const std::string measurements =
      ws.Write("m.yaml",
               "points:\n  - {xyz: [0, 0, 0], sigma: 0.001, label: a}\n"
               "  - {xyz: [1, 0, 0], sigma: 0.001, label: b}\n");
  SolveCommandOptions o;
  o.model = model;
  o.measurements = measurements;
  o.output = ws.Path("out/r.json");
  std::ostringstream out, err;
  CHECK(RunSolve(o, out, err) == 1);
  CHECK_THAT(err.str(), StartsWith("cfuse: contradictory constraints or measurements, not "
                                   "fused: ") ||
                            StartsWith("cfuse: the constraints hold only to "));
  CHECK(fs::exists(o.output));
}

// The program itself: what only main() sees (options), and that a refusal is one line on
// stderr even where a library would print its own (libpng, the video back ends).
struct Process {
  int status = -1;
  std::string err;
};

Process RunCfuse(const Workspace& ws, const std::string& arguments) {
  const std::string err_file = ws.Path("stderr.txt");
  const int raw = std::system(
      (std::string("'") + CFUSE_EXE + "' " + arguments + " > /dev/null 2> '" + err_file + "'")
          .c_str());
  Process p;
  p.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : -1;
  std::ifstream in(err_file);
  p.err.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  fs::remove(err_file);
  return p;
}

TEST_CASE("errors: the program exits 2 for unknown options and one-line refusals",
          "[cli][errors]") {
  const Workspace ws("program");
  // Each with its required arguments, so that the unknown option is what CLI11 reports.
  for (const char* command :
       {"check x", "graph x", "plan x", "solve x --measurements m", "interpret x --measurements m",
        "simulate x -o m --truth t", "import x", "fk x", "segments x",
        "project x --camera c --pose p", "render x --camera c -o o",
        "track x --camera c --images i --init p", "demo"}) {
    INFO(command);
    const Process p = RunCfuse(ws, fmt::format("{} --frobnicate", command));
    CHECK(p.status == 2);
    CHECK_THAT(p.err, Catch::Matchers::Contains("--frobnicate"));
  }
  for (const char* arguments : {"", "frobnicate", "check", "solve x.yaml", "fk --joints"}) {
    INFO(arguments);
    CHECK(RunCfuse(ws, arguments).status == 2);
  }
  CHECK(RunCfuse(ws, "solve x.yaml --measurements m.json --method magic").status == 2);
  CHECK(RunCfuse(ws, "render x.yaml --camera c.json -o o.png --frames 0").status == 2);

  // One line, though libpng and OpenCV's video back ends have their own say.
  Process p = RunCfuse(ws, "segments '" + ws.Path("truncated.png") + "'");
  CHECK(p.status == 2);
  CHECK(p.err == ws.Path("truncated.png") +
                     ": error: cannot read the image: not in a format OpenCV reads (PNG, JPEG, "
                     "TIFF, BMP, PNM, ...) or damaged\n");
  p = RunCfuse(ws, fmt::format("track '{}' --camera '{}' --images '{}' --init '{}'", kBox,
                               ws.Path("camera.json"), ws.Path("fake.avi"), ws.Path("pose.json")));
  CHECK(p.status == 2);
  CHECK(p.err ==
        ws.Path("fake.avi") + ": error: cannot open the video (no decoder for it, or damaged)\n");
  // A model named after a file name that is not UTF-8: its JSON summary, not an internal error.
  const std::string latin1 = ws.Path("caf\xE9.yaml");
  fs::copy_file(kLamp, latin1);
  p = RunCfuse(ws, "check --json '" + latin1 + "'");
  CHECK(p.status == 0);
  CHECK(p.err.empty());
}

// ViSP's files (cfuse/importers/visp.h) and the camera's image size, through the program: each bad
// input exits 2 with one located line, and nothing is written.
TEST_CASE("errors: ViSP's files and the camera's size, refused by the program", "[cli][errors]") {
  const Workspace ws("visp");
  const std::string five = ws.Write("five.0.pos", "0.1 0.2 0.3\n0 0\n");
  const std::string seven = ws.Write("seven.pos", "0 0 1 0 0 0 0\n");
  const std::string no_camera =
      ws.Write("settings.xml", "<?xml version=\"1.0\"?>\n<conf>\n  <ecm/>\n</conf>\n");
  const std::string sizeless =
      ws.Write("tracker.xml",
               "<?xml version=\"1.0\"?>\n<conf>\n  <camera>\n    <px>800</px>\n"
               "    <py>800</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"
               "  </camera>\n</conf>\n");
  const std::string assembly = ws.Write("assembly.cao", "V1\nload(\"parts/missing.cao\")\n");
  fs::create_directories(ws.Path("small"));
  cv::imwrite(ws.Path("small/frame_00000.png"), cv::Mat(240, 320, CV_8U, cv::Scalar(60)));
  const std::string box = "'" + kBox + "'";
  auto q = [&](const std::string& relative) { return "'" + ws.Path(relative) + "'"; };
  const std::string six =
      "a ViSP pose is six numbers tx ty tz tux tuy tuz (metres, then the rotation vector in "
      "radians), found ";
  const std::string no_block =
      ":2:1: error: these ViSP tracker settings have no <camera> (<camera> with <px>, <py>, "
      "<u0>, <v0>): ViSP's tracker would take its default camera, cfuse needs the real one";
  const std::string missing_load =
      assembly + ":2:6: error: cannot open '" + ws.Path("parts/missing.cao") + "': no such file";
  const std::string no_size = sizeless +
                              ": error: the camera gives no image size (width and "
                              "height), and ";
  const std::vector<std::pair<std::string, std::string>> cases = {
      // A .pos with the wrong count of numbers, for every command that reads a model's pose.
      {"track " + box + " --camera " + q("camera.json") + " --images " + q("frames/*.png") +
           " --init " + q("five.0.pos") + " -o " + q("out/t.csv") + " --overlay " + q("out/ov"),
       five + ":2:4: error: " + six + "5"},
      {"project " + box + " --camera " + q("camera.json") + " --pose " + q("seven.pos") + " -o " +
           q("out/e.json"),
       seven + ":1:13: error: " + six + "7"},
      {"render " + box + " --camera " + q("camera.json") + " --pose " + q("five.0.pos") + " -o " +
           q("out/r.png"),
       five + ":2:4: error: " + six + "5"},
      // An XML without a camera block.
      {"project " + box + " --camera " + q("settings.xml") + " --pose " + q("pose.json") +
           " --image " + q("image.png") + " -o " + q("out/e.json"),
       no_camera + no_block},
      {"track " + box + " --camera " + q("settings.xml") + " --images " + q("frames/*.png") +
           " --init " + q("pose.json") + " -o " + q("out/t.csv"),
       no_camera + no_block},
      // A CAO load() of a missing file: at the load's file name.
      {"check " + q("assembly.cao"), missing_load},
      {"track " + q("assembly.cao") + " --camera " + q("camera.json") + " --images " +
           q("frames/*.png") + " --init " + q("five.0.pos") + " -o " + q("out/t.csv"),
       missing_load},
      // Frames of another size than the camera's.
      {"track " + box + " --camera " + q("camera.json") + " --images " + q("small/*.png") +
           " --init " + q("pose.json") + " -o " + q("out/t.csv") + " --overlay " + q("out/ov"),
       ws.Path("small/frame_00000.png") + ": error: the image is 320 x 240, the camera's (" +
           ws.Path("camera.json") + ") 640 x 480"},
      // A camera without a size, where nothing gives one.
      {"render " + box + " --camera " + q("tracker.xml") + " --pose " + q("pose.json") + " -o " +
           q("out/r.png"),
       no_size + "render draws images of the camera's size: give a camera file with one"},
      {"render " + box + " --camera " + q("tracker.xml") + " --sequence steady --frames 2 -o " +
           q("out/seq"),
       no_size + "render draws images of the camera's size: give a camera file with one"},
      {"simulate " + box + " --camera " + q("tracker.xml") + " -o " + q("out/m.json") +
           " --truth " + q("out/t.json"),
       no_size + "simulate places the model and the clutter inside the image: give a camera file "
                 "with one"},
      {"project " + box + " --camera " + q("tracker.xml") + " --pose " + q("pose.json") + " -o " +
           q("out/e.json"),
       sizeless + ": error: the camera gives no image size (width and height) to clip the edges "
                  "to: give --image, whose size it then takes"},
  };
  for (const auto& [arguments, line] : cases) {
    INFO(arguments);
    const std::set<std::string> before = ws.Listing();
    const Process p = RunCfuse(ws, arguments);
    CHECK(p.status == 2);
    CHECK(p.err == line + "\n");
    CHECK(ws.Listing() == before);
  }
}

}  // namespace
}  // namespace cfuse::cli
