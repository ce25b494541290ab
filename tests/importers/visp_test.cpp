// ViSP's files as ViSP writes them (cfuse/importers/visp.h): the cameras of its data sets' tracker
// settings and of vpXmlParserCamera's files, projecting as ViSP's own model does; its `.pos`
// poses turned by the exponential map; an assembly of CAO parts placed as ViSP's own test places
// them; and every malformed file refused at its line and column. The data sets come with the
// visp-images-data package (scripts/install-deps.sh); without it those cases are skipped, saying
// so.
#include "cfuse/importers/visp.h"

#include <fmt/format.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "cfuse/importers/cao.h"
#include "test_util.h"

namespace cfuse {
namespace {

namespace fs = std::filesystem;

const std::string kVisp = "/usr/share/visp-images-data/ViSP-images";

// The data set's file, or "" (with a warning) when the package is not installed.
std::string VispData(const std::string& relative) {
  const std::string path = kVisp + "/" + relative;
  if (!fs::exists(path)) {
    WARN("skipped: " << path << " is missing (install visp-images-data: scripts/install-deps.sh)");
    return "";
  }
  return path;
}

struct TempDir {
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / fmt::format("cfuse_visp_test_{}_{}", ::getpid(), name)) {
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream((path / name).string(), std::ios::binary) << text;
    return (path / name).string();
  }
  fs::path path;
};

TEST_CASE("visp: the data sets' tracker settings give their cameras, without a size",
          "[importers][visp]") {
  struct Expected {
    const char* file;
    double px, py, u0, v0;
  };
  // The values of each file's <camera> (mbt/cube.xml lists u0 and v0 first).
  const Expected files[] = {{"mbt-depth/Castle-simu/Config/chateau.xml", 700, 700, 320, 240},
                            {"mbt-depth/castel/chateau.xml", 615.1674804688, 615.1675415039,
                             312.1889953613, 243.4373779297},
                            {"mbt-depth/castel/chateau_depth.xml", 476.0536193848, 476.0534973145,
                             311.4845581055, 246.2832336426},
                            {"mbt/cube.xml", 547.7367575, 542.0744058, 338.7036994, 234.5083345}};
  for (const Expected& e : files) {
    const std::string path = VispData(e.file);
    if (path.empty()) continue;
    INFO(path);
    CHECK(IsVispCameraFile(path));
    const Camera camera = ReadVispCamera(path);
    CHECK(camera.model == Camera::Model::kPinhole);
    CHECK(camera.fx == e.px);
    CHECK(camera.fy == e.py);
    CHECK(camera.cx == e.u0);
    CHECK(camera.cy == e.v0);
    CHECK(camera.width == 0);  // tracker settings give no size
    CHECK(camera.height == 0);
    for (double d : camera.distortion) CHECK(d == 0);
  }
  // Other files are not ViSP's cameras.
  for (const char* other :
       {"tests/data/cameras/opencv_calibration.xml", "tests/data/cameras/opencv_calibration.yml",
        "tests/data/urdf/arm.urdf", "tests/data/cao/cube.cao"}) {
    INFO(other);
    CHECK_FALSE(IsVispCameraFile(testing::SourcePath(other)));
  }
  CHECK_FALSE(IsVispCameraFile("/nonexistent/camera.xml"));
}

// vpXmlParserCamera's example file (its header's documentation): one camera, both models.
std::string ParserFile(const std::string& camera_body) {
  return "<?xml version=\"1.0\"?>\n<root>\n  <camera>\n" + camera_body + "  </camera>\n</root>\n";
}
const std::string kName = "    <name>myCamera</name>\n";
const std::string kSize =
    "    <image_width>640</image_width>\n    <image_height>480</image_height>\n";
const std::string kWithout =
    "    <model>\n      <type>perspectiveProjWithoutDistortion</type>\n      <px>1129.0</px>\n"
    "      <py>1130.6</py>\n      <u0>317.9</u0>\n      <v0>229.1</v0>\n    </model>\n";
const std::string kWith =
    "    <model>\n      <type>perspectiveProjWithDistortion</type>\n      <px>1089.9</px>\n"
    "      <py>1090.1</py>\n      <u0>326.1</u0>\n      <v0>230.5</v0>\n"
    "      <kud>-0.196</kud>\n      <kdu>0.204</kdu>\n    </model>\n";

// ViSP's projection (vpCameraParameters, vpMeterPixelConversion) written out:
// u = u0 + px x (1 + kud r²), v = v0 + py y (1 + kud r²).
Eigen::Vector2d VispProject(double px, double py, double u0, double v0, double kud,
                            const Eigen::Vector3d& p) {
  const double x = p.x() / p.z(), y = p.y() / p.z(), r2 = x * x + y * y;
  return {u0 + px * x * (1 + kud * r2), v0 + py * y * (1 + kud * r2)};
}

double WorstDifference(const Camera& camera, double px, double py, double u0, double v0,
                       double kud) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> depth(0.3, 4), slope(-0.4, 0.4);
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    const double z = depth(rng);
    const Eigen::Vector3d p(slope(rng) * z, slope(rng) * z, z);
    worst = std::max(worst, (camera.Project(p) - VispProject(px, py, u0, v0, kud, p)).norm());
  }
  return worst;
}

TEST_CASE("visp: vpXmlParserCamera's files, the distortion model taken when both are given",
          "[importers][visp]") {
  // Both models: the one with distortion, which describes the raw images.
  Camera camera = ReadVispCameraFromString(ParserFile(kName + kSize + kWithout + kWith), "c.xml");
  CHECK(camera.width == 640);
  CHECK(camera.height == 480);
  CHECK(camera.fx == 1089.9);
  CHECK(camera.distortion[0] == -0.196);
  CHECK(WorstDifference(camera, 1089.9, 1090.1, 326.1, 230.5, -0.196) < 1e-9);
  // The same in the other order.
  camera = ReadVispCameraFromString(ParserFile(kName + kSize + kWith + kWithout), "c.xml");
  CHECK(camera.fx == 1089.9);
  // Without distortion only.
  camera = ReadVispCameraFromString(ParserFile(kName + kSize + kWithout), "c.xml");
  CHECK(camera.fx == 1129.0);
  CHECK(camera.fy == 1130.6);
  CHECK(camera.cx == 317.9);
  CHECK(camera.cy == 229.1);
  for (double d : camera.distortion) CHECK(d == 0);
  CHECK(WorstDifference(camera, 1129.0, 1130.6, 317.9, 229.1, 0) < 1e-9);
  // kdu is not needed: a file without it is read. No size, or 0 x 0: unknown.
  std::string no_kdu = kWith;
  no_kdu.erase(no_kdu.find("      <kdu>"), std::string("      <kdu>0.204</kdu>\n").size());
  camera = ReadVispCameraFromString(ParserFile(kName + no_kdu), "c.xml");
  CHECK(camera.distortion[0] == -0.196);
  CHECK(camera.width == 0);
  camera = ReadVispCameraFromString(
      ParserFile("    <image_width>0</image_width>\n    <image_height>0</image_height>\n" +
                 kWithout),
      "c.xml");
  CHECK(camera.width == 0);
  CHECK(camera.height == 0);
  // ViSP's notes are ignored; comments and white space anywhere.
  camera = ReadVispCameraFromString(
      ParserFile("    <!-- calibrated on 14 May -->\n" + kName + kSize +
                 "    <subsampling_width>1</subsampling_width>\n"
                 "    <additional_information>grid 9x6</additional_information>\n" +
                 kWithout),
      "c.xml");
  CHECK(camera.fx == 1129.0);
  // A file on disk, with its sniff.
  const TempDir dir("parser");
  const std::string path = dir.Write("camera.xml", ParserFile(kName + kSize + kWith));
  CHECK(IsVispCameraFile(path));
  CHECK(ReadVispCamera(path).fx == 1089.9);
}

TEST_CASE("visp: every malformed camera file is refused at its line and column",
          "[importers][visp]") {
  const std::string conf_head = "<?xml version=\"1.0\"?>\n<conf>\n  <camera>\n";
  const std::string conf_tail = "  </camera>\n</conf>\n";
  auto conf = [&](const std::string& body) { return conf_head + body + conf_tail; };
  const std::string good =
      "    <px>700</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n";
  std::string deep = "<?xml version=\"1.0\"?>\n";
  for (int i = 0; i < 300; ++i) deep += "<conf>";
  // Two cameras, the second starting on line 15.
  std::string two_cameras = ParserFile(kName + kSize + kWithout);
  two_cameras.insert(two_cameras.find("</root>"),
                     "  <camera>\n    <name>wide</name>\n"
                     "    <image_width>320</image_width>\n    <image_height>240</image_height>\n" +
                         kWithout + "  </camera>\n");
  const std::string texts[] = {
      // Tracker settings.
      "<?xml version=\"1.0\"?>\n<conf>\n  <ecm><range><tracking>8</tracking></range></ecm>\n"
      "</conf>\n",
      conf("    <px>abc</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px>-700</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px>0</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px></px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px>nan</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px>700</px>\n    <py>1e999</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf("    <px>700 px</px>\n    <py>700</py>\n    <u0>320</u0>\n    <v0>240</v0>\n"),
      conf(good + "    <kud>0.1</kud>\n"),
      conf(good + "    <px>710</px>\n"),
      conf("    <px><value>700</value></px>\n    <py>700</py>\n    <u0>320</u0>\n"
           "    <v0>240</v0>\n"),
      conf_head + good + conf_tail.substr(0, 12) + "  <camera>\n" + good + conf_tail,
      // Not well formed, or not a camera file at all.
      conf("    <px>700</py>\n"),
      conf_head + "    <px>700",
      "",
      "<?xml version=\"1.0\"?>\n<calibration><px>700</px></calibration>\n",
      std::string("<conf>\0</conf>", 14),
      deep,
      // vpXmlParserCamera's files.
      "<?xml version=\"1.0\"?>\n<root>\n</root>\n",
      "<?xml version=\"1.0\"?>\n<root>\n  <cameras/>\n</root>\n",
      two_cameras,
      ParserFile(kName + kSize),
      ParserFile(kName + kSize +
                 "    <model>\n      <type>ProjWithKannalaBrandtDistortion</type>\n"
                 "    </model>\n"),
      ParserFile(kName + kSize + kWith + kWith),
      ParserFile(kName + kSize +
                 "    <model>\n      <type>perspectiveProjWithoutDistortion</type>\n"
                 "      <px>1129.0</px>\n      <py>1130.6</py>\n      <u0>317.9</u0>\n"
                 "      <v0>229.1</v0>\n      <kud>-0.2</kud>\n    </model>\n"),
      ParserFile(kName + kSize +
                 "    <model>\n      <type>perspectiveProjWithDistortion</type>\n"
                 "      <px>1129.0</px>\n      <py>1130.6</py>\n      <u0>317.9</u0>\n"
                 "      <v0>229.1</v0>\n    </model>\n"),
      ParserFile(kName + "    <image_width>640</image_width>\n" + kWithout),
      ParserFile(kName +
                 "    <image_width>640.5</image_width>\n"
                 "    <image_height>480</image_height>\n" +
                 kWithout),
      ParserFile(kName +
                 "    <image_width>640</image_width>\n"
                 "    <image_height>0</image_height>\n" +
                 kWithout),
      ParserFile(kName + kSize +
                 "    <model>\n      <type>perspectiveProjWithoutDistortion</type>\n"
                 "      <px>1129.0</px>\n      <py>1130.6</py>\n      <u0>5000</u0>\n"
                 "      <v0>229.1</v0>\n    </model>\n"),
      ParserFile(kName + kSize + "    <focal>1129</focal>\n" + kWithout),
      ParserFile(kName + kSize +
                 "    <model>\n      <type>perspectiveProjWithoutDistortion</type>\n"
                 "      <fx>1129.0</fx>\n    </model>\n"),
  };
  const testing::BadCase cases[] = {
      {texts[0].c_str(), 2, 1, "these ViSP tracker settings have no <camera>"},
      {texts[1].c_str(), 4, 5, "<px> must be a number, found 'abc'"},
      {texts[2].c_str(), 3, 3, "<camera> needs <px>"},
      {texts[3].c_str(), 4, 5, "<px>: fx = K[0][0] must be positive, got -700"},
      {texts[4].c_str(), 4, 5, "<px>: fx = K[0][0] must be positive, got 0"},
      {texts[5].c_str(), 4, 5, "<px> is empty: it holds a number"},
      {texts[6].c_str(), 4, 5, "<px> must be finite, found 'nan'"},
      {texts[7].c_str(), 5, 5, "<py> must be finite, found '1e999'"},
      {texts[8].c_str(), 4, 5, "<px> must be a number, found '700 px'"},
      {texts[9].c_str(), 8, 5,
       "unknown element <kud> in the tracker settings' <camera>: it holds <px>, <py>, <u0>, "
       "<v0>"},
      {texts[10].c_str(), 8, 5, "<px> given twice in <camera> (first at line 4)"},
      {texts[11].c_str(), 4, 9, "<px> holds an element <value>: it holds a value"},
      {texts[12].c_str(), 9, 3,
       "a second <camera> in the tracker settings (the first at line 3): which one is meant?"},
      {texts[13].c_str(), 4, 12, "not well-formed XML: Error reading end tag"},
      {texts[14].c_str(), 4, 12, "not well-formed XML: the file ends inside an element left open"},
      {texts[15].c_str(), 1, 1, "not well-formed XML: Error document empty"},
      {texts[16].c_str(), 2, 1,
       "not a camera file cfuse reads: the root element is <calibration>; ViSP's tracker "
       "settings have <conf>, vpXmlParserCamera's files <root> (and OpenCV's calibration files "
       "<opencv_storage>)"},
      {texts[18].c_str(), 2, 1537, "elements nested more than 256 deep"},
      {texts[19].c_str(), 2, 1, "this vpXmlParserCamera file has no <camera>"},
      {texts[20].c_str(), 3, 3,
       "unknown element <cameras> in vpXmlParserCamera's <root>: it holds <camera>"},
      {texts[21].c_str(), 15, 3,
       "the file has 2 cameras: 'myCamera' 640 x 480 (line 3), 'wide' 320 x 240 (line 15); cfuse "
       "reads a file with one camera"},
      {texts[22].c_str(), 3, 3,
       "<camera> has no <model> (<type>perspectiveProjWithoutDistortion</type> or "
       "<type>perspectiveProjWithDistortion</type> with <px>, <py>, <u0>, <v0>)"},
      {texts[23].c_str(), 8, 7,
       "unknown camera model 'ProjWithKannalaBrandtDistortion': ViSP's pinhole models are "
       "perspectiveProjWithoutDistortion and perspectiveProjWithDistortion (Kannala-Brandt is a "
       "fisheye model, which cfuse's camera does not have)"},
      {texts[24].c_str(), 16, 5,
       "a second perspectiveProjWithDistortion <model> in the camera (the first at line 7)"},
      {texts[25].c_str(), 13, 7,
       "<kud> in a perspectiveProjWithoutDistortion model: its distortion would not be applied"},
      {texts[26].c_str(), 7, 5, "the perspectiveProjWithDistortion <model> needs <kud>"},
      {texts[27].c_str(), 3, 3, "<camera> has <image_width> but no <image_height>"},
      {texts[28].c_str(), 5, 5,
       "<image_width> must be a whole number of pixels from 1 to 10^6 (or 0 for an unknown "
       "size), found '640.5'"},
      {texts[29].c_str(), 6, 5, "the image is 640 x 0: a side of 0 (unknown) needs the other 0"},
      {texts[30].c_str(), 11, 7, "<u0>: the principal point cx = 5000 is outside [-640, 1280]"},
      {texts[31].c_str(), 7, 5,
       "unknown element <focal> in vpXmlParserCamera's <camera>: it holds <name>, "
       "<image_width>, <image_height>, <subsampling_width>, <subsampling_height>, <full_width>, "
       "<full_height>, <model>, <additional_information>"},
      {texts[32].c_str(), 9, 7,
       "unknown element <fx> in <model>: it holds <type>, <px>, <py>, <u0>, <v0>, <kud>, "
       "<kdu>"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* name) { return ReadVispCameraFromString(text, name); });
  // The NUL case (texts[17]), whose text a C string would cut short.
  CHECK_THROWS_WITH(ReadVispCameraFromString(texts[17], "bad.json"),
                    "bad.json: error: is a binary file, not a ViSP camera file (NUL byte at "
                    "offset 6)");
  // Files that cannot be read.
  const TempDir dir("unreadable");
  const std::string missing = (dir.path / "missing.xml").string();
  CHECK_THROWS_WITH(ReadVispCamera(missing), missing + ": error: cannot open: no such file");
  CHECK_THROWS_WITH(ReadVispCamera(dir.path.string()),
                    dir.path.string() + ": error: is a directory, not a ViSP camera file");
}

TEST_CASE("visp: .pos poses, the rotation by the exponential map", "[importers][visp]") {
  // A quarter turn about z and a translation, one number a line as ViSP writes them.
  Rigid3d pose = ReadVispPoseFromString("0.1\n-0.2\n0.5\n0\n0\n1.5707963267948966\n", "q.pos");
  CHECK((pose.translation - Eigen::Vector3d(0.1, -0.2, 0.5)).norm() < 1e-15);
  CHECK((pose * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(0.1, 0.8, 0.5)).norm() < 1e-12);
  // On one line, tabs and CRLF, a trailing space and no final newline (mbt/cube.0.pos has those).
  pose = ReadVispPoseFromString("0 0 0\t3.141592653589793 0 0 \r\n", "q.pos");
  CHECK((pose * Eigen::Vector3d(0, 1, 0) - Eigen::Vector3d(0, -1, 0)).norm() < 1e-12);
  // A whole turn, the most a rotation vector may have, is the identity.
  pose = ReadVispPoseFromString("0 0 0 0 0 6.283185307179586", "q.pos");
  CHECK(pose.RotationMatrix().isApprox(Eigen::Matrix3d::Identity(), 1e-12));

  for (const auto& [file, values] :
       {std::pair<const char*, std::array<double, 6>>{"mbt-depth/castel/chateau.0.pos",
                                                      {0.06988440346, 0.09132817024, 0.3345575353,
                                                       -2.684014069, 0.1235874193, -0.5943761092}},
        {"mbt/cube.0.pos",
         {0.02231950571, 0.1071368004, 0.5071128378, 2.100485509, 1.146812236, -0.4560126437}}}) {
    const std::string path = VispData(file);
    if (path.empty()) continue;
    INFO(path);
    pose = ReadVispPose(path);
    CHECK(pose.translation == Eigen::Vector3d(values[0], values[1], values[2]));
    // Exp(θu) against Eigen's angle-axis rotation, computed independently.
    const Eigen::Vector3d theta_u(values[3], values[4], values[5]);
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(theta_u.norm(), theta_u.normalized()).toRotationMatrix();
    CHECK((pose.RotationMatrix() - R).norm() < 1e-12);
  }
}

TEST_CASE("visp: every malformed .pos is refused at its line and column", "[importers][visp]") {
  const testing::BadCase cases[] = {
      {"", 1, 1, "the file is empty: a ViSP pose is six numbers tx ty tz tux tuy tuz"},
      {"  \n\n ", 1, 1, "the file is empty"},
      {"0.1 0.2 0.3\n0 0\n", 2, 4,
       "a ViSP pose is six numbers tx ty tz tux tuy tuz (metres, then the rotation vector in "
       "radians), found 5"},
      {"1\n2\n3\n4\n5\n6\n7\n", 7, 1, "a ViSP pose is six numbers tx ty tz tux tuy tuz"},
      {"1 2 3 4 5 6 7 8 9", 1, 13,
       "a ViSP pose is six numbers tx ty tz tux tuy tuz (metres, then "
       "the rotation vector in radians), found 9"},
      {"1 2 x 4 5 6", 1, 5, "expected a number, found 'x'"},
      {"1 2 3 4 5 6,", 1, 11, "expected a number, found '6,'"},
      {"# cMo\n1 2 3 4 5 6", 1, 1, "expected a number, found '#'"},
      {"0x10 0 0 0 0 0", 1, 1, "expected a number, found '0x10'"},
      {"1 2 3 nan 5 6", 1, 7, "'nan' is not a finite number"},
      {"1 2 3 4 -inf 6", 1, 9, "'-inf' is not a finite number"},
      {"1 2 1e999 4 5 6", 1, 5, "'1e999' is not a finite number"},
      {"1 2 3 4 5 1.5.2", 1, 11, "expected a number, found '1.5.2'"},
      // Beyond 2π: degrees written for radians, or a norm that overflows (fuzz/poses_fuzz.cpp).
      {"0 0 1\n0 0 90\n", 2, 1,
       "the rotation vector θu = (0, 0, 90) turns by 90 rad, more than 2π: θu is in radians"},
      {"0 1215 0.0 1e308 062 -0.381", 1, 12,
       "the rotation vector θu = (1e+308, 62, -0.381) turns "
       "by inf rad, more than 2π"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* name) { return ReadVispPoseFromString(text, name); });
  CHECK_THROWS_WITH(ReadVispPoseFromString(std::string("1 2 3\0 4 5 6", 12), "p.pos"),
                    "p.pos: error: is a binary file, not a ViSP pose file (NUL byte at offset 5)");
  const TempDir dir("poses");
  const std::string missing = (dir.path / "missing.pos").string();
  CHECK_THROWS_WITH(ReadVispPose(missing), missing + ": error: cannot open: no such file");
  CHECK_THROWS_WITH(ReadVispPose(dir.path.string()),
                    dir.path.string() + ": error: is a directory, not a ViSP pose file");
}

TEST_CASE("visp: homogeneous matrices, the pose read as written", "[importers][visp]") {
  // A quarter turn about z and a translation, four rows of four.
  const Rigid3d pose =
      ReadVispMatrixPoseFromString("0 -1 0 0.1\n1 0 0 -0.2\n0 0 1 0.5\n0 0 0 1\n", "m.txt");
  CHECK((pose.translation - Eigen::Vector3d(0.1, -0.2, 0.5)).norm() < 1e-15);
  CHECK((pose * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(0.1, 0.8, 0.5)).norm() < 1e-12);
  const std::string path = VispData("mbt-depth/castel/depth_M_color.txt");
  if (path.empty()) return;
  const Rigid3d depth_from_color = ReadVispMatrixPose(path);
  CHECK((depth_from_color.translation -
         Eigen::Vector3d(-0.02470519207, 0.0006583171198, -0.003773850389))
            .norm() < 1e-12);
  CHECK(depth_from_color.RotationMatrix()(0, 1) == Approx(-0.003901827615).margin(1e-8));
}

TEST_CASE("visp: every malformed matrix is refused at its line and column", "[importers][visp]") {
  const testing::BadCase cases[] = {
      {"", 1, 1, "the file is empty: a ViSP homogeneous matrix is sixteen numbers"},
      {"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0\n", 4, 6,
       "a ViSP homogeneous matrix is sixteen numbers, four rows of four: the rotation and the "
       "translation (metres), then 0 0 0 1, found 15 numbers"},
      {"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1 7\n", 4, 9,
       "a ViSP homogeneous matrix is sixteen numbers, four rows of four: the rotation and the "
       "translation (metres), then 0 0 0 1, found 17 numbers"},
      {"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 x 1\n", 4, 5, "expected a number, found 'x'"},
      {"1 0 0 0\n0 1 0 0\n0 0 1 nan\n0 0 0 1\n", 3, 7, "'nan' is not a finite number"},
      {"1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n", 4, 1, "the last row is 0 0 1 1"},
      {"2 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", 1, 1,
       "the upper-left 3 x 3 block is no rotation (RᵀR departs from the identity by 3"},
      {"-1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", 1, 1,
       "the upper-left 3 x 3 block is no rotation (RᵀR departs from the identity by 0, det R = "
       "-1)"},
  };
  testing::ExpectRefused(
      std::begin(cases), std::end(cases),
      [](const char* text, const char* name) { return ReadVispMatrixPoseFromString(text, name); });
  const TempDir dir("matrices");
  const std::string missing = (dir.path / "missing.txt").string();
  CHECK_THROWS_WITH(ReadVispMatrixPose(missing), missing + ": error: cannot open: no such file");
}

// ViSP's testGenericTracker.cpp (modules/tracker/mbt/test) tracks Castle-simu's chateau with a
// cube added: tracker.loadModel("Models/cube.cao", false, T) with
//   T = [-1 0 0 -0.2; 0 0 1 0.12; 0 1 0 -0.15; 0 0 0 1],
// T mapping the cube's points into the chateau's frame. In cfuse the same assembly is one CAO
// file of loads: T's rotation is a half turn about (0, 1, 1)/√2, θu = π (0, 1, 1)/√2.
TEST_CASE("visp: Castle-simu's chateau and cube assembled as ViSP's own test does",
          "[importers][visp][cao]") {
  const std::string chateau = VispData("mbt-depth/Castle-simu/Models/chateau.cao");
  const std::string cube = VispData("mbt-depth/Castle-simu/Models/cube.cao");
  if (chateau.empty() || cube.empty()) return;
  const TempDir dir("assembly");
  const double half = M_PI / std::sqrt(2.0);
  const std::string path =
      dir.Write("castle.cao", fmt::format("V1\nload(\"{}\")\nload(\"{}\", t=[-0.2; 0.12; -0.15], "
                                          "tu=[0; {:.17g}; {:.17g}])\n",
                                          chateau, cube, half, half));
  const ConstraintGraph model = ImportCao(path);
  REQUIRE(model.components.size() == 1);
  const Component& c = model.components[0];
  const ConstraintGraph alone = ImportCao(chateau);
  const ConstraintGraph cube_alone = ImportCao(cube);
  CHECK(c.points.size() == alone.components[0].points.size() + 10);
  CHECK(c.faces.size() == alone.components[0].faces.size() + 4);

  Eigen::Matrix4d T;
  T << -1, 0, 0, -0.2,  //
      0, 0, 1, 0.12,    //
      0, 1, 0, -0.15,   //
      0, 0, 0, 1;
  // Every cube point where T puts it: its point 0, (0.05, 0.05, -0.05), at (-0.25, 0.07, -0.1).
  const Component& unplaced = cube_alone.components[0];
  for (size_t i = 0; i < unplaced.points.size(); ++i) {
    const int p = c.FindPoint(fmt::format("cube_p{}", i));
    REQUIRE(p >= 0);
    const Eigen::Vector4d expected = T * unplaced.points[i].position.homogeneous();
    CHECK((c.points[p].position - expected.head<3>()).norm() < 1e-12);
  }
  CHECK((c.points[c.FindPoint("cube_p0")].position - Eigen::Vector3d(-0.25, 0.07, -0.1)).norm() <
        1e-12);
  // The chateau's own points stay where they are (its parts under its prefix).
  const Component& castle = alone.components[0];
  for (const FeaturePoint& p : castle.points) {
    const int q = c.FindPoint("chateau_" + p.name);
    REQUIRE(q >= 0);
    CHECK(c.points[q].position == p.position);
  }
}

}  // namespace
}  // namespace cfuse
