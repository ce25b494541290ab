#include "cfuse/track/detector.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <functional>
#include <queue>

#include "cfuse/constraints/evaluate.h"
#include "cfuse/constraints/joint_model.h"
#include "cfuse/geometry/model_edges.h"
#include "cfuse/geometry/p3p.h"
#include "cfuse/kernel/error.h"

namespace cfuse {
namespace {

using Clock = std::chrono::steady_clock;

// px: two poses drawing every edge within this of the other's are one answer (symmetry).
constexpr double kSameOutlinePixels = 2;

double Ms(Clock::time_point from) {
  return std::chrono::duration<double, std::milli>(Clock::now() - from).count();
}

// A rigid component's edges and faces in its own coordinates, for the ranking, and its vertices
// where two or more edges meet.
struct Shape {
  int component = -1;
  int block = -1;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 2>> edges;
  std::vector<std::vector<int>> edge_faces;
  std::vector<Eigen::Vector3d> face_normal, face_centre;  // normal: twice the area, outward
  std::vector<std::vector<int>> neighbours;              // per point, along edges
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
};

std::vector<Shape> Shapes(const ConstraintGraph& graph) {
  const std::vector<ModelEdge> edges = ModelEdges(graph);
  std::vector<Shape> shapes;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    const Component& component = graph.components[c];
    if (!component.rigid) continue;
    Shape s;
    s.component = static_cast<int>(c);
    s.block = component.block;
    for (const FeaturePoint& p : component.points) s.points.push_back(p.position);
    s.neighbours.resize(s.points.size());
    for (const Face& face : component.faces) {
      Eigen::Vector3d normal = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < face.loop.size(); ++k) {
        const Eigen::Vector3d& p = s.points[face.loop[k]];
        normal += p.cross(s.points[face.loop[(k + 1) % face.loop.size()]]);
        centre += p;
      }
      s.face_normal.push_back(normal);
      s.face_centre.push_back(centre / static_cast<double>(std::max<size_t>(1, face.loop.size())));
    }
    for (const ModelEdge& e : edges) {
      if (e.component != s.component || e.a == e.b) continue;
      s.edges.push_back({e.a, e.b});
      s.edge_faces.push_back(e.faces);
      for (const auto& [from, to] : {std::pair{e.a, e.b}, std::pair{e.b, e.a}}) {
        std::vector<int>& n = s.neighbours[from];
        if (std::find(n.begin(), n.end(), to) == n.end()) n.push_back(to);
      }
    }
    if (s.edges.empty()) continue;
    for (const Eigen::Vector3d& p : s.points) s.centroid += p;
    s.centroid /= static_cast<double>(s.points.size());
    shapes.push_back(std::move(s));
  }
  return shapes;
}

// A scored pose of one shape.
struct Scored {
  Rigid3d camera_from_component;
  int shape = -1, vertex = -1, junction = -1;
  double evidence = 0;
  Eigen::Vector2d centroid;  // the shape's centroid in the image
};

// What `shape`'s edges at `pose` explain of the image: supported samples less chance's share.
// False when the pose puts a point too near or behind the camera or shows too little.
bool Rank(const Shape& shape, const Rigid3d& pose, const Camera& camera,
          const EdgeOrientations& steps, const DetectorOptions& options, double* evidence,
          double floor = -INFINITY) {
  thread_local std::vector<Eigen::Vector2d> pixels;
  thread_local std::vector<char> front;
  struct Piece {
    Eigen::Vector2d a, d;
    int bin, n;
  };
  thread_local std::vector<Piece> pieces;
  pixels.resize(shape.points.size());
  for (size_t i = 0; i < shape.points.size(); ++i) {
    const Eigen::Vector3d p = pose * shape.points[i];
    if (!(p.z() >= options.min_depth)) return false;
    pixels[i] = camera.Project(p);
  }
  const Eigen::Vector3d eye = pose.Inverse().translation;  // the camera centre, component frame
  front.resize(shape.face_normal.size());
  for (size_t f = 0; f < front.size(); ++f) {
    front[f] = shape.face_normal[f].dot(eye - shape.face_centre[f]) > 0;
  }
  pieces.clear();
  int remaining = 0;
  for (size_t e = 0; e < shape.edges.size(); ++e) {
    bool visible = shape.edge_faces[e].empty();
    for (const int f : shape.edge_faces[e]) visible = visible || front[f];
    if (!visible) continue;
    const Eigen::Vector2d a = pixels[shape.edges[e][0]], b = pixels[shape.edges[e][1]];
    const Eigen::Vector2d d = b - a;
    const double length = d.norm();
    if (!(length > 0)) continue;
    const int n = static_cast<int>(std::ceil(length / options.sample_step));
    pieces.push_back({a, d, EdgeOrientations::Bin(Eigen::Vector2d(-d.y(), d.x())), n});
    remaining += n;
  }
  // Samples supported less chance's share of them; a pose that cannot reach `floor` even with
  // every sample left supported is given up.
  double supported = 0, chance = 0;
  int samples = 0;
  for (const Piece& piece : pieces) {
    const std::uint8_t mask = EdgeOrientations::Tolerant(piece.bin);
    for (int k = 0; k < piece.n; ++k) {
      const Eigen::Vector2d p = piece.a + ((k + 0.5) / piece.n) * piece.d;
      --remaining;
      if (p.x() < 0 || p.y() < 0 || p.x() > steps.width() - 1 || p.y() > steps.height() - 1) {
        continue;
      }
      ++samples;
      chance += steps.Chance(piece.bin);
      supported += steps.Has(p.x(), p.y(), mask);
    }
    if (supported + remaining - chance < floor) return false;
  }
  if (samples < options.min_samples) return false;
  *evidence = supported - chance;
  return true;
}

// The whole model placed by one component's pose, the others at their nominal place about it.
Values Place(const ConstraintGraph& graph, int block, const Rigid3d& camera_from_component) {
  Values values = graph.nominal;
  const int index = graph.blocks[block].index;
  const Rigid3d move = camera_from_component * values.poses[index].Inverse();
  for (Rigid3d& pose : values.poses) pose = move * pose;
  for (Eigen::Vector3d& point : values.points) point = move * point;
  return values;
}

// What every shape's edges at `values` explain (Rank over the model; shapes showing too little
// add nothing). -infinity when a point lies too near or behind the camera.
double RankModel(const ConstraintGraph& graph, const std::vector<Shape>& shapes,
                 const Values& values, const Camera& camera, const EdgeOrientations& steps,
                 const DetectorOptions& options) {
  double total = 0;
  DetectorOptions any = options;
  any.min_samples = 0;
  for (const Shape& s : shapes) {
    const Rigid3d& pose = values.poses[graph.blocks[s.block].index];
    double evidence = 0;
    if (!Rank(s, pose, camera, steps, any, &evidence)) return -INFINITY;
    total += evidence;
  }
  return total;
}

// `values` with joint `joint` at `q`, the side of it away from component `fixed` moved with it.
Values WithJoint(const ConstraintGraph& graph, const Values& values, const Joint& joint, double q,
                 int fixed) {
  // The components on the child's side of the joint (the joint's own link cut).
  std::vector<bool> child_side(graph.components.size(), false);
  child_side[joint.child] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (const Joint& j : graph.joints) {
      if (&j == &joint) continue;
      for (const auto& [from, to] : {std::pair{j.parent, j.child}, std::pair{j.child, j.parent}}) {
        if (child_side[from] && !child_side[to] && to != joint.parent) child_side[to] = grew = true;
      }
    }
  }
  const auto pose_of = [&](int c) -> const Rigid3d& {
    return values.poses[graph.blocks[graph.components[c].block].index];
  };
  const Rigid3d motion = JointMotion(joint.type, joint.axis, q);
  const bool move_child = !child_side[fixed];
  Rigid3d delta;
  if (move_child) {
    const Rigid3d placed =
        pose_of(joint.parent) * joint.parent_from_joint * motion * joint.child_from_joint.Inverse();
    delta = placed * pose_of(joint.child).Inverse();
  } else {
    const Rigid3d placed = pose_of(joint.child) * joint.child_from_joint * motion.Inverse() *
                           joint.parent_from_joint.Inverse();
    delta = placed * pose_of(joint.parent).Inverse();
  }
  Values v = values;
  for (size_t c = 0; c < graph.components.size(); ++c) {
    if (child_side[c] != move_child) continue;
    const Block& b = graph.blocks[graph.components[c].block];
    if (b.kind == BlockKind::kPose) {
      v.poses[b.index] = delta * v.poses[b.index];
    } else {
      v.points[b.index] = delta * v.points[b.index];
    }
  }
  MatchSlacks(graph, &v);
  return v;
}

// The configuration a candidate starts from: the seeded component where P3P put it, each joint
// between rigid parts (one at a time) at `values` across its range (or round the circle), the
// one whose edges explain the most of the image kept.
Values BestJoints(const ConstraintGraph& graph, const std::vector<Shape>& shapes,
                  const Values& nominal, int seeded, const Camera& camera,
                  const EdgeOrientations& steps, const DetectorOptions& options) {
  Values best = nominal;
  double best_rank = RankModel(graph, shapes, nominal, camera, steps, options);
  const int n = options.joint_values;
  for (const Joint& joint : graph.joints) {
    if (!HasJointVariable(joint.type) || joint.mimic || !graph.components[joint.parent].rigid ||
        !graph.components[joint.child].rigid) {
      continue;
    }
    std::vector<double> qs;
    if (joint.limits) {
      for (int k = 0; k < n; ++k) {
        qs.push_back(joint.limits->first +
                     (k + 0.5) * (joint.limits->second - joint.limits->first) / n);
      }
    } else if (!ModelOf(joint.type).VariableIsLength()) {
      for (int k = 0; k < n; ++k) qs.push_back(2 * M_PI * k / n);
    }
    for (const double q : qs) {
      Values v = WithJoint(graph, nominal, joint, q, seeded);
      const double rank = RankModel(graph, shapes, v, camera, steps, options);
      if (rank > best_rank) {
        best_rank = rank;
        best = std::move(v);
      }
    }
  }
  return best;
}

double AngleDegrees(const Rigid3d& a, const Rigid3d& b) {
  return Eigen::AngleAxisd(a.rotation.inverse() * b.rotation).angle() * 180 / M_PI;
}

// The root component's pose block: the first rigid component's.
int RootBlock(const ConstraintGraph& graph) {
  for (const Component& c : graph.components) {
    if (c.rigid) return c.block;
  }
  return -1;
}

const Rigid3d& RootPose(const ConstraintGraph& graph, const Values& values) {
  static const Rigid3d kIdentity;
  const int block = RootBlock(graph);
  return block < 0 ? kIdentity : values.poses[graph.blocks[block].index];
}

// The largest distance (px) from a point of `from` to the nearest point of `to`.
double Farthest(const std::vector<Eigen::Vector2d>& from, const std::vector<Eigen::Vector2d>& to) {
  double farthest = 0;
  for (const Eigen::Vector2d& p : from) {
    double nearest = INFINITY;
    for (const Eigen::Vector2d& q : to) nearest = std::min(nearest, (p - q).norm());
    farthest = std::max(farthest, nearest);
  }
  return farthest;
}

// Whether every point of `a` lies within `tolerance` px of one of `b`'s and the other way round:
// two poses of a symmetric model (a box turned half round) draw the same outline, and no image
// can tell them apart.
bool SameOutline(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b,
                 double tolerance) {
  return !a.empty() && Farthest(a, b) <= tolerance && Farthest(b, a) <= tolerance;
}

// Whether two point sets cover the same part of the image: their bounding boxes share at least
// half of the smaller one.
bool Overlap(const std::vector<Eigen::Vector2d>& a, const std::vector<Eigen::Vector2d>& b) {
  Eigen::AlignedBox2d ba, bb;
  for (const Eigen::Vector2d& p : a) ba.extend(p);
  for (const Eigen::Vector2d& p : b) bb.extend(p);
  if (ba.isEmpty() || bb.isEmpty()) return false;
  const Eigen::AlignedBox2d shared = ba.intersection(bb);
  return !shared.isEmpty() && shared.volume() >= 0.5 * std::min(ba.volume(), bb.volume());
}

// Whether two verified frames found the same object: their root components within 1 % of the
// depth and 5 degrees of each other.
bool SamePlace(const ConstraintGraph& graph, const Values& a, const Values& b) {
  const int block = RootBlock(graph);
  if (block < 0) return true;
  const int index = graph.blocks[block].index;
  const Rigid3d& pa = a.poses[index];
  const Rigid3d& pb = b.poses[index];
  return (pa.translation - pb.translation).norm() <= 0.01 * pa.translation.norm() + 1e-3 &&
         AngleDegrees(pa, pb) <= 5;
}

// Why a verified frame does not show the object plainly enough to be found with no prior, or "".
std::string Plainly(const TrackedFrame& f, const DetectorOptions& options) {
  const Verification& v = f.verification;
  if (f.matches < options.min_matches) {
    return fmt::format("{} edges matched, {} needed for a pose found with no prior", f.matches,
                       options.min_matches);
  }
  if (v.share - v.chance < options.min_margin) {
    return fmt::format(
        "{:.0f} % of the outline supported against chance's {:.0f} % beside it: too little "
        "above chance for a pose found with no prior ({:.0f} points needed)",
        100 * v.share, 100 * v.chance, 100 * options.min_margin);
  }
  if (v.dominant_share < options.min_dominant) {
    return fmt::format(
        "the strongest step lies on the edge at {:.0f} % of the outline, {:.0f} % needed for a "
        "pose found with no prior",
        100 * v.dominant_share, 100 * options.min_dominant);
  }
  return "";
}

// A candidate's tracker: no settling (the best found is settled), and the search range doubled
// once at most for a model with joints (their values start from a coarse grid across their
// ranges, up to half a step off), never for a rigid one (its pose from P3P is as near as a
// doubled range would reach, and a doubling that fails costs a tracked frame more).
TrackerOptions ForCandidates(TrackerOptions options, bool joints) {
  options.settle_places = 0;
  options.settle_depths = 0;
  options.settle_tilts = 0;
  options.settle_joint_values = 0;
  options.max_doublings = std::min(options.max_doublings, joints ? 1 : 0);
  return options;
}

// Whether `point` lies at the corner of a junction other than `j`: a segment ending there ends
// where its edge meets another, at a vertex (the hinged box's lid along the box's top edge
// carries the edge's steps on past it), not where texture broke it.
bool AtCorner(const std::vector<Junction>& junctions, int j, const Eigen::Vector2d& point,
              const JunctionOptions& options) {
  for (size_t k = 0; k < junctions.size(); ++k) {
    if (static_cast<int>(k) != j && (junctions[k].corner - point).norm() <= options.max_gap) {
      return true;
    }
  }
  return false;
}

// Steps 2 and 3: every junction against every vertex of every shape, both ways round, each
// P3P pose ranked; the poses that beat the best kRanked so far, best first.
std::vector<Scored> RankedPoses(const std::vector<Shape>& shapes,
                                const std::vector<Junction>& junctions, const Camera& camera,
                                const EdgeOrientations& steps, const DetectorOptions& options,
                                DetectionStats* stats) {
  std::vector<Scored> scored;
  // The best kRanked evidences so far (a min-heap): a pose that cannot beat the least of them
  // is not ranked further, nor kept.
  constexpr size_t kRanked = 300;
  std::priority_queue<double, std::vector<double>, std::greater<double>> best;
  // Every vertex where two edges meet, with its ordered pairs of neighbours.
  struct Seed {
    int shape, vertex;
    std::array<Eigen::Vector3d, 3> object;  // neighbour, vertex, neighbour
  };
  std::vector<Seed> seeds;
  for (size_t si = 0; si < shapes.size(); ++si) {
    const Shape& s = shapes[si];
    for (size_t v = 0; v < s.points.size(); ++v) {
      const std::vector<int>& n = s.neighbours[v];
      stats->vertices += n.size() >= 2;
      for (size_t i = 0; i < n.size(); ++i) {
        for (size_t k = 0; k < n.size(); ++k) {
          if (i != k) {
            seeds.push_back({static_cast<int>(si), static_cast<int>(v),
                             {s.points[n[i]], s.points[v], s.points[n[k]]}});
          }
        }
      }
    }
  }
  for (int j = 0; j < static_cast<int>(junctions.size()); ++j) {
    std::vector<Eigen::Vector2d> ends[2];
    for (int arm = 0; arm < 2; ++arm) {
      ends[arm] = ArmEnds(junctions, j, arm, options.junctions, options.max_arm_ends);
      if (!(options.arm_trace_gap > 0) || AtCorner(junctions, j, ends[arm][0], options.junctions)) {
        continue;
      }
      // A segment that broke short of its edge's far corner: its end moved on to where the
      // edge's steps end, unless a junction's corner there is an end already.
      const Eigen::Vector2d traced = TracedEnd(junctions[j], arm, steps, options.arm_trace_gap);
      if (std::none_of(ends[arm].begin(), ends[arm].end(),
                       [&](const Eigen::Vector2d& e) { return (e - traced).norm() < 3; })) {
        ends[arm][0] = traced;
      }
    }
    for (const Eigen::Vector2d& end1 : ends[1]) {
      for (const Eigen::Vector2d& end0 : ends[0]) {
        const std::array<Eigen::Vector2d, 3> image_points = {end0, junctions[j].corner, end1};
        for (const Seed& seed : seeds) {
          const Shape& s = shapes[seed.shape];
          for (const Rigid3d& pose : PosesFromThreeProjections(camera, seed.object, image_points)) {
            if (++stats->poses > options.max_poses) {
              stats->poses = options.max_poses;
              stats->poses_cut = true;
              return scored;
            }
            double evidence = 0;
            const double floor = best.size() < kRanked ? 0.0 : best.top();
            if (!Rank(s, pose, camera, steps, options, &evidence, floor) ||
                !(evidence > floor)) {
              continue;
            }
            best.push(evidence);
            if (best.size() > kRanked) best.pop();
            scored.push_back({pose, seed.shape, seed.vertex, j, evidence,
                              camera.Project<double>(pose * s.centroid)});
          }
        }
      }
    }
  }
  return scored;
}

// The best poses, spread apart: a pose whose points' images each lie within spread_pixels of one
// of those of a pose kept is the same hypothesis again. `scored` best first.
std::vector<const Scored*> SpreadApart(const std::vector<Scored>& scored,
                                       const std::vector<Shape>& shapes, const Camera& camera,
                                       const DetectorOptions& options) {
  std::vector<const Scored*> kept;
  std::vector<std::vector<Eigen::Vector2d>> kept_points;
  for (const Scored& p : scored) {
    if (static_cast<int>(kept.size()) >= options.max_candidates) break;
    std::vector<Eigen::Vector2d> points;
    for (const Eigen::Vector3d& x : shapes[p.shape].points) {
      points.push_back(camera.Project<double>(p.camera_from_component * x));
    }
    bool near = false;
    for (size_t k = 0; k < kept.size() && !near; ++k) {
      near = kept[k]->shape == p.shape &&
             (kept[k]->centroid - p.centroid).norm() < options.spread_pixels &&
             Farthest(points, kept_points[k]) < options.spread_pixels;
    }
    if (!near) {
      kept.push_back(&p);
      kept_points.push_back(std::move(points));
    }
  }
  return kept;
}

// One answer: a verified frame, the points' images it draws, and the other poses verified that
// draw the same outline from elsewhere (the model's symmetry).
struct Answer {
  const TrackedFrame* frame;
  std::vector<Eigen::Vector2d> outline;
  std::vector<Values> twins;
};

// The verified frames (best first) as distinct answers: frames at the same place, or drawing the
// same outline, are one.
std::vector<Answer> DistinctAnswers(const ConstraintGraph& graph, const Camera& camera,
                                    const std::vector<TrackedFrame>& verified) {
  std::vector<Answer> answers;
  for (const TrackedFrame& f : verified) {
    std::vector<Eigen::Vector2d> points = ProjectedPoints(graph, camera, f.estimate.mean);
    bool same = false;
    for (Answer& a : answers) {
      if (SamePlace(graph, f.estimate.mean, a.frame->estimate.mean)) {
        same = true;
      } else if (SameOutline(points, a.outline, kSameOutlinePixels)) {
        same = true;
        bool known = false;
        for (const Values& t : a.twins) known = known || SamePlace(graph, f.estimate.mean, t);
        if (!known) a.twins.push_back(f.estimate.mean);
      }
      if (same) break;
    }
    if (!same) answers.push_back({&f, std::move(points), {}});
  }
  return answers;
}

}  // namespace

std::vector<Eigen::Vector2d> ProjectedPoints(const ConstraintGraph& graph, const Camera& camera,
                                            const Values& values) {
  std::vector<Eigen::Vector2d> out;
  for (const Component& c : graph.components) {
    if (!c.rigid) continue;
    const Rigid3d& pose = values.poses[graph.blocks[c.block].index];
    for (const FeaturePoint& p : c.points) out.push_back(camera.Project<double>(pose * p.position));
  }
  return out;
}

namespace {

// Step 4: each candidate (its `values` set) tracked on `image`, then the decision among those
// verified (Detection::found, twins, candidates). Returns why the first answer refused was
// refused, or "".
std::string TrackAndDecide(const ConstraintGraph& graph, const Camera& camera,
                           const GrayView& image, std::vector<DetectionCandidate> candidates,
                           const DetectorOptions& options, Detection* out) {
  bool joints = false;
  for (const Joint& joint : graph.joints) joints = joints || HasJointVariable(joint.type);
  const TrackerOptions quick = ForCandidates(options.tracker, joints);
  std::vector<TrackedFrame> verified;
  for (DetectionCandidate& c : candidates) {
    Tracker tracker(graph, camera, c.values, quick);
    c.frame = tracker.Track(image);
    ++out->stats.candidates;
    if (c.frame.verified) verified.push_back(c.frame);
    out->candidates.push_back(std::move(c));
  }
  std::stable_sort(verified.begin(), verified.end(),
                   [](const TrackedFrame& a, const TrackedFrame& b) {
                     return ExplainedEvidence(a.verification) > ExplainedEvidence(b.verification);
                   });
  const std::vector<Answer> answers = DistinctAnswers(graph, camera, verified);

  // A pose is the object only when no other pose over the same part of the image explains
  // about as much of it (TrackerOptions::decisive_share, as the settling judges places): a
  // model of repeated parts and parallel edges verifies a pose slid by one of them too. Only the
  // best can be the first object found; the others are further objects elsewhere.
  std::string refused;  // why the first answer refused was
  auto refuse = [&](const std::string& why) {
    if (refused.empty()) refused = why;
  };
  for (size_t i = 0; i < answers.size(); ++i) {
    if (static_cast<int>(out->found.size()) >= options.max_results) break;
    if (i > 0 && out->found.empty()) break;
    const Answer& a = answers[i];
    bool taken = false;  // by an object found already
    for (const TrackedFrame& g : out->found) {
      taken = taken || Overlap(ProjectedPoints(graph, camera, g.estimate.mean), a.outline);
    }
    if (taken) continue;
    const double evidence = ExplainedEvidence(a.frame->verification);
    const Answer* rival = nullptr;
    for (size_t k = 0; k < answers.size() && !rival; ++k) {
      if (k != i && Overlap(answers[k].outline, a.outline) &&
          Plainly(*answers[k].frame, options).empty() &&
          options.tracker.decisive_share * ExplainedEvidence(answers[k].frame->verification) >
              evidence) {
        rival = &answers[k];
      }
    }
    if (rival) {
      refuse(fmt::format(
          "ambiguous: two poses {:.0f} mm apart explain the image about as well ({:.0f} and "
          "{:.0f} samples beyond chance)",
          1000 * (RootPose(graph, a.frame->estimate.mean).translation -
                  RootPose(graph, rival->frame->estimate.mean).translation)
                     .norm(),
          evidence, ExplainedEvidence(rival->frame->verification)));
      continue;
    }
    if (const std::string plain = Plainly(*a.frame, options); !plain.empty()) {
      refuse(plain);
      continue;
    }
    // Settled as a tracker settles its first frame: tracked again from places about it.
    Tracker tracker(graph, camera, a.frame->estimate.mean, options.tracker);
    TrackedFrame settled = tracker.Track(image);
    if (!settled.verified) {
      refuse("refused when settled: " + settled.verification.why);
    } else if (const std::string plain = Plainly(settled, options); !plain.empty()) {
      refuse("refused when settled: " + plain);
    } else {
      out->found.push_back(std::move(settled));
      out->twins.push_back(a.twins);
    }
  }
  return refused;
}

// Refuses (InputError, its location left to the caller) an empty image, a camera without a size
// or of another size than the image, and a model without edges; returns the model's shapes.
std::vector<Shape> CheckedShapes(const ConstraintGraph& graph, const Camera& camera,
                                 const GrayView& image) {
  if (image.data == nullptr || image.width <= 0 || image.height <= 0) {
    throw InputError(SourceLocation(), "the image is empty");
  }
  if (camera.width != image.width || camera.height != image.height) {
    throw InputError(SourceLocation(),
                     fmt::format("the image is {} x {}, the camera's {} x {}", image.width,
                                 image.height, camera.width, camera.height));
  }
  std::vector<Shape> shapes = Shapes(graph);
  if (shapes.empty()) {
    throw InputError(SourceLocation(),
                     fmt::format("model '{}' has no edges to find in an image", graph.name));
  }
  return shapes;
}

}  // namespace

Detection Detect(const ConstraintGraph& graph, const Camera& camera, const GrayView& image,
                 const DetectorOptions& options, const std::vector<ImageSegment>* segments) {
  const std::vector<Shape> shapes = CheckedShapes(graph, camera, image);
  Detection out;
  auto start = Clock::now();
  out.segments = segments ? *segments : DetectSegments(image, options.segments);
  out.junctions = FindJunctions(out.segments, options.junctions);
  out.stats.segments = static_cast<int>(out.segments.size());
  out.stats.junctions = static_cast<int>(out.junctions.size());
  out.stats.segment_ms = Ms(start);

  start = Clock::now();
  const EdgeOrientations steps(image, options.orientations);
  out.stats.orientation_ms = Ms(start);

  start = Clock::now();
  const int junctions =
      std::min<int>(static_cast<int>(out.junctions.size()), options.max_junctions);
  out.stats.junctions_cut = junctions < static_cast<int>(out.junctions.size());
  std::vector<Scored> scored =
      RankedPoses(shapes, {out.junctions.begin(), out.junctions.begin() + junctions}, camera, steps,
                  options, &out.stats);
  std::sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) {
    if (a.evidence != b.evidence) return a.evidence > b.evidence;
    if (a.junction != b.junction) return a.junction < b.junction;
    if (a.shape != b.shape) return a.shape < b.shape;
    return a.vertex < b.vertex;
  });
  const std::vector<const Scored*> kept = SpreadApart(scored, shapes, camera, options);
  out.stats.ranking_ms = Ms(start);

  // Step 4: each candidate tracked on this image.
  start = Clock::now();
  std::vector<DetectionCandidate> candidates;
  for (const Scored* p : kept) {
    DetectionCandidate c;
    c.component = shapes[p->shape].component;
    c.vertex = p->vertex;
    c.junction = p->junction;
    c.evidence = p->evidence;
    c.values =
        BestJoints(graph, shapes, Place(graph, shapes[p->shape].block, p->camera_from_component),
                   c.component, camera, steps, options);
    candidates.push_back(std::move(c));
  }
  const std::string refused =
      TrackAndDecide(graph, camera, image, std::move(candidates), options, &out);
  out.stats.tracking_ms = Ms(start);

  if (out.found.empty()) {
    if (out.junctions.empty()) {
      out.why = "no junction of two segments in the image to seed a pose from";
    } else if (kept.empty()) {
      out.why = fmt::format(
          "no pose from {} junctions and {} vertices explains more of the image than chance",
          junctions, out.stats.vertices);
    } else if (!refused.empty()) {
      out.why = refused;
    } else {
      const DetectionCandidate& best = out.candidates.front();
      out.why = fmt::format("none of {} candidates verified; the best ranked was refused: {}",
                            out.candidates.size(),
                            best.frame.verification.why.empty() ? "no matches"
                                                                : best.frame.verification.why);
    }
  }
  return out;
}

Detection DetectFrom(const ConstraintGraph& graph, const Camera& camera, const GrayView& image,
                     const std::vector<Values>& poses, const DetectorOptions& options) {
  CheckedShapes(graph, camera, image);
  Detection out;
  const auto start = Clock::now();
  std::vector<DetectionCandidate> candidates(poses.size());
  for (size_t i = 0; i < poses.size(); ++i) candidates[i].values = poses[i];
  const std::string refused =
      TrackAndDecide(graph, camera, image, std::move(candidates), options, &out);
  out.stats.tracking_ms = Ms(start);
  if (out.found.empty()) {
    out.why = !refused.empty() ? refused
              : poses.empty()  ? "no pose to start from"
                               : fmt::format("none of {} poses verified", poses.size());
  }
  return out;
}

}  // namespace cfuse
