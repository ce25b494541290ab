// The realistic style (render.h): a photograph behind, photographs printed on the faces in
// perspective, a point light with its highlight, a soft shadow, motion blur, hands, the optics'
// blur and the sensor's noise. In named steps: Background, Rasterise, Shade (FaceShader),
// CastShadow, the object's layer (sharp or averaged over the exposure), DrawFront, and Sensor.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <random>

#include "cfuse/kernel/error.h"

#include "render_internal.h"

namespace cfuse::internal {
namespace {

// What every face's shading shares.
struct Lighting {
  Eigen::Vector3d light;  // camera frame, m
  double ambient = 0.3, specular = 0.5, shininess = 40;
  double cutoff = 0;  // n·h below which the highlight is under 1e-3 of its peak
  // (n·h)^shininess tabulated from the cutoff to 1: a power per pixel near a highlight would
  // cost more than the rest of the shading.
  std::vector<float> highlight;

  void Tabulate() {
    cutoff = std::pow(1e-3, 1 / shininess);
    highlight.resize(kSteps + 2);
    for (int k = 0; k <= kSteps + 1; ++k) {
      highlight[k] = static_cast<float>(
          std::pow(std::min(1.0, cutoff + (1 - cutoff) * k / kSteps), shininess));
    }
  }
  float Highlight(float facing) const {
    if (!(facing > cutoff)) return 0;
    const float x = std::min(1.f, static_cast<float>((facing - cutoff) / (1 - cutoff))) * kSteps;
    const int k = static_cast<int>(x);
    return highlight[k] + (x - k) * (highlight[k + 1] - highlight[k]);
  }
  static constexpr int kSteps = 1024;
};

// One front face's radiance at a configuration (render.h's shading equation): the face's plane
// in the camera frame, its texture and the light. Evaluated a row of pixels at a time, in
// float: the ray, the face's depth and texture coordinates along a row are linear in u or a
// ratio of linear terms, so each pixel costs one division and three square roots.
class FaceShader {
 public:
  FaceShader(const ViewedFace& viewed, const FacePlane& plane, const Rigid3d& camera_from_component,
             const FaceTexture& texture, const std::vector<GrayImage>& photographs,
             const Lighting& lighting, const Camera& camera)
      : camera_(camera), lighting_(lighting), texture_(texture) {
    normal_ = viewed.normal;
    offset_ = normal_.dot(viewed.corners[0]);
    origin_ = camera_from_component * plane.origin;
    s_ = camera_from_component.rotation * plane.s;
    t_ = camera_from_component.rotation * plane.t;
    if (texture.photograph >= 0) photo_ = &photographs[texture.photograph];
  }

  // The radiance of pixels u0 .. u1 - 1 of row v, into out[0 .. u1 - u0). In chunks: the
  // geometry and the light first, in loops the compiler vectorises, then the texture's and the
  // highlight's look-ups.
  void Row(int v, int u0, int u1, float* out) const {
    // Pinhole: the ray r(u) = (a + u k, b, 1) and the face's point z(u) r(u), with
    // z(u) = offset / (n · r(u)). Orthographic: the point o(u) + z(u) ẑ, with o(u) =
    // (a + u k, b, 0) and z(u) = (offset - n · o(u)) / n_z, linear in u; the view along -ẑ.
    const bool pinhole = camera_.model == Camera::Model::kPinhole;
    const double k = pinhole ? 1 / camera_.fx : 1 / camera_.scale;
    const double a = -camera_.cx * k;
    const double b = (v - camera_.cy) / (pinhole ? camera_.fy : camera_.scale);
    const Eigen::Matrix<double, 2, 3>& A = texture_.photo_from_face;
    // The texture's coordinates q = A (s, t, 1) with s = (x - origin)·ŝ: q = Q x + q0.
    Eigen::Matrix<double, 2, 3> Q;
    Q.row(0) = A(0, 0) * s_.transpose() + A(0, 1) * t_.transpose();
    Q.row(1) = A(1, 0) * s_.transpose() + A(1, 1) * t_.transpose();
    const Eigen::Vector2d q0 = A.col(2) - Q * origin_;
    const float q00 = float(Q(0, 0)), q01 = float(Q(0, 1)), q02 = float(Q(0, 2)),
                q10 = float(Q(1, 0)), q11 = float(Q(1, 1)), q12 = float(Q(1, 2));
    const float qx0 = float(q0.x()), qy0 = float(q0.y());
    const float nx = float(normal_.x()), ny = float(normal_.y()), nz = float(normal_.z());
    const float lx = float(lighting_.light.x()), ly = float(lighting_.light.y()),
                lz = float(lighting_.light.z());
    const float ambient = float(lighting_.ambient), specular = float(lighting_.specular);
    const float base = float(texture_.base), gain = float(texture_.gain),
                mean = float(texture_.mean), white = float(kWhite);
    const float offset = float(offset_), y = float(b);
    // n · r(u) = along0 + u along_du (pinhole); z(u) = z0 + u z_du (orthographic).
    const double along0 = normal_.x() * a + normal_.y() * b + normal_.z();
    const double along_du = normal_.x() * k;
    const double z0 = (offset_ - normal_.x() * a - normal_.y() * b) / normal_.z();
    const double z_du = -normal_.x() * k / normal_.z();
    constexpr int kChunk = 64;
    float qx[kChunk], qy[kChunk], lit[kChunk], facing[kChunk];
    for (int c = u0; c < u1; c += kChunk) {
      const int n = std::min(kChunk, u1 - c);
      const float x0 = float(a + c * k), dx = float(k);
      const float start = float(pinhole ? along0 + c * along_du : z0 + c * z_du);
      const float step = float(pinhole ? along_du : z_du);
      const Chunk chunk{n,   x0,  dx,  y,   start, step, offset, q00, q01, q02, qx0,
                        q10, q11, q12, qy0, nx,    ny,   nz,     lx,  ly,  lz,  ambient};
      if (pinhole) {
        Geometry<true>(chunk, qx, qy, lit, facing);
      } else {
        Geometry<false>(chunk, qx, qy, lit, facing);
      }
      for (int i = 0; i < n; ++i) {
        float albedo = base;
        if (photo_) albedo = std::clamp(base + gain * (Sample(qx[i], qy[i]) - mean), 0.02f, 0.98f);
        const float highlight = specular > 0 ? lighting_.Highlight(facing[i]) : 0.f;
        out[c - u0 + i] = white * (albedo * lit[i] + specular * highlight);
      }
    }
  }

 private:
  // One chunk of a row: its pixels' ray or origin (x0 + i dx, y), the face's n · r (pinhole) or
  // depth (orthographic) start + i step, the texture map and the light.
  struct Chunk {
    int n;
    float x0, dx, y, start, step, offset;
    float q00, q01, q02, qx0, q10, q11, q12, qy0;
    float nx, ny, nz, lx, ly, lz, ambient;
  };

  // The texture's coordinates, the diffuse share (ambient included) and n · h where the face
  // is lit (0 elsewhere), for each pixel of the chunk; without branches, so vectorised.
  template <bool kPinhole>
  static void Geometry(const Chunk& c, float* qx, float* qy, float* lit, float* facing) {
    for (int i = 0; i < c.n; ++i) {
      const float x = c.x0 + i * c.dx, w = c.start + i * c.step;
      float px, py, pz, vx, vy, vz;
      if constexpr (kPinhole) {
        const float z = c.offset / w;
        px = z * x;
        py = z * c.y;
        pz = z;
        const float inverse = 1 / std::sqrt(x * x + c.y * c.y + 1);
        vx = -x * inverse;
        vy = -c.y * inverse;
        vz = -inverse;
      } else {
        px = x;
        py = c.y;
        pz = w;
        vx = vy = 0;
        vz = -1;
      }
      qx[i] = c.q00 * px + c.q01 * py + c.q02 * pz + c.qx0;
      qy[i] = c.q10 * px + c.q11 * py + c.q12 * pz + c.qy0;
      float dx = c.lx - px, dy = c.ly - py, dz = c.lz - pz;
      const float inverse = 1 / std::sqrt(dx * dx + dy * dy + dz * dz);
      dx *= inverse;
      dy *= inverse;
      dz *= inverse;
      const float diffuse = c.nx * dx + c.ny * dy + c.nz * dz;
      lit[i] = c.ambient + (1 - c.ambient) * std::max(0.f, diffuse);
      const float hx = dx + vx, hy = dy + vy, hz = dz + vz;
      const float cosine =
          (c.nx * hx + c.ny * hy + c.nz * hz) / std::sqrt(hx * hx + hy * hy + hz * hz + 1e-20f);
      facing[i] = diffuse > 0 ? cosine : 0.f;
    }
  }

  // The photograph's bilinear interpolation, clamped at its border.
  float Sample(float x, float y) const {
    const GrayImage& p = *photo_;
    x = std::clamp(x, 0.f, p.width - 1.001f);
    y = std::clamp(y, 0.f, p.height - 1.001f);
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const float fx = x - x0, fy = y - y0;
    const std::uint8_t* a = p.pixels.data() + static_cast<size_t>(y0) * p.width + x0;
    const std::uint8_t* b = a + p.width;
    const float top = a[0] + fx * (a[1] - a[0]), bottom = b[0] + fx * (b[1] - b[0]);
    return top + fy * (bottom - top);
  }

  const Camera& camera_;
  const Lighting& lighting_;
  const FaceTexture& texture_;
  const GrayImage* photo_ = nullptr;
  Eigen::Vector3d normal_, origin_, s_, t_;
  double offset_ = 0;  // normal · x = offset on the face's plane
};

// The faces' textures, indexed by component and face.
class TextureTable {
 public:
  explicit TextureTable(const ConstraintGraph& graph, std::vector<FaceTexture> textures)
      : textures_(std::move(textures)), first_(graph.components.size() + 1, 0) {
    for (size_t c = 0; c < graph.components.size(); ++c) {
      first_[c + 1] =
          first_[c] +
          (graph.components[c].rigid ? static_cast<int>(graph.components[c].faces.size()) : 0);
    }
  }
  int Index(int component, int face) const { return first_[component] + face; }
  const FaceTexture& At(int component, int face) const { return textures_[Index(component, face)]; }
  int size() const { return first_.back(); }

 private:
  std::vector<FaceTexture> textures_;
  std::vector<int> first_;
};

// The z-buffered faces of one configuration: the buffers (ids as component * kFaceStride +
// face) cover `box`, and each face drawn has its shader.
struct Layer {
  cv::Rect box;
  std::vector<ViewedFace> faces;
  std::vector<std::unique_ptr<FaceShader>> shaders;  // by TextureTable::Index; null: not drawn
  const TextureTable* table = nullptr;

  const FaceShader* ShaderOf(int id) const {
    return shaders[table->Index(id / kFaceStride, id % kFaceStride)].get();
  }
};

// Fills `depth` and `face` with the front faces of `values` (over their bounding box, which it
// first clears) and makes their shaders.
Layer Rasterise(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                const TextureTable& table, const std::vector<GrayImage>& photographs,
                const Lighting& lighting, cv::Mat1f& depth, cv::Mat1i& face) {
  Layer layer;
  layer.table = &table;
  layer.shaders.resize(table.size());
  layer.faces = FrontFaces(graph, values, camera);
  double left = std::numeric_limits<double>::infinity(), top = left, right = -left, bottom = -left;
  for (const ViewedFace& f : layer.faces) {
    for (const Eigen::Vector2d& p : f.polygon) {
      left = std::min(left, p.x());
      right = std::max(right, p.x());
      top = std::min(top, p.y());
      bottom = std::max(bottom, p.y());
    }
  }
  if (!(left <= right && top <= bottom)) return layer;
  // Every pixel whose centre a face may cover.
  const int u0 = static_cast<int>(std::clamp(std::floor(left), 0.0, double(depth.cols)));
  const int u1 = static_cast<int>(std::clamp(std::ceil(right) + 1, 0.0, double(depth.cols)));
  const int v0 = static_cast<int>(std::clamp(std::floor(top), 0.0, double(depth.rows)));
  const int v1 = static_cast<int>(std::clamp(std::ceil(bottom) + 1, 0.0, double(depth.rows)));
  if (u0 >= u1 || v0 >= v1) return layer;
  layer.box = cv::Rect(u0, v0, u1 - u0, v1 - v0);
  depth(layer.box).setTo(std::numeric_limits<float>::infinity());
  face(layer.box).setTo(-1);
  const RayCaster rays{camera};
  const bool orthographic = camera.model == Camera::Model::kOrthographic;
  for (const ViewedFace& f : layer.faces) {
    const Component& c = graph.components[f.component];
    const Rigid3d& pose = values.poses[graph.blocks[c.block].index];
    const FacePlane plane = FaceFrame(c, f.face);
    if (!plane.valid) continue;
    layer.shaders[table.Index(f.component, f.face)] = std::make_unique<FaceShader>(
        f, plane, pose, table.At(f.component, f.face), photographs, lighting, camera);
    const int id = f.component * kFaceStride + f.face;
    // The face's depth along a row: offset / (n · ray(u)) for a pinhole camera, linear in u
    // for an orthographic one (RayCaster::DepthOnPlane, a row at a time).
    const double offset = f.normal.dot(f.corners[0]);
    ForEachSpan(f.polygon, depth.cols, depth.rows, [&](int v, int a, int b) {
      const Eigen::Vector3d r0 = rays.Ray(0, v), r1 = rays.Ray(1, v);
      const double start = f.normal.dot(r0), step = f.normal.dot(r1) - start;
      float* z = depth.ptr<float>(v);
      int* ids = face.ptr<int>(v);
      for (int u = a; u < b; ++u) {
        double d;
        if (orthographic) {
          d = (offset - start - u * step) / f.normal.z();
        } else {
          const double along = start + u * step;
          d = std::abs(along) < 1e-12 ? std::numeric_limits<double>::quiet_NaN() : offset / along;
        }
        if (!(d < z[u])) continue;
        z[u] = static_cast<float>(d);
        ids[u] = id;
      }
    });
  }
  return layer;
}

// The image-sized buffers of one rendering, kept from call to call on each thread: fresh ones
// cost more in page faults (about 0.5 ms each at 640 x 480) than all of the shading.
struct Workspace {
  cv::Mat1b warped;
  cv::Mat1f background, image, clean, front, depth, sub_depth, change;
  cv::Mat1i face, sub_face;
};

// The photograph behind the object (render.h), with the clutter over it, into `out`.
void Background(const std::vector<GrayImage>& photographs, const RenderOptions& options, int w,
                int h, cv::Mat1b& warped, cv::Mat1f& out) {
  const RealisticOptions& ro = options.realistic;
  std::mt19937 look(ro.look_seed * 0x9E3779B1u + 0x51ED27u);
  auto uniform = [&](double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(look);
  };
  const GrayImage& photo = photographs[look() % photographs.size()];
  const double angle = uniform(-0.2, 0.2);
  const double zoom = uniform(1.0, 1.6);
  const double brightness = uniform(0.55, 0.95);
  const double c = std::abs(std::cos(angle)), s = std::abs(std::sin(angle));
  // Photograph pixels per image pixel: the turned image fits inside the photograph, with 3 %
  // to spare for the shake.
  const double scale =
      std::min(photo.width / (w * c + h * s), photo.height / (w * s + h * c)) / (zoom * 1.03);
  const double slack_x = std::max(0.0, 0.5 * (photo.width - scale * (w * c + h * s) * 1.03));
  const double slack_y = std::max(0.0, 0.5 * (photo.height - scale * (w * s + h * c) * 1.03));
  const Eigen::Vector2d centre(0.5 * photo.width + uniform(-slack_x, slack_x),
                               0.5 * photo.height + uniform(-slack_y, slack_y));
  const double turn = angle + ro.camera_shake.z();
  Eigen::Matrix2d rotation;
  rotation << std::cos(turn), -std::sin(turn), std::sin(turn), std::cos(turn);
  // photo = centre + scale R (image - image centre - shake)
  const Eigen::Matrix2d linear = scale * rotation;
  const Eigen::Vector2d shift =
      centre - linear * (Eigen::Vector2d(0.5 * w, 0.5 * h) + ro.camera_shake.head<2>());
  const cv::Matx23d image_to_photo(linear(0, 0), linear(0, 1), shift.x(), linear(1, 0),
                                   linear(1, 1), shift.y());
  const cv::Mat source(photo.height, photo.width, CV_8U,
                       const_cast<std::uint8_t*>(photo.pixels.data()));
  cv::warpAffine(source, warped, image_to_photo, cv::Size(w, h),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT101);
  // The clutter is part of the scene: drawn from the look, it stays put while the frames'
  // seeds advance, and sways with the background.
  std::mt19937 clutter(ro.look_seed * 7919u + 3u);
  DrawClutter(warped, options.clutter_lines, options.clutter_blobs, clutter,
              cv::Point(static_cast<int>(std::lround(ro.camera_shake.x())),
                        static_cast<int>(std::lround(ro.camera_shake.y()))));
  warped.convertTo(out, CV_32F, brightness, 8);
}

// Darkens the background by the object's silhouette (the face buffer's faces) moved away from
// the light and blurred: a soft shadow, worked at a quarter of the resolution.
void CastShadow(const cv::Mat1i& face, const cv::Rect& box, const std::vector<ViewedFace>& faces,
                const Camera& camera, const RealisticOptions& ro, cv::Mat1f& background) {
  if (ro.shadow <= 0 || box.empty() || faces.empty()) return;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  int n = 0;
  for (const ViewedFace& f : faces) {
    for (const Eigen::Vector3d& p : f.corners) centre += p, ++n;
  }
  centre /= n;
  const Eigen::Vector3d away = 0.05 * centre.norm() * (centre - ro.light).normalized();
  Eigen::Vector2d direction =
      camera.Project<double>(Eigen::Vector3d(centre + away)) - camera.Project<double>(centre);
  direction = direction.allFinite() && direction.norm() > 1e-9 ? direction.normalized()
                                                               : Eigen::Vector2d(0, 1);
  const double size = std::hypot(box.width, box.height);
  const double sigma = std::max(1.5, 0.04 * size);
  const Eigen::Vector2d offset = 0.06 * size * direction;
  constexpr int kReduce = 4;
  // The reduced silhouette (the share of each 4 x 4 block's pixels on the object), placed
  // `offset` on, with room for the blur all round.
  const int margin = static_cast<int>(std::ceil(3 * sigma / kReduce)) + 1;
  const int sx = static_cast<int>(std::lround(offset.x() / kReduce)),
            sy = static_cast<int>(std::lround(offset.y() / kReduce));
  const int bw = (box.width + kReduce - 1) / kReduce, bh = (box.height + kReduce - 1) / kReduce;
  cv::Mat1f small(bh + 2 * margin, bw + 2 * margin, 0.f);
  for (int v = box.y; v < box.y + box.height; ++v) {
    const int* ids = face.ptr<int>(v);
    const int i = (v - box.y) / kReduce + margin + sy;
    if (i < 0 || i >= small.rows) continue;
    float* row = small.ptr<float>(i);
    for (int u = box.x; u < box.x + box.width; ++u) {
      const int j = (u - box.x) / kReduce + margin + sx;
      if (ids[u] >= 0 && j >= 0 && j < small.cols) row[j] += 1.f / (kReduce * kReduce);
    }
  }
  cv::GaussianBlur(small, small, cv::Size(0, 0), sigma / kReduce, sigma / kReduce,
                   cv::BORDER_CONSTANT);
  // Back at full resolution, interpolated: small's pixel (i, j) covers the block whose centre
  // is at box.x - margin * 4 + 4 j + 1.5 (and the same in v).
  const double x0 = box.x - margin * kReduce + 1.5, y0 = box.y - margin * kReduce + 1.5;
  const int u_lo = std::max(0, static_cast<int>(x0)),
            u_hi = std::min(background.cols, static_cast<int>(x0 + kReduce * (small.cols - 1)));
  const int v_lo = std::max(0, static_cast<int>(y0)),
            v_hi = std::min(background.rows, static_cast<int>(y0 + kReduce * (small.rows - 1)));
  const float depth = static_cast<float>(ro.shadow);
  std::vector<int> column(std::max(0, u_hi - u_lo));
  std::vector<float> weight(column.size());
  for (int u = u_lo; u < u_hi; ++u) {
    const double x = (u - x0) / kReduce;
    column[u - u_lo] = std::clamp(static_cast<int>(x), 0, small.cols - 2);
    weight[u - u_lo] = static_cast<float>(x - column[u - u_lo]);
  }
  for (int v = v_lo; v < v_hi; ++v) {
    const double y = (v - y0) / kReduce;
    const int i = std::clamp(static_cast<int>(y), 0, small.rows - 2);
    const float fy = static_cast<float>(y - i);
    const float* top = small.ptr<float>(i);
    const float* bottom = small.ptr<float>(i + 1);
    float* out = background.ptr<float>(v) + u_lo;
    for (size_t k = 0; k < column.size(); ++k) {
      const int j = column[k];
      const float upper = top[j] + weight[k] * (top[j + 1] - top[j]);
      const float lower = bottom[j] + weight[k] * (bottom[j + 1] - bottom[j]);
      out[k] *= 1 - depth * std::min(1.f, upper + fy * (lower - upper));
    }
  }
}

// Shades the pixels of `layer`'s faces (ids in `face` over its box) into `image`, or, with
// `accumulate`, adds their radiance less the background's to it.
void Shade(const Layer& layer, const cv::Mat1i& face, const cv::Mat1f& background, bool accumulate,
           cv::Mat1f& image) {
  std::vector<float> radiance(layer.box.width);
  const int right = layer.box.x + layer.box.width;
  for (int v = layer.box.y; v < layer.box.y + layer.box.height; ++v) {
    const int* ids = face.ptr<int>(v);
    const float* behind = background.ptr<float>(v);
    float* out = image.ptr<float>(v);
    for (int u = layer.box.x; u < right;) {
      if (ids[u] < 0) {
        ++u;
        continue;
      }
      int end = u + 1;
      while (end < right && ids[end] == ids[u]) ++end;
      layer.ShaderOf(ids[u])->Row(v, u, end, radiance.data());
      for (int x = u; x < end; ++x) {
        out[x] = accumulate ? out[x] + radiance[x - u] - behind[x] : radiance[x - u];
      }
      u = end;
    }
  }
}

// Hands and occluders over `image`: they hide what is behind them in the buffers, and `front`
// keeps what they show, for the truth.
void DrawFront(const RenderOptions& options, cv::Mat1f& image, cv::Mat1f& depth, cv::Mat1i& face,
               cv::Mat1f& front) {
  const int w = image.cols, h = image.rows;
  for (const HandOccluder& hand : options.hands) {
    ForEachHandPixel(hand, w, h, [&](int u, int v, float coverage, float shade) {
      float& pixel = image(v, u);
      pixel += coverage * (static_cast<float>(kWhite * kSkinAlbedo) * shade - pixel);
      if (coverage >= 0.5f) {
        face(v, u) = kOccluder;
        depth(v, u) = 0;
        front(v, u) = pixel;
      }
    });
  }
  for (const std::vector<Eigen::Vector2d>& polygon : options.occluders) {
    if (polygon.size() < 3) continue;
    const float grey = static_cast<float>(options.occluder_grey);
    ForEachSpan(polygon, w, h, [&](int v, int a, int b) {
      for (int u = a; u < b; ++u) {
        image(v, u) = front(v, u) = grey;
        face(v, u) = kOccluder;
        depth(v, u) = 0;
      }
    });
  }
}

// The sensor (render.h): read and shot noise, clipping, 8 bits.
std::vector<std::uint8_t> Sensor(const cv::Mat1f& signal, const RenderOptions& options) {
  const int w = signal.cols, h = signal.rows;
  const float read = static_cast<float>(options.noise * options.noise);
  const float gain = static_cast<float>(std::max(0.0, options.realistic.gain));
  cv::Mat1f normal(1, w);
  cv::RNG rng(options.seed * 7919u + 17u);
  std::vector<std::uint8_t> out(static_cast<size_t>(w) * h);
  for (int v = 0; v < h; ++v) {
    rng.fill(normal, cv::RNG::NORMAL, 0, 1);
    const float* s = signal.ptr<float>(v);
    const float* z = normal.ptr<float>(0);
    std::uint8_t* o = out.data() + static_cast<size_t>(v) * w;
    for (int u = 0; u < w; ++u) {
      const float value = s[u] + z[u] * std::sqrt(read + gain * std::clamp(s[u], 0.f, 255.f));
      o[u] = static_cast<std::uint8_t>(std::clamp(value, 0.f, 255.f) + 0.5f);  // rounded
    }
  }
  return out;
}

void CheckPhotographs(const std::vector<GrayImage>& photographs) {
  for (size_t i = 0; i < photographs.size(); ++i) {
    const GrayImage& p = photographs[i];
    if (p.width < 32 || p.height < 32 ||
        p.pixels.size() != static_cast<size_t>(p.width) * p.height) {
      throw InputError(SourceLocation(),
                       "photograph " + std::to_string(i) + " (" + std::to_string(p.width) +
                           " x " + std::to_string(p.height) + " pixels, " +
                           std::to_string(p.pixels.size()) +
                           " given) is not a grey image of at least 32 x 32 pixels");
    }
  }
}

}  // namespace

Rendering RenderRealistic(const ConstraintGraph& graph, const Values& values, const Camera& camera,
                          const RenderOptions& options) {
  const RealisticOptions& ro = options.realistic;
  const int w = camera.width, h = camera.height;
  std::vector<GrayImage> procedural;
  const std::vector<GrayImage>* photographs = ro.photographs.get();
  if (!photographs || photographs->empty()) {
    procedural = ProceduralPhotographs(ro.look_seed);
    photographs = &procedural;
  }
  CheckPhotographs(*photographs);
  const TextureTable table(graph,
                           FaceTextures(graph, *photographs, ro.look_seed, ro.texture_contrast));
  Lighting lighting;
  lighting.light = ro.light;
  lighting.ambient = std::clamp(ro.ambient, 0.0, 1.0);
  lighting.specular = std::max(0.0, ro.specular);
  lighting.shininess = std::max(1.0, ro.shininess);
  lighting.Tabulate();

  thread_local Workspace work;
  cv::Mat1f& background = work.background;
  Background(*photographs, options, w, h, work.warped, background);
  cv::Mat1f& depth = work.depth;
  cv::Mat1i& face = work.face;
  depth.create(h, w);
  face.create(h, w);
  depth.setTo(std::numeric_limits<float>::infinity());
  face.setTo(-1);
  const Layer frame = Rasterise(graph, values, camera, table, *photographs, lighting, depth, face);
  CastShadow(face, frame.box, frame.faces, camera, ro, background);

  cv::Mat1f& image = work.image;
  background.copyTo(image);
  Shade(frame, face, background, false, image);
  // The truth's contrast is the sharp image's at `values`. With an exposure, the image becomes
  // the background plus the mean of what each instant's faces change, each instant z-buffered
  // alone, and the sharp one is kept aside.
  const cv::Mat1f* clean = &image;
  if (!ro.exposure.empty()) {
    std::swap(work.image, work.clean);
    clean = &work.clean;
    work.sub_depth.create(h, w);
    work.sub_face.create(h, w);
    work.change.create(h, w);
    work.change.setTo(0);
    for (const Values& config : ro.exposure) {
      const Layer layer = Rasterise(graph, config, camera, table, *photographs, lighting,
                                    work.sub_depth, work.sub_face);
      Shade(layer, work.sub_face, background, true, work.change);
    }
    cv::scaleAdd(work.change, 1.0 / static_cast<double>(ro.exposure.size()), background, image);
  }
  cv::Mat1f& front = work.front;
  if (!options.hands.empty() || !options.occluders.empty()) front.create(h, w);
  DrawFront(options, image, depth, face, front);

  auto side_mean = [&](const Eigen::Vector2d& uv, const Eigen::Vector2d& across,
                       const Eigen::Vector2d& along, double* mean) {
    double sum = 0;
    int n = 0;
    for (double a : {1.5, 3.0}) {
      for (double b : {-1.5, 0.0, 1.5}) {
        const Eigen::Vector2d p = uv + a * across + b * along;
        const int u = static_cast<int>(std::lround(p.x())),
                  v = static_cast<int>(std::lround(p.y()));
        if (u < 0 || v < 0 || u >= w || v >= h) continue;
        sum += face(v, u) == kOccluder ? front(v, u) : (*clean)(v, u);
        ++n;
      }
    }
    if (n == 0) return false;
    *mean = sum / n;
    return true;
  };
  Rendering out;
  out.width = w;
  out.height = h;
  out.truth = VisibleTruth(
      graph, values, camera, depth, face,
      [&](const Eigen::Vector2d& uv, const Eigen::Vector2d& normal) {
        const Eigen::Vector2d along(-normal.y(), normal.x());
        double one = 0, other = 0;
        if (!side_mean(uv, normal, along, &one) || !side_mean(uv, -normal, along, &other)) {
          return false;
        }
        return std::abs(one - other) < options.min_contrast;
      });

  if (options.blur > 0) {
    cv::GaussianBlur(image, image, cv::Size(0, 0), options.blur, options.blur,
                     cv::BORDER_REPLICATE);
  }
  out.pixels = Sensor(image, options);
  return out;
}

}  // namespace cfuse::internal
