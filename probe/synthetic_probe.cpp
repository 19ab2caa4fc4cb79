#include "probe/synthetic_probe.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "probe/fisheye.h"

namespace lp {

RgbImage render_mirror_ball(const EnvMap& world, const BallInImage& ball, const MirrorBallCamera& camera,
                            int width, int height, const RenderBallOptions& options) {
  if (width <= 0 || height <= 0) throw InputError("render mirror ball: image size must be positive");
  if (options.samples_per_pixel_edge < 1) throw InputError("render mirror ball: samples_per_pixel_edge must be >= 1");
  if (world.pixel_count() == 0) throw InputError("render mirror ball: the map is empty");
  const MirrorBallProjection proj(ball, camera, width);
  RgbImage img;
  img.width = width;
  img.height = height;
  img.units = world.units;
  img.rgb.resize(3 * size_t(width) * height);
  const int k = options.samples_per_pixel_edge;
  const auto& bg = options.background;
  tbb::parallel_for(0, height, [&](int y) {
    for (int x = 0; x < width; ++x) {
      float* out = &img.rgb[3 * (size_t(y) * width + x)];
      // Pixels whose square misses the disc entirely.
      const double dx = std::max(0.0, std::abs(x + 0.5 - ball.cx) - 0.5);
      const double dy = std::max(0.0, std::abs(y + 0.5 - ball.cy) - 0.5);
      if (dx * dx + dy * dy > ball.radius_px * ball.radius_px) {
        for (int c = 0; c < 3; ++c) out[c] = bg[c];
        continue;
      }
      double sum[3] = {0, 0, 0};
      for (int j = 0; j < k; ++j)
        for (int i = 0; i < k; ++i) {
          const auto hit = proj.hit(x + (i + 0.5) / k, y + (j + 0.5) / k);
          if (!hit) {
            for (int c = 0; c < 3; ++c) sum[c] += bg[c];
            continue;
          }
          const auto p = pixel_at(world, hit->direction);
          if (!p || !world.is_valid(*p)) continue;
          const double f = proj.reflectivity(hit->cos_incidence);
          for (int c = 0; c < 3; ++c) sum[c] += f * world.pixel(*p)[c];
        }
      for (int c = 0; c < 3; ++c) out[c] = float(sum[c] / (k * k));
    }
  });
  if (options.noise_relative > 0 || options.noise_absolute > 0) {
    std::mt19937_64 rng(options.seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (float& v : img.rgb) {
      double nv = v * (1 + options.noise_relative * normal(rng));
      if (options.noise_absolute > 0) nv += options.noise_absolute * normal(rng);
      v = float(std::max(0.0, nv));
    }
  }
  return img;
}

RgbImage render_mirror_ball(const EnvMap& world, const BallInImage& ball, const MirrorBallCamera& camera,
                            int width, int height, int samples_per_pixel_edge) {
  RenderBallOptions options;
  options.samples_per_pixel_edge = samples_per_pixel_edge;
  return render_mirror_ball(world, ball, camera, width, height, options);
}

std::vector<BallInImage> jittered_track(BallInImage ball, int frames, double jitter_px, uint64_t seed) {
  if (frames < 0) throw InputError("jittered track: frames must be >= 0");
  if (!(jitter_px >= 0)) throw InputError("jittered track: jitter must be >= 0");
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<BallInImage> track(size_t(frames), ball);
  for (auto& b : track) {
    b.cx = ball.cx + jitter_px * normal(rng);
    b.cy = ball.cy + jitter_px * normal(rng);
  }
  return track;
}

nlohmann::json write_synthetic_probe(const EnvMap& world, const std::string& input_label,
                                     const SyntheticProbeOptions& o, const std::string& output) {
  const bool sequence = o.frames > 1;
  if (o.frames < 1) throw InputError("--frames must be at least 1");
  if (o.type != "mirrorball" && o.type != "fisheye")
    throw InputError(fmt::format("--type must be mirrorball or fisheye, got '{}'", o.type));
  if (o.type == "fisheye" && sequence) throw InputError("--frames applies to mirror balls only");
  // Ground truth says what it rendered: a negative or NaN radius or distance was taken for
  // the default, a negative noise flipped its sign, and the truth file said neither.
  if (!(o.radius_px >= 0)) throw InputError(fmt::format("--radius must be 0 (the default) or more, got {}", o.radius_px));
  if (!(o.distance_in_radii >= 0))
    throw InputError(fmt::format("--distance must be 0 (orthographic) or more, got {}", o.distance_in_radii));
  if (!(o.noise_relative >= 0)) throw InputError(fmt::format("--noise must be 0 or more, got {}", o.noise_relative));
  if (o.type == "fisheye" && !(o.fov_deg > 0 && o.fov_deg <= 360))
    throw InputError(fmt::format("--fov must be in (0, 360] degrees, got {}", o.fov_deg));
  if (!std::isfinite(o.noise_relative) || o.noise_relative > 1)  // inf wrote infinite pixels
    throw InputError(fmt::format("--noise must be a relative noise in [0, 1], got {}", o.noise_relative));
  // What the other probe type reads is refused: the fisheye render took a ball's options, and
  // the ball a fisheye's --fov, wrote the same image, and the truth file named neither.
  const SyntheticProbeOptions d;
  if (o.type == "fisheye") {
    for (const auto& [given, option] : {std::pair{o.radius_px != d.radius_px, "--radius"},
                                        std::pair{o.distance_in_radii != d.distance_in_radii, "--distance"},
                                        std::pair{o.noise_relative != d.noise_relative, "--noise"},
                                        std::pair{o.jitter_px != d.jitter_px, "--jitter"}, std::pair{o.seed != d.seed, "--seed"}})
      if (given) throw InputError(fmt::format("{} applies to --type mirrorball (the fisheye render is noiseless)", option));
  } else if (o.fov_deg != d.fov_deg) {
    throw InputError("--fov applies to --type fisheye (a ball's camera is --distance)");
  }
  if (!sequence && o.jitter_px != d.jitter_px) throw InputError("--jitter moves the ball between frames: give --frames");
  if (sequence) make_output_directory(output);
  nlohmann::json truth = {{"type", o.type}, {"input", input_label}, {"frames", o.frames}};
  nlohmann::json per_frame = nlohmann::json::array();
  if (o.type == "mirrorball") {
    const double r = o.radius_px > 0 ? o.radius_px : 0.4 * std::min(o.width, o.height);
    MirrorBallCamera camera;
    if (o.distance_in_radii > 0) camera.distance_in_radii = o.distance_in_radii;
    const auto track = jittered_track({o.width / 2.0, o.height / 2.0, r}, o.frames, sequence ? o.jitter_px : 0, o.seed);
    for (int f = 0; f < o.frames; ++f) {
      RenderBallOptions ro;
      ro.noise_relative = o.noise_relative;
      ro.seed = o.seed + uint64_t(f);
      const BallInImage& ball = track[size_t(f)];
      const std::string path =
          sequence ? (std::filesystem::path(output) / fmt::format("frame_{:04d}.exr", f)).string() : output;
      write_rgb_image(path, render_mirror_ball(world, ball, camera, o.width, o.height, ro));
      per_frame.push_back({{"frame", f}, {"ball", {ball.cx, ball.cy, ball.radius_px}}});
    }
    if (o.distance_in_radii > 0) truth["distance_in_radii"] = o.distance_in_radii;
  } else {
    write_rgb_image(output, render_fisheye(world, equidistant_fisheye(o.width, o.height, o.fov_deg), 4));
    truth["fov_deg"] = o.fov_deg;
  }
  truth["per_frame"] = per_frame;
  if (sequence) write_file_atomically((std::filesystem::path(output) / "truth.json").string(), truth.dump(2) + "\n");
  return truth;
}

}  // namespace lp
