// Photographs for the realistic renderer (cfuse/vision/texture.h): read from files and
// directories or refused at the file, the procedural cards, a face's own frame, and how each
// face is printed: a crop inside its photograph, turned by quarter turns, drawn from the seed
// per face, its grey levels scaled to the asked contrast.
#include "cfuse/vision/texture.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/kernel/check.h"
#include "cfuse/kernel/error.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

// A 256 x 256 photograph whose grey level is its column.
GrayImage Ramp() {
  GrayImage image;
  image.width = image.height = 256;
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) image.pixels.push_back(static_cast<std::uint8_t>(x));
  return image;
}

Component Square(std::vector<int> loop) {
  Component c;
  c.rigid = true;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.1, 0.1, 0.2), Eigen::Vector3d(0.1, 0.3, 0.2),
        Eigen::Vector3d(0.4, 0.3, 0.2), Eigen::Vector3d(0.4, 0.1, 0.2)}) {
    c.points.push_back({"", p, {}});
  }
  c.faces.push_back({"face", std::move(loop), {}});
  return c;
}

TEST_CASE("photographs: read from files and directories, refused at the file", "[vision][render]") {
  const fs::path dir = fs::temp_directory_path() / "cfuse_render_photographs_test";
  fs::remove_all(dir);
  fs::create_directories(dir / "none");
  fs::create_directories(dir / "bad");
  cv::Mat colour(40, 60, CV_8UC3, cv::Scalar(10, 200, 30));
  cv::imwrite((dir / "b.png").string(), colour);
  cv::imwrite((dir / "a.pgm").string(), cv::Mat(50, 70, CV_8U, cv::Scalar(77)));
  cv::imwrite((dir / "tiny.png").string(), cv::Mat(8, 8, CV_8U, cv::Scalar(1)));
  std::ofstream(dir / "notes.txt") << "not an image";
  std::ofstream(dir / "none" / "notes.txt") << "no images here";
  std::ofstream(dir / "bad" / "broken.png") << "not a png";

  const std::vector<GrayImage> one = LoadPhotographs({(dir / "b.png").string()});
  REQUIRE(one.size() == 1);
  CHECK(one[0].width == 60);
  CHECK(one[0].height == 40);
  CHECK(one[0].pixels.size() == 2400u);
  fs::remove(dir / "tiny.png");
  const std::vector<GrayImage> all = LoadPhotographs({dir.string()});
  REQUIRE(all.size() == 2);  // a.pgm, b.png by name; notes.txt skipped, folders not entered
  CHECK(all[0].pixels[0] == 77);

  auto refused = [](const std::string& path, const std::string& message) {
    INFO(path);
    try {
      LoadPhotographs({path});
      FAIL("accepted");
    } catch (const InputError& e) {
      CHECK(e.where().file == path);
      CHECK_THAT(e.message(), Catch::Matchers::Contains(message));
    }
  };
  refused((dir / "missing.png").string(), "no such file");
  refused((dir / "bad" / "broken.png").string(), "cannot read the image");
  refused((dir / "none").string(), "holds no images");
  cv::imwrite((dir / "tiny.png").string(), cv::Mat(8, 8, CV_8U, cv::Scalar(1)));
  refused((dir / "tiny.png").string(), "at least 32 x 32");
  fs::remove_all(dir);

  CHECK(VispPhotographPaths((dir / "nowhere").string()).empty());
  const std::vector<std::string> visp = VispPhotographPaths();
  if (visp.empty()) {
    WARN("visp-images-data is not installed: its photographs are not checked");
  } else {
    CHECK(visp.size() == 8);
    CHECK(LoadPhotographs({visp.front()}).front().width > 500);
  }
}

TEST_CASE("texture: procedural cards are a function of their seed", "[vision][render]") {
  const std::vector<GrayImage> a = ProceduralPhotographs(3, 2), b = ProceduralPhotographs(3, 2);
  const std::vector<GrayImage> c = ProceduralPhotographs(4, 2);
  REQUIRE(a.size() == 2);
  CHECK(a[0].width == 512);
  CHECK(a[0].height == 512);
  CHECK(a[0].pixels.size() == 512u * 512u);
  CHECK(a[0].pixels == b[0].pixels);
  CHECK(a[1].pixels == b[1].pixels);
  CHECK(a[0].pixels != a[1].pixels);
  CHECK(a[0].pixels != c[0].pixels);
  CHECK(ProceduralPhotographs(3, 0).empty());
}

TEST_CASE("texture: a face's frame, by its first corner and side and the right-hand rule",
          "[vision][render]") {
  // Corners 0 -> 1 along +y, then +x: seen from +z the loop turns clockwise, its normal -z.
  const FacePlane plane = FaceFrame(Square({0, 1, 2, 3}), 0);
  REQUIRE(plane.valid);
  CHECK((plane.origin - Eigen::Vector3d(0.1, 0.1, 0.2)).norm() < 1e-15);
  CHECK((plane.s - Eigen::Vector3d::UnitY()).norm() < 1e-12);
  CHECK((plane.normal + Eigen::Vector3d::UnitZ()).norm() < 1e-12);
  CHECK((plane.t - Eigen::Vector3d::UnitX()).norm() < 1e-12);
  // The loop reversed: the other side.
  const FacePlane back = FaceFrame(Square({3, 2, 1, 0}), 0);
  CHECK((back.origin - Eigen::Vector3d(0.4, 0.1, 0.2)).norm() < 1e-15);
  CHECK((back.normal - Eigen::Vector3d::UnitZ()).norm() < 1e-12);
  CHECK((back.s - Eigen::Vector3d::UnitY()).norm() < 1e-12);
  CHECK((back.t + Eigen::Vector3d::UnitX()).norm() < 1e-12);
  // Fewer than three corners, or on one line: no frame.
  CHECK_FALSE(FaceFrame(Square({0, 1}), 0).valid);
  Component line = Square({0, 1, 2});
  line.points[2].position = Eigen::Vector3d(0.1, 0.5, 0.2);
  CHECK_FALSE(FaceFrame(line, 0).valid);
}

TEST_CASE("texture: each face printed with a crop inside its photograph, from the seed",
          "[vision][render]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const std::vector<GrayImage> ramp = {Ramp()};
  const std::vector<FaceTexture> t = FaceTextures(g, ramp, 7, 0.16);
  REQUIRE(t.size() == 12);
  int printed = 0;
  for (const FaceTexture& f : t) {
    CAPTURE(f.component, f.face);
    const Component& c = g.components[f.component];
    const FacePlane plane = FaceFrame(c, f.face);
    CHECK(f.base >= 0.35);
    CHECK(f.base <= 0.8);
    // A scale times a quarter turn, 500-1100 photograph pixels per metre or as many as fit.
    const Eigen::Matrix2d linear = f.photo_from_face.leftCols<2>();
    const double scale = std::abs(linear.determinant()) > 0 ? std::sqrt(linear.determinant()) : 0;
    CHECK(scale <= 1100);
    CHECK((linear / scale).cwiseAbs().sum() == Approx(2));  // one ±1 per row and column
    Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
    for (int k : c.faces[f.face].loop) {
      const Eigen::Vector3d d = c.points[k].position - plane.origin;
      const Eigen::Vector2d st(d.dot(plane.s), d.dot(plane.t));
      lo = lo.cwiseMin(st);
      hi = hi.cwiseMax(st);
      const Eigen::Vector2d q = f.photo_from_face * st.homogeneous();
      CHECK(q.minCoeff() >= 1 - 1e-9);
      CHECK(q.maxCoeff() <= 254 + 1e-9);
    }
    // The ramp's grey level is its column, x = a s + b t + c: over the 16 x 16 grid of the
    // face's extent the crop's mean is the column of its middle, and its spread
    // sqrt(a² ws² + b² wt²) sqrt(255 / 3072); the gain scales it to the asked 0.16, unless it
    // is under 2 grey levels (a rim 10 mm across), which leaves the face plain.
    const Eigen::Vector2d middle = f.photo_from_face * (0.5 * (lo + hi)).homogeneous();
    CHECK(f.mean == Approx(middle.x()).epsilon(1e-9));
    const Eigen::Vector2d w = hi - lo;
    const double spread =
        std::hypot(linear(0, 0) * w.x(), linear(0, 1) * w.y()) * std::sqrt(255.0 / 3072);
    if (spread >= 2) {
      CHECK(f.photograph == 0);
      CHECK(f.gain * spread == Approx(0.16).epsilon(1e-6));
      ++printed;
    } else {
      CHECK(f.photograph == -1);
      CHECK(f.gain == 0);
    }
  }
  CHECK(printed >= 6);
  // The same seed, the same print; each face draws alone, whatever else the model holds.
  const std::vector<FaceTexture> again = FaceTextures(g, ramp, 7, 0.16);
  CHECK(again[5].photo_from_face == t[5].photo_from_face);
  ConstraintGraph box_only = g;
  box_only.components.pop_back();
  const std::vector<FaceTexture> box = FaceTextures(box_only, ramp, 7, 0.16);
  REQUIRE(box.size() == 6);
  CHECK(box[3].photo_from_face == t[3].photo_from_face);
  CHECK(FaceTextures(g, ramp, 8, 0.16)[3].photo_from_face != t[3].photo_from_face);
}

TEST_CASE("texture: plain faces without contrast, photographs or print; photographs checked",
          "[vision][render]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  GrayImage flat;
  flat.width = flat.height = 64;
  flat.pixels.assign(64 * 64, 100);
  for (const auto& t : {FaceTextures(g, {Ramp()}, 1, 0), FaceTextures(g, {}, 1, 0.16),
                        FaceTextures(g, {flat}, 1, 0.16)}) {
    REQUIRE(t.size() == 12);
    for (const FaceTexture& f : t) {
      CHECK(f.photograph == -1);
      CHECK(f.gain == 0);
    }
  }
  // The base albedo is the face's own draw, printed or not.
  CHECK(FaceTextures(g, {}, 1, 0)[4].base == FaceTextures(g, {Ramp()}, 1, 0.16)[4].base);
  GrayImage tiny = flat;
  tiny.width = tiny.height = 16;
  tiny.pixels.resize(16 * 16);
  CHECK_THROWS_AS(FaceTextures(g, {tiny}, 1, 0.16), InternalError);
  GrayImage hollow = flat;
  hollow.pixels.pop_back();
  CHECK_THROWS_AS(FaceTextures(g, {hollow}, 1, 0.16), InternalError);
}

}  // namespace
}  // namespace cfuse
