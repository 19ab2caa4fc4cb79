#include "calib/synthetic_boards.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "core/error.h"
#include "core/image_io.h"

namespace lp {
namespace {

constexpr float kBlack = 0.08f, kWhite = 0.92f, kBackground = 0.5f, kOutside = 0.0f;

struct Pose {
  Mat3 R;  // camera_from_board: columns are the board axes in the camera frame
  Vec3 t;
};

Vec3 column(const Mat3& R, int c) { return {R(0, c), R(1, c), R(2, c)}; }

// Rotation about unit axis a by angle t (radians).
Mat3 axis_angle(Vec3 a, double t) {
  const double c = std::cos(t), s = std::sin(t), C = 1 - c;
  return {{c + a.x * a.x * C, a.x * a.y * C - a.z * s, a.x * a.z * C + a.y * s,
           a.y * a.x * C + a.z * s, c + a.y * a.y * C, a.y * a.z * C - a.x * s,
           a.z * a.x * C - a.y * s, a.z * a.y * C + a.x * s, c + a.z * a.z * C}};
}

struct Scene {
  BoardSpec board;
  Pose pose;
  double max_angle = M_PI;  // rays beyond this angle from +z are outside the lens

  // Brightness where the camera ray `ray` lands.
  float shade(Vec3 ray) const {
    if (std::atan2(std::hypot(ray.x, ray.y), ray.z) > max_angle) return kOutside;
    const Vec3 n = column(pose.R, 2);
    const double denom = dot(n, ray);
    if (std::fabs(denom) < 1e-12) return kBackground;
    const double lambda = dot(n, pose.t) / denom;
    if (lambda <= 0) return kBackground;
    const Vec3 q = transpose(pose.R) * (lambda * ray - pose.t);
    const double s = board.square_mm;
    const double X = q.x / s, Y = q.y / s;  // in squares; inner corners at integers
    if (X >= -1 && X < board.cols && Y >= -1 && Y < board.rows) {
      const long i = static_cast<long>(std::floor(X)) + 1, j = static_cast<long>(std::floor(Y)) + 1;
      return ((i + j) % 2 == 0) ? kBlack : kWhite;
    }
    if (X >= -2 && X < board.cols + 1 && Y >= -2 && Y < board.rows + 1) return kWhite;
    return kBackground;
  }
};

double angle_of(Vec3 d) { return std::atan2(std::hypot(d.x, d.y), d.z); }

// What every view of a synthetic set shares: the lens, the rays through every pixel corner,
// the board points that must be imaged.
struct Renderer {
  const SyntheticBoardsOptions& options;
  const LensFunctions& lens;
  int W = 0, H = 0, GW = 0, GH = 0;
  double max_angle = M_PI;
  std::vector<Vec3> rays;  // through pixel corners (x - 0.5, y - 0.5), x in [0, W], y in [0, H]
  std::vector<uint8_t> ray_ok;
  std::vector<Vec3> must_see;  // the inner corners (first), then the outline of the white margin

  Renderer(const SyntheticBoardsOptions& o, const LensFunctions& l) : options(o), lens(l) {
    W = o.camera.width;
    H = o.camera.height;
    GW = W + 1;
    GH = H + 1;
    max_angle = o.field_deg > 0 ? 0.5 * o.field_deg * M_PI / 180 : M_PI;
    // Rays inside a pixel are bilinear between its four corners (the lens is smooth at
    // this scale).
    rays.resize(static_cast<size_t>(GW) * GH);
    ray_ok.resize(rays.size());
    cv::parallel_for_(cv::Range(0, GH), [&](const cv::Range& range) {
      for (int y = range.start; y < range.end; ++y)
        for (int x = 0; x < GW; ++x) {
          const auto r = lens.unproject(Pixel{x - 0.5, y - 0.5});
          const size_t k = static_cast<size_t>(y) * GW + x;
          ray_ok[k] = r.has_value();
          if (r) rays[k] = *r;
        }
    });
    const BoardSpec& board = o.board;
    const double s = board.square_mm;
    for (int r = 0; r < board.rows; ++r)
      for (int c = 0; c < board.cols; ++c) must_see.push_back({c * s, r * s, 0});
    for (int k = 0; k <= 20; ++k) {
      const double u = k / 20.0;
      const double x0 = -2 * s, x1 = (board.cols + 1) * s, y0 = -2 * s, y1 = (board.rows + 1) * s;
      must_see.push_back({x0 + u * (x1 - x0), y0, 0});
      must_see.push_back({x0 + u * (x1 - x0), y1, 0});
      must_see.push_back({x0, y0 + u * (y1 - y0), 0});
      must_see.push_back({x1, y0 + u * (y1 - y0), 0});
    }
  }

  // Angle spanned by the central `fraction` of the image width (through the centre row).
  double width_angle(double fraction) const {
    const double cx = 0.5 * (W - 1), cy = 0.5 * (H - 1);
    const auto a = lens.unproject(Pixel{cx - 0.5 * fraction * W, cy});
    const auto b = lens.unproject(Pixel{cx + 0.5 * fraction * W, cy});
    if (!a || !b) return 0.0;
    return angle_between(normalize(*a), normalize(*b));
  }

  // A random pose (see the header) with every must-see point imaged inside the image and the
  // board facing the camera at every corner; false after 20000 tries.
  bool place(std::mt19937_64& rng, Pose& pose, std::vector<std::array<double, 2>>& corners) const {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const BoardSpec& board = options.board;
    const double s = board.square_mm;
    const Vec3 centre_board{0.5 * (board.cols - 1) * s, 0.5 * (board.rows - 1) * s, 0};
    for (int attempt = 0; attempt < 20000; ++attempt) {
      const auto dir = lens.unproject(Pixel{uni(rng) * (W - 1), uni(rng) * (H - 1)});
      const double cover = options.min_cover + uni(rng) * (options.max_cover - options.min_cover);
      const double tilt =
          (options.min_tilt_deg + uni(rng) * (options.max_tilt_deg - options.min_tilt_deg)) * M_PI / 180;
      const double spin = uni(rng) * 2 * M_PI, tilt_axis_angle = uni(rng) * 2 * M_PI;
      if (!dir || angle_of(*dir) > max_angle) continue;
      const double alpha = width_angle(cover);
      if (!(alpha > 0) || alpha >= M_PI * 0.95) continue;
      const Vec3 z = normalize(*dir);  // board normal, facing away from the camera
      const Vec3 helper = std::fabs(z.y) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
      const Vec3 x0 = normalize(cross(helper, z));
      const Vec3 y0 = cross(z, x0);
      const Mat3 facing{{x0.x, y0.x, z.x, x0.y, y0.y, z.y, x0.z, y0.z, z.z}};
      const Vec3 tilt_axis = std::cos(tilt_axis_angle) * x0 + std::sin(tilt_axis_angle) * y0;
      pose.R = axis_angle(tilt_axis, tilt) * facing * axis_angle({0, 0, 1}, spin);
      const double board_width = (board.cols + 1) * s;
      const double distance = 0.5 * board_width / std::tan(0.5 * alpha);
      pose.t = distance * z - pose.R * centre_board;
      if (!visible(pose)) continue;
      corners.clear();
      for (int k = 0; k < board.rows * board.cols; ++k) {
        const auto px = lens.project(pose.R * must_see[k] + pose.t);
        corners.push_back({px->x, px->y});
      }
      return true;
    }
    return false;
  }

  bool visible(const Pose& pose) const {
    for (const Vec3& p : must_see) {
      const Vec3 pc = pose.R * p + pose.t;
      const auto px = lens.project(pc);
      if (!px || angle_of(pc) > max_angle - 0.01 || px->x < 3 || px->y < 3 || px->x > W - 4 || px->y > H - 4)
        return false;
    }
    // The board must face the camera at every corner (no grazing views beyond 80 deg).
    const Vec3 n = column(pose.R, 2);
    for (int k = 0; k < options.board.rows * options.board.cols; ++k) {
      const Vec3 pc = pose.R * must_see[k] + pose.t;
      if (std::fabs(dot(n, normalize(pc))) < std::cos(80 * M_PI / 180)) return false;
    }
    return true;
  }

  // The view of the board at `pose`: shade at every pixel corner; pixels whose corners agree
  // are flat, others supersampled 4x4; then blur.
  cv::Mat render(const Pose& pose) const {
    Scene scene{options.board, pose, max_angle};
    std::vector<float> node(rays.size());
    for (size_t k = 0; k < rays.size(); ++k) node[k] = ray_ok[k] ? scene.shade(rays[k]) : kOutside;
    cv::Mat img(H, W, CV_32F);
    cv::parallel_for_(cv::Range(0, H), [&](const cv::Range& range) {
      for (int y = range.start; y < range.end; ++y) {
        float* row = img.ptr<float>(y);
        for (int x = 0; x < W; ++x) {
          const size_t k00 = static_cast<size_t>(y) * GW + x, k01 = k00 + 1, k10 = k00 + GW, k11 = k10 + 1;
          const float v = node[k00];
          if (node[k01] == v && node[k10] == v && node[k11] == v) {
            row[x] = v;
            continue;
          }
          if (!(ray_ok[k00] && ray_ok[k01] && ray_ok[k10] && ray_ok[k11])) {
            row[x] = 0.25f * (node[k00] + node[k01] + node[k10] + node[k11]);
            continue;
          }
          double sum = 0;
          for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 4; ++i) {
              const double u = (i + 0.5) / 4, w = (j + 0.5) / 4;
              const Vec3 r = (1 - w) * ((1 - u) * rays[k00] + u * rays[k01]) + w * ((1 - u) * rays[k10] + u * rays[k11]);
              sum += scene.shade(r);
            }
          row[x] = static_cast<float>(sum / 16);
        }
      }
    });
    if (options.blur_px > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), options.blur_px);
    return img;
  }
};

// 8-bit-style camera image of a rendered view with Gaussian noise (drawn from `rng`).
CameraImage to_camera_image(const cv::Mat& img, double noise_sigma, std::mt19937_64& rng) {
  const int W = img.cols, H = img.rows;
  CameraImage image;
  image.width = W;
  image.height = H;
  image.bit_depth = 8;
  image.rgb.resize(static_cast<size_t>(W) * H * 3);
  std::normal_distribution<double> noise(0.0, noise_sigma > 0 ? noise_sigma : 1.0);
  for (int y = 0; y < H; ++y) {
    const float* row = img.ptr<float>(y);
    for (int x = 0; x < W; ++x) {
      double v = row[x];
      if (noise_sigma > 0) v += noise(rng);
      const float f = static_cast<float>(std::clamp(v, 0.0, 1.0));
      float* p = &image.rgb[(static_cast<size_t>(y) * W + x) * 3];
      p[0] = p[1] = p[2] = f;
    }
  }
  return image;
}

}  // namespace

SyntheticBoards synthesize_boards(const SyntheticBoardsOptions& options, const LensFunctions& lens) {
  const BoardSpec& board = options.board;
  const int W = options.camera.width, H = options.camera.height;
  if (options.views < 1) throw InputError("synth boards: views must be >= 1");
  if (board.cols < 3 || board.rows < 3 || !(board.square_mm > 0))
    throw InputError("synth boards: board needs >= 3x3 inner corners and a positive square size");
  if (W < 16 || H < 16) throw InputError("synth boards: camera model has no image size");
  // Taken as given, a negative or NaN noise, blur or field made images the truth does not
  // describe (NaN noise: images of NaN codes), with exit 0.
  if (!(options.noise_sigma >= 0)) throw InputError(fmt::format("synth boards: --noise must be 0 or more, got {}", options.noise_sigma));
  if (!(options.blur_px >= 0)) throw InputError(fmt::format("synth boards: blur must be 0 or more, got {}", options.blur_px));
  if (!(options.field_deg >= 0 && options.field_deg <= 360))
    throw InputError(fmt::format("synth boards: --fov must be in [0, 360] degrees (0: the model's own), got {}", options.field_deg));
  if (!lens.project || !lens.unproject) throw InputError("synth boards: lens functions missing");

  const Renderer renderer(options, lens);
  std::mt19937_64 rng(options.seed);
  SyntheticBoards out;
  for (int view = 0; view < options.views; ++view) {
    Pose pose;
    std::vector<std::array<double, 2>> corners;
    if (!renderer.place(rng, pose, corners))
      throw InputError("synth boards: could not place the board " + std::to_string(view + 1) +
                       " in the camera's view");
    const cv::Mat img = renderer.render(pose);
    cv::Mat R(3, 3, CV_64F), rvec;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R.at<double>(r, c) = pose.R(r, c);
    cv::Rodrigues(R, rvec);
    out.images.push_back(to_camera_image(img, options.noise_sigma, rng));
    out.true_corners.push_back(std::move(corners));
    out.poses.push_back({rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2), pose.t.x, pose.t.y, pose.t.z});
  }
  return out;
}

void write_synthetic_boards(const std::string& dir, const SyntheticBoardsOptions& options,
                            const SyntheticBoards& boards) {
  namespace fs = std::filesystem;
  const CameraModel& camera = options.camera;
  make_output_directory(dir);
  nlohmann::json truth = {{"board", {options.board.cols, options.board.rows}}, {"square_mm", options.board.square_mm},
                          {"lensmodel", camera.lensmodel}, {"intrinsics", camera.intrinsics},
                          {"width", camera.width}, {"height", camera.height}};
  nlohmann::json views = nlohmann::json::array();
  for (size_t i = 0; i < boards.images.size(); ++i) {
    const std::string name = fmt::format("board_{:02d}.png", i);
    const CameraImage& image = boards.images[i];
    write_code_image((fs::path(dir) / name).string(), RgbImage{image.width, image.height, image.rgb, {}, Units::Relative}, 8);
    views.push_back({{"file", name}, {"corners", boards.true_corners[i]}, {"pose", boards.poses[i]}});
  }
  truth["views"] = views;
  write_file_atomically((fs::path(dir) / "truth.json").string(), truth.dump(1) + "\n");
  try {
    write_opencv_yaml((fs::path(dir) / "true_camera.yaml").string(), camera);
  } catch (const InputError&) {  // a lens model OpenCV has no name for
  }
}

}  // namespace lp

namespace lp {

std::vector<std::vector<std::array<double, 2>>> project_board_views(const CameraModel& cam, const BoardSpec& board,
                                                                    int nviews, double max_theta_deg,
                                                                    double distance, double noise_px, uint64_t seed,
                                                                    double max_corner_deg, const BoardWarp& warp) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise_px > 0 ? noise_px : 1.0);
  const double scale = noise_px > 0 ? 1.0 : 0.0;
  auto rotate = [](Vec3 axis, double angle, Vec3 v) {
    const double c = std::cos(angle), s = std::sin(angle);
    return c * v + s * cross(axis, v) + (1 - c) * dot(axis, v) * axis;
  };
  std::vector<std::vector<std::array<double, 2>>> out;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < nviews; ++i) {
    double theta = max_theta_deg * M_PI / 180 * std::sqrt((i + 0.5) / nviews);
    const double phi = i * golden;
    for (int attempt = 0; attempt < 40; ++attempt, theta *= 0.95) {
      const Vec3 dir = direction_from_angles(theta, phi);
      const Vec3 a = std::abs(dir.y) > 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
      Vec3 e1 = normalize(cross(a, dir));
      Vec3 e2 = cross(dir, e1);
      const Vec3 axis = normalize(std::cos(1.3 * i) * e1 + std::sin(1.3 * i) * e2);
      const double tilt = (15 + 20 * ((i * 7) % 5) / 4.0) * M_PI / 180;
      e1 = rotate(axis, tilt, e1);
      e2 = rotate(axis, tilt, e2);
      const double cx = (board.cols - 1) * board.square_mm / 2, cy = (board.rows - 1) * board.square_mm / 2;
      const Vec3 normal = cross(e1, e2);  // the board frame's z axis
      std::vector<std::array<double, 2>> v;
      bool inside = true;
      for (int k = 0; k < board.rows * board.cols && inside; ++k) {
        const int r = k / board.cols, c = k % board.cols;
        const Vec3 P = distance * dir + (c * board.square_mm - cx) * e1 + (r * board.square_mm - cy) * e2 +
                       board_warp_z(board, k, warp) * normal;
        const auto q = project(cam, P);
        inside = q && std::acos(P.z / length(P)) <= max_corner_deg * M_PI / 180 && q->x >= 2 && q->y >= 2 &&
                 q->x <= cam.width - 3 && q->y <= cam.height - 3;
        if (inside) v.push_back({q->x, q->y});
      }
      if (!inside) continue;
      for (auto& q : v) {
        q[0] += scale * gauss(rng);
        q[1] += scale * gauss(rng);
      }
      out.push_back(std::move(v));
      break;
    }
  }
  return out;
}

}  // namespace lp
