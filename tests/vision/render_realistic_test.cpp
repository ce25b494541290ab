// The renderer's realistic style (cfuse/vision/render.h, cfuse/vision/texture.h): textures in
// perspective, the truth against the image, motion blur, the sensor's noise model, determinism, the
// procedural fallback, the hand and the realistic standard sequences.
#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cfuse/dsl/model_loader.h"
#include "cfuse/importers/urdf.h"
#include "cfuse/kernel/chi_square.h"
#include "cfuse/kernel/error.h"
#include "cfuse/vision/render.h"
#include "cfuse/vision/sequence.h"
#include "cfuse/vision/texture.h"
#include "test_util.h"

namespace cfuse {
namespace {

// Whether two renderings have the same pixels (said without printing 307200 of them).
bool SamePixels(const Rendering& a, const Rendering& b) { return a.pixels == b.pixels; }

cv::Mat Image(const Rendering& r) {
  return cv::Mat(r.height, r.width, CV_8U, const_cast<std::uint8_t*>(r.pixels.data()));
}

// A square plate `side` mm across whose one face looks along -z of its frame.
ConstraintGraph Plate(int side) {
  const std::string s = std::to_string(side);
  return LoadModelFromString(
      "name: plate\nunits: {length: mm}\ncomponents:\n  plate:\n    points: {p00: [0, 0, 0], "
      "p10: [" +
          s + ", 0, 0], p11: [" + s + ", " + s + ", 0], p01: [0, " + s +
          ", 0]}\n    faces: {front: [p00, p01, p11, p10]}\n",
      "plate.yaml", ".");
}

Values Placed(const ConstraintGraph& g, const Rigid3d& camera_from_plate) {
  Values v = g.nominal;
  v.poses[0] = camera_from_plate;
  return v;
}

std::shared_ptr<const std::vector<GrayImage>> Share(std::vector<GrayImage> photographs) {
  return std::make_shared<const std::vector<GrayImage>>(std::move(photographs));
}

GrayImage Flat(int grey, int side = 64) {
  GrayImage image;
  image.width = image.height = side;
  image.pixels.assign(static_cast<size_t>(side) * side, static_cast<std::uint8_t>(grey));
  return image;
}

// Realistic options without noise, blur, highlight or shadow: the scene alone.
RenderOptions Quiet(std::shared_ptr<const std::vector<GrayImage>> photographs) {
  RenderOptions o;
  o.style = RenderStyle::kRealistic;
  o.clutter_lines = o.clutter_blobs = 0;
  o.noise = 0;
  o.blur = 0;
  o.realistic.gain = 0;
  o.realistic.specular = 0;
  o.realistic.shadow = 0;
  o.realistic.photographs = std::move(photographs);
  return o;
}

TEST_CASE("realistic render: a face's texture is mapped in perspective", "[vision][render]") {
  // A checkerboard printed on a 30 cm plate turned 54 degrees from the view, 0.6 m away: each of
  // its corners shows where the camera projects the face point that FaceTextures maps onto it,
  // within a pixel. An image-affine mapping (across the image, not the plane) would miss some by
  // over 3 px.
  const ConstraintGraph g = Plate(300);
  GrayImage checker;
  checker.width = checker.height = 800;
  for (int y = 0; y < 800; ++y) {
    for (int x = 0; x < 800; ++x) {
      checker.pixels.push_back((x / 40 + y / 40) % 2 ? 200 : 40);
    }
  }
  const auto photographs = Share({checker});
  const Camera camera = testing::Pinhole();
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.95, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Rigid3d pose(R, Eigen::Vector3d(0, 0, 0.6) - R * Eigen::Vector3d(0.15, 0.15, 0));
  const Values values = Placed(g, pose);
  RenderOptions o = Quiet(photographs);
  o.blur = 0.7;
  o.realistic.look_seed = 3;
  const Rendering r = Render(g, values, camera, o);
  cv::Mat image;
  Image(r).convertTo(image, CV_32F);

  const std::vector<FaceTexture> textures = FaceTextures(g, *photographs, 3, 0.16);
  REQUIRE(textures.size() == 1);
  REQUIRE(textures[0].photograph == 0);
  const FacePlane plane = FaceFrame(g.components[0], 0);
  const Eigen::Matrix2d linear = textures[0].photo_from_face.leftCols<2>();
  auto project = [&](double s, double t) {
    return camera.Project<double>(
        Eigen::Vector3d(pose * (plane.origin + s * plane.s + t * plane.t)));
  };
  // What a mapping affine in the image would give: the face's frame through three projections.
  const Eigen::Vector2d o0 = project(0, 0), os = project(0.3, 0) - o0, ot = project(0, 0.3) - o0;
  std::vector<cv::Point2f> outline;
  for (const auto& [s, t] : {std::pair{0.0, 0.0}, {0.3, 0.0}, {0.3, 0.3}, {0.0, 0.3}}) {
    const Eigen::Vector2d p = project(s, t);
    outline.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }
  std::vector<cv::Point2f> expected, found;
  double affine_miss = 0;
  for (int i = 1; i < 20; ++i) {
    for (int j = 1; j < 20; ++j) {
      // Squares change between pixel centres 40k - 1 and 40k: the corner is at 40k - 0.5.
      const Eigen::Vector2d q(40 * i - 0.5, 40 * j - 0.5);
      const Eigen::Vector2d st = linear.inverse() * (q - textures[0].photo_from_face.col(2));
      const Eigen::Vector2d p = project(st.x(), st.y());
      const cv::Point2f at(static_cast<float>(p.x()), static_cast<float>(p.y()));
      if (cv::pointPolygonTest(outline, at, true) < 12 || at.x < 12 || at.y < 12 ||
          at.x > camera.width - 13 || at.y > camera.height - 13) {
        continue;
      }
      // The squares about it at least 12 px across.
      const double square = 40 / linear.col(0).norm();
      if ((project(st.x() + square, st.y()) - p).norm() < 12 ||
          (project(st.x(), st.y() + square) - p).norm() < 12) {
        continue;
      }
      expected.push_back(at);
      affine_miss = std::max(affine_miss, (o0 + st.x() / 0.3 * os + st.y() / 0.3 * ot - p).norm());
    }
  }
  REQUIRE(expected.size() >= 12);
  CHECK(affine_miss > 3);
  found = expected;
  cv::cornerSubPix(image, found, cv::Size(5, 5), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
  double worst = 0;
  for (size_t k = 0; k < expected.size(); ++k) {
    worst = std::max(worst, static_cast<double>(cv::norm(found[k] - expected[k])));
  }
  INFO("corners " << expected.size() << ", affine mapping off by up to " << affine_miss
                  << " px, found within " << worst << " px");
  CHECK(worst < 0.5);
}

// The hinged box's first frame of the steady scenario, realistic, on procedural cards, without
// noise: the scene and its truth.
struct BoxScene {
  ConstraintGraph graph = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  Camera camera = StandardCamera();
  SequenceFrame frame;
};

BoxScene RenderBox(RenderStyle style, unsigned seed) {
  BoxScene scene;
  SequenceSpec spec =
      StandardSequence(scene.graph, "steady", 1, seed, style, Share(ProceduralPhotographs(seed)));
  spec.render.noise = 0;
  spec.render.realistic.gain = 0;
  spec.shutter = 0;
  scene.frame = RenderSequence(scene.graph, scene.camera, spec).front();
  return scene;
}

// The image's mean over 2-3 px to one side of uv (across: the unit normal), over 3 px along.
double SideMean(const cv::Mat& image, const Eigen::Vector2d& uv, const Eigen::Vector2d& across) {
  const Eigen::Vector2d along(-across.y(), across.x());
  double sum = 0;
  int n = 0;
  for (double a : {2.0, 3.0}) {
    for (double b : {-1.0, 0.0, 1.0}) {
      const Eigen::Vector2d p = uv + a * across + b * along;
      const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
      if (u < 0 || v < 0 || u >= image.cols || v >= image.rows) continue;
      sum += image.at<std::uint8_t>(v, u);
      ++n;
    }
  }
  return n ? sum / n : std::nan("");
}

TEST_CASE("realistic render: the truth is the model's edges where they show, not the print",
          "[vision][render]") {
  const BoxScene scene = RenderBox(RenderStyle::kRealistic, 11);
  const Rendering& r = scene.frame.rendering;
  const cv::Mat image = Image(r);
  const std::vector<ModelEdge> edges = ModelEdges(scene.graph);
  const std::vector<ProjectedEdge> visible =
      VisibleEdges(scene.graph, edges, scene.frame.truth, scene.camera);
  REQUIRE(!r.truth.empty());

  // Every truth segment lies on its edge's projection and shows a step across it.
  int samples = 0, steps = 0;
  std::vector<double> truth_gradient;
  cv::Mat gx, gy, gradient;
  cv::Sobel(image, gx, CV_32F, 1, 0);
  cv::Sobel(image, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, gradient);
  for (const TruthSegment& t : r.truth) {
    const auto on = std::find_if(visible.begin(), visible.end(),
                                 [&](const ProjectedEdge& e) { return e.edge == t.edge; });
    REQUIRE(on != visible.end());
    const Eigen::Vector2d d = (on->b - on->a).normalized();
    for (const Eigen::Vector2d& p : {t.a, t.b}) {
      CHECK(std::abs(d.x() * (p - on->a).y() - d.y() * (p - on->a).x()) < 1e-6);
    }
    const Eigen::Vector2d normal(-d.y(), d.x());
    const double length = (t.b - t.a).norm();
    for (double x = 1; x < length - 1; x += 2) {
      const Eigen::Vector2d uv = t.a + x * d;
      const double step = std::abs(SideMean(image, uv, normal) - SideMean(image, uv, -normal));
      if (std::isnan(step)) continue;
      ++samples;
      steps += step >= 7.5;  // half of min_contrast, after the optics' blur
      float strongest = 0;
      for (double a : {-1.0, 0.0, 1.0}) {
        const Eigen::Vector2d p = uv + a * normal;
        const int u = static_cast<int>(std::lround(p.x())),
                  v = static_cast<int>(std::lround(p.y()));
        if (u >= 0 && v >= 0 && u < image.cols && v < image.rows) {
          strongest = std::max(strongest, gradient.at<float>(v, u));
        }
      }
      truth_gradient.push_back(strongest);
    }
  }
  REQUIRE(samples > 200);
  CHECK(steps >= 0.95 * samples);

  // Where a visible edge shows no step (print as dark as the background beside it), the truth
  // leaves it out.
  int flat = 0, flat_in_truth = 0;
  for (const ProjectedEdge& e : visible) {
    const Eigen::Vector2d d = (e.b - e.a).normalized(), normal(-d.y(), d.x());
    for (double x = 3; x < (e.b - e.a).norm() - 3; x += 2) {
      const Eigen::Vector2d uv = e.a + x * d;
      const double step = std::abs(SideMean(image, uv, normal) - SideMean(image, uv, -normal));
      if (!(step < 3)) continue;
      ++flat;
      for (const TruthSegment& t : r.truth) {
        if (t.edge != e.edge) continue;
        const double along = (uv - t.a).dot(d);
        if (along > 1 && along < (t.b - t.a).norm() - 1) ++flat_in_truth;
      }
    }
  }
  INFO("visible edge samples without a step: " << flat);
  REQUIRE(flat >= 10);
  CHECK(flat_in_truth <= 0.1 * flat);

  // Inside the faces, away from every edge, the print makes edges as strong as the model's:
  // its strongest gradients (99th percentile) reach the truth's median. The plain style's faces,
  // flat, do not come near.
  auto interior_p99 = [&](const BoxScene& s) {
    const cv::Mat picture = Image(s.frame.rendering);
    cv::Mat sx, sy, magnitude;
    cv::Sobel(picture, sx, CV_32F, 1, 0);
    cv::Sobel(picture, sy, CV_32F, 0, 1);
    cv::magnitude(sx, sy, magnitude);
    cv::Mat1b faces(picture.size(), 0), near_edges(picture.size(), 0);
    for (size_t c = 0; c < s.graph.components.size(); ++c) {
      for (size_t f = 0; f < s.graph.components[c].faces.size(); ++f) {
        if (!FrontFacing(s.graph, c, f, s.frame.truth, s.camera)) continue;
        std::vector<cv::Point> polygon;
        const Rigid3d& pose =
            s.frame.truth.poses[s.graph.blocks[s.graph.components[c].block].index];
        for (int k : s.graph.components[c].faces[f].loop) {
          const Eigen::Vector2d p = s.camera.Project<double>(
              Eigen::Vector3d(pose * s.graph.components[c].points[k].position));
          polygon.emplace_back(static_cast<int>(std::lround(p.x())),
                               static_cast<int>(std::lround(p.y())));
        }
        cv::fillPoly(faces, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(255));
      }
    }
    for (const ProjectedEdge& e : VisibleEdges(s.graph, edges, s.frame.truth, s.camera)) {
      cv::line(near_edges, cv::Point2d(e.a.x(), e.a.y()), cv::Point2d(e.b.x(), e.b.y()),
               cv::Scalar(255), 11);
    }
    std::vector<float> inside;
    for (int v = 0; v < picture.rows; ++v) {
      for (int u = 0; u < picture.cols; ++u) {
        if (faces(v, u) && !near_edges(v, u)) inside.push_back(magnitude.at<float>(v, u));
      }
    }
    REQUIRE(inside.size() > 5000);
    std::nth_element(inside.begin(), inside.begin() + inside.size() * 99 / 100, inside.end());
    return static_cast<double>(inside[inside.size() * 99 / 100]);
  };
  std::nth_element(truth_gradient.begin(), truth_gradient.begin() + truth_gradient.size() / 2,
                   truth_gradient.end());
  const double truth_median = truth_gradient[truth_gradient.size() / 2];
  const double print = interior_p99(scene);
  const double plain = interior_p99(RenderBox(RenderStyle::kPlain, 11));
  INFO("gradient: truth median " << truth_median << ", print p99 " << print << ", plain p99 "
                                 << plain);
  CHECK(print >= truth_median);
  CHECK(plain < 0.25 * truth_median);
}

TEST_CASE("realistic render: motion blur spreads an edge over the shutter's travel",
          "[vision][render]") {
  // A plain plate moving right 20 px a frame: with the shutter open half the frame, its left
  // edge spreads over 10 px centred on the frame's own position; shut, it stays sharp.
  const ConstraintGraph g = Plate(300);
  const Camera camera = testing::Pinhole();
  SequenceSpec spec;
  spec.frames = 2;
  // The left edge at u = 320 + 800 x: 200.3 at frame 0, 220.3 at frame 1.
  spec.start = Rigid3d(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.15 + 0.3 / 800, -0.15, 1.0));
  spec.velocity = Eigen::Vector3d(0.025, 0, 0);  // 20 px a frame at 1 m
  spec.render = Quiet(Share({Flat(60)}));
  spec.render.realistic.texture_contrast = 0;
  spec.render.realistic.ambient = 1;  // a flat plate over a flat background
  spec.shutter_samples = 64;
  auto profile = [&](double shutter, double* centre, double* spread) {
    spec.shutter = shutter;
    const Rendering r = RenderSequence(g, camera, spec)[1].rendering;
    const cv::Mat image = Image(r);
    // The profile's derivative between pixel centres u - 1 and u, placed at u - 0.5: its
    // centroid is where the edge is, its standard deviation how far it spreads.
    std::vector<double> row;
    for (int u = 200; u < 242; ++u) row.push_back(image.at<std::uint8_t>(240, u));
    double m0 = 0, m1 = 0, m2 = 0;
    for (size_t k = 1; k < row.size(); ++k) {
      const double x = 200 + k - 0.5, d = row[k] - row[k - 1];
      m0 += d;
      m1 += d * x;
      m2 += d * x * x;
    }
    REQUIRE(m0 > 40);  // the plate is brighter than the background
    *centre = m1 / m0;
    *spread = std::sqrt(std::max(0.0, m2 / m0 - *centre * *centre));
  };
  double centre = 0, spread = 0;
  profile(0, &centre, &spread);
  CHECK(centre == Approx(220.3).margin(0.6));
  CHECK(spread < 0.6);
  profile(0.5, &centre, &spread);
  // Evenly spread over 10 px (ceil(10 / 2) = 5 instants): a uniform spread's standard deviation.
  const int n = 5;
  const double expected = 10 * std::sqrt((n * n - 1.0) / (12.0 * n * n));
  CHECK(centre == Approx(220.3).margin(0.6));
  CHECK(spread == Approx(expected).margin(0.4));
}

TEST_CASE("realistic render: the sensor's noise has variance read² + gain · signal",
          "[vision][render]") {
  // A flat grey over the whole image (an occluder), at two levels: the sample variance of
  // 307200 pixels against noise² + gain · grey + 1/12 (the rounding to 8 bits), by the
  // chi-square distribution's 99.9 % interval.
  const ConstraintGraph g = Plate(300);
  const Camera camera = testing::Pinhole();
  RenderOptions o = Quiet(Share({Flat(90)}));
  o.noise = 3;
  o.realistic.gain = 0.08;
  o.occluders.push_back({{-1, -1}, {641, -1}, {641, 481}, {-1, 481}});
  for (int grey : {40, 180}) {
    o.occluder_grey = grey;
    o.seed = static_cast<unsigned>(grey);
    const Rendering r = Render(g, Placed(g, Rigid3d()), camera, o);
    double sum = 0, sum2 = 0;
    for (std::uint8_t p : r.pixels) {
      sum += p;
      sum2 += double(p) * p;
    }
    const double n = static_cast<double>(r.pixels.size());
    const double mean = sum / n, variance = (sum2 - n * mean * mean) / (n - 1);
    const double model = 3 * 3 + 0.08 * grey + 1.0 / 12;
    INFO("grey " << grey << ": variance " << variance << ", model " << model);
    CHECK(std::abs(mean - grey) < 4 * std::sqrt(model / n));
    CHECK(variance > model * ChiSquareQuantile(0.0005, n - 1) / (n - 1));
    CHECK(variance < model * ChiSquareQuantile(0.9995, n - 1) / (n - 1));
  }
}

TEST_CASE("realistic render: the same seeds give the same image", "[vision][render]") {
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const auto photographs = Share(ProceduralPhotographs(5));
  SequenceSpec spec = StandardSequence(g, "fast", 3, 5, RenderStyle::kRealistic, photographs);
  const std::vector<SequenceFrame> one = RenderSequence(g, StandardCamera(), spec);
  const std::vector<SequenceFrame> two = RenderSequence(g, StandardCamera(), spec);
  REQUIRE(one.size() == 3);
  for (size_t i = 0; i < one.size(); ++i) {
    CHECK(SamePixels(one[i].rendering, two[i].rendering));
    REQUIRE(one[i].rendering.truth.size() == two[i].rendering.truth.size());
    for (size_t k = 0; k < one[i].rendering.truth.size(); ++k) {
      CHECK(one[i].rendering.truth[k].a == two[i].rendering.truth[k].a);
      CHECK(one[i].rendering.truth[k].b == two[i].rendering.truth[k].b);
    }
  }
  // Another noise seed changes the pixels, not the truth; another look changes the scene.
  RenderOptions o = spec.render;
  const Values& at = one[0].truth;
  const Rendering base = Render(g, at, StandardCamera(), o);
  o.seed += 100;
  const Rendering noise = Render(g, at, StandardCamera(), o);
  CHECK(!SamePixels(noise, base));
  CHECK(noise.truth.size() == base.truth.size());
  o = spec.render;
  o.realistic.look_seed += 1;
  cv::Mat difference;
  cv::absdiff(Image(Render(g, at, StandardCamera(), o)), Image(base), difference);
  CHECK(cv::mean(difference)[0] > 10);
}

TEST_CASE("realistic render: without photographs, procedural cards", "[vision][render]") {
  // No photographs (null or empty) is ProceduralPhotographs(look_seed): printed cards on the
  // faces and behind.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  SequenceSpec spec = StandardSequence(g, "steady", 1, 8, RenderStyle::kRealistic);
  const Values at = SequencePose(g, spec, 0);
  RenderOptions o = spec.render;
  REQUIRE(o.realistic.photographs == nullptr);
  const Rendering none = Render(g, at, StandardCamera(), o);
  CHECK(SamePixels(Render(g, at, StandardCamera(), o), none));
  o.realistic.photographs = Share({});
  CHECK(SamePixels(Render(g, at, StandardCamera(), o), none));
  o.realistic.photographs = Share(ProceduralPhotographs(o.realistic.look_seed));
  CHECK(SamePixels(Render(g, at, StandardCamera(), o), none));
  const std::vector<GrayImage> cards = ProceduralPhotographs(8);
  REQUIRE(cards.size() == 4);
  for (const GrayImage& card : cards) {
    cv::Scalar mean, deviation;
    cv::meanStdDev(
        cv::Mat(card.height, card.width, CV_8U, const_cast<std::uint8_t*>(card.pixels.data())),
        mean, deviation);
    CHECK(deviation[0] > 25);  // print, not a flat card
  }
  // Most faces printed (a thin rim's crop may fall on flat card and stay plain).
  const std::vector<FaceTexture> textures = FaceTextures(g, cards, 8, 0.16);
  const auto printed = std::count_if(textures.begin(), textures.end(), [](const FaceTexture& t) {
    return t.photograph >= 0 && t.gain > 0;
  });
  CHECK(printed >= 9);
  CHECK(textures.size() == 12u);
  // A photograph too small, or without its pixels, is refused.
  GrayImage tiny = Flat(100, 16);
  o.realistic.photographs = Share({tiny});
  CHECK_THROWS_AS(Render(g, at, StandardCamera(), o), InputError);
  GrayImage hollow = Flat(100);
  hollow.pixels.pop_back();
  o.realistic.photographs = Share({hollow});
  CHECK_THROWS_AS(Render(g, at, StandardCamera(), o), InputError);
}

TEST_CASE("realistic render: a hand hides what it passes over", "[vision][render]") {
  // The `hand` scenario, both styles: at the middle frame the hand covers part of the box, whose
  // edges there leave the truth; the other scenarios' frames are untouched by it.
  const ConstraintGraph g = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  const Camera camera = StandardCamera();
  for (RenderStyle style : {RenderStyle::kPlain, RenderStyle::kRealistic}) {
    INFO(RenderStyleName(style));
    SequenceSpec hand = StandardSequence(g, "hand", 21, 2, style, Share(ProceduralPhotographs(2)));
    SequenceSpec steady =
        StandardSequence(g, "steady", 21, 2, style, Share(ProceduralPhotographs(2)));
    REQUIRE(hand.hand_width > 0);
    CHECK(steady.hand_width == 0);
    hand.frames = steady.frames = 21;
    const Values at = SequencePose(g, hand, 10);
    RenderOptions with = hand.render, without = steady.render;
    // Frame 10 of 21: the palm at hand_to, 35 cm in front of the box.
    HandOccluder h;
    h.palm = camera.Project<double>(hand.hand_to);
    const Eigen::Vector2d elbow = camera.Project<double>(hand.hand_from) - h.palm;
    h.arm_angle = std::atan2(elbow.y(), elbow.x());
    h.width = 0.09 * camera.fx / hand.hand_to.z();
    with.hands = {h};
    const Rendering covered = Render(g, at, camera, with), bare = Render(g, at, camera, without);
    auto length = [](const Rendering& r) {
      double sum = 0;
      for (const TruthSegment& t : r.truth) sum += (t.b - t.a).norm();
      return sum;
    };
    CHECK(length(covered) < 0.95 * length(bare));
    for (const TruthSegment& t : covered.truth) {
      for (double x = 0; x <= 1; x += 0.05) {
        CHECK((t.a + x * (t.b - t.a) - h.palm).norm() > 0.45 * h.width);
      }
    }
    // The sequence draws the same hand at its middle frame.
    const std::vector<SequenceFrame> frames = RenderSequence(g, camera, hand);
    REQUIRE(frames.size() == 21);
    REQUIRE(!frames[10].rendering.truth.empty());
    for (const TruthSegment& t : frames[10].rendering.truth) {
      CHECK((0.5 * (t.a + t.b) - h.palm).norm() > 0.45 * h.width);
    }
  }
  const std::vector<std::string> names = StandardSequenceNames();
  CHECK(std::find(names.begin(), names.end(), "hand") != names.end());
}

TEST_CASE("realistic render: every standard scenario, and a robot of boxes", "[vision][render]") {
  const auto photographs = Share(ProceduralPhotographs(4));
  const ConstraintGraph box = LoadModel(testing::SourcePath("examples/hinged-box.yaml"));
  for (const std::string& name : StandardSequenceNames()) {
    INFO(name);
    const SequenceSpec spec =
        StandardSequence(box, name, 2, 4, RenderStyle::kRealistic, photographs);
    CHECK(spec.render.style == RenderStyle::kRealistic);
    CHECK(spec.shutter == 0.5);
    const std::vector<SequenceFrame> frames = RenderSequence(box, StandardCamera(), spec);
    REQUIRE(frames.size() == 2);
    CHECK(frames[1].rendering.truth.size() >= 4);
  }
  // A URDF robot whose links are boxes: their faces printed too.
  const ConstraintGraph arm =
      ImportUrdf(testing::SourcePath("tests/data/urdf/arm.urdf"));
  const SequenceSpec spec =
      StandardSequence(arm, "steady", 1, 6, RenderStyle::kRealistic, photographs);
  const std::vector<SequenceFrame> frames = RenderSequence(arm, StandardCamera(), spec);
  CHECK(frames.front().rendering.truth.size() >= 4);
  int printed = 0;
  for (const FaceTexture& t : FaceTextures(arm, *photographs, 6, 0.16)) printed += t.gain > 0;
  CHECK(printed >= 12);
  CHECK(ParseRenderStyle("realistic") == RenderStyle::kRealistic);
  CHECK(ParseRenderStyle("plain") == RenderStyle::kPlain);
  CHECK(!ParseRenderStyle("photographic"));
}

}  // namespace
}  // namespace cfuse
