#include "probe/unwrap_sequence.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "core/chromaticities.h"
#include "core/accuracy.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/sensor_white_level.h"
#include "core/warnings.h"
#include "probe/fisheye.h"

namespace lp {

namespace {

// A seeded fit stands when its rim agrees with the edges along at least this share of the
// arc that the last full search's fit did (the ball moves, the rim's content with it a
// little). Against the last full search, not the last frame: a chain of seeded frames each
// 0.9x the one before could otherwise drift to a fit that agrees along ever less of the rim.
constexpr double kSeededAgreement = 0.9;
// How far the seeded search looks for the ball around the last frame's (px).
constexpr double kSeededReachPx = 8;

// One frame's ball. After a frame whose silhouette fit held, the search starts from that
// frame's ball alone (FindBallOptions::initial_guess, refined on the pyramid levels that
// reach at most kSeededReachPx), which skips the exhaustive search of the coarsest level and
// the refinement of a dozen seeds; where that seeded fit does not hold as well (the ball
// jumped, a cut, a dark rim), the frame gets the full search. `reference_agreement`: the rim
// agreement of the last frame found by the full search with a sub-pixel fit (0: none, or
// the last frame's fit did not hold; then the full search). docs/probes.md "Sequences" has
// the cost and the agreement with the full search.
BallInImage track_ball(const RgbImage& img, double reference_agreement, const CircleTrack& raw, FindBallReport& fit,
                       bool& seeded_fit) {
  seeded_fit = false;
  if (reference_agreement > 0 && !raw.cx.empty()) {
    FindBallOptions seeded;
    seeded.initial_guess = BallInImage{raw.cx.back(), raw.cy.back(), raw.r.back()};
    seeded.initial_guess_reach_px = kSeededReachPx;
    try {
      const BallInImage ball = find_ball(img, seeded, &fit);
      seeded_fit = fit.subpixel && fit.rim_agreement >= kSeededAgreement * reference_agreement;
      if (seeded_fit) return ball;
    } catch (const InputError&) {
      // not near the last ball: the full search below
    }
  }
  return find_ball(img, {}, &fit);
}

// Pass 1: each frame's raw geometry, and the frames themselves while they fit in
// options.kept_frames_bytes (pass 2 reads the others again: a long sequence must not hold
// every frame, 25 MB each at 1920 x 1080).
struct FirstPass {
  std::vector<RgbImage> kept;  // frames [0, kept.size())
  int width = 0, height = 0;
  std::vector<std::optional<FindBallReport>> fits;
  std::vector<char> seeded;
  std::vector<size_t> recorded;  // frames whose ball was recorded in the file (probe register)
  // 16-bit frames: the white level of a sensor of fewer bits, decided at the first frame.
  SequenceWhiteLevel white_level;
  bool orientation_said = false;  // a fisheye frame's EXIF Orientation left unapplied, said once
};

// Frames are read in both passes: a frame whose codes cannot be made linear is refused as
// it is first read, before any ball is searched for.
RgbImage read_frame(const std::string& f, FirstPass& pass, const UnwrapSequenceOptions& o) {
  // A fisheye is unwrapped in its sensor's frame, where the calibration and "image up is +X"
  // (CONVENTIONS.md) hold: its EXIF Orientation is a gravity sensor's reading, which for a
  // camera pointing up is noise. Applied, the same pixels tagged upside down came out turned
  // 180 degrees in azimuth, and a 90-degree tag refused a calibrated lens for its size.
  const bool fisheye = o.type == ProbeType::Fisheye;
  RgbImage img = read_rgb_image(f, fisheye);
  if (fisheye && img.orientation != 1 && img.code_bits > 0 && !pass.orientation_said) {
    warn(orientation_not_applied_note(f, img.orientation));
    pass.orientation_said = true;
  }
  // A bracket fused as its frames' tags showed it (hdr fuse records the turn): turned back to
  // the sensor's frame. Unwrapped as it was, a bracket tagged upside down came out 180
  // degrees off in azimuth.
  if (fisheye && img.code_bits == 0 && img.orientation != 1) {
    if (!pass.orientation_said) warn(fused_turn_undone_note(f, img.orientation));
    pass.orientation_said = true;
    img = turned_back_to_sensor(std::move(img));
  }
  if (pass.width && (img.width != pass.width || img.height != pass.height))
    throw InputError(fmt::format("{}: {}x{} differs from the sequence's {}x{}", f, img.width, img.height, pass.width,
                                 pass.height));
  if (o.vignetting) {
    check_vignetting_size(vignetting_as_shown(*o.vignetting, fisheye ? 1 : img.orientation), img.width, img.height,
                          f + " (" + o.vignetting_file + ")");
    if (img.vignetting_corrected)
      throw InputError(fmt::format("{}: its vignetting is corrected already (hdr fuse --vignetting); --vignetting {} "
                                   "would divide it out twice",
                                   f, o.vignetting_file));
  }
  require_curve_for_deep_codes(img, o.codes.has_value(), f);
  // A Mono12 frame saved as 16-bit: its clipped sun at 4095 was linearised as a valid value
  // and the report's clipped fraction said 0.
  if (img.code_bits == 16) img.code_bits = pass.white_level.read(img.rgb, f);
  return img;
}

FirstPass first_pass(const std::vector<std::string>& files, const UnwrapSequenceOptions& o, CircleTrack& raw,
                     const std::function<void()>& step) {
  FirstPass pass;
  double reference_agreement = 0;  // track_ball's: of the last full search's sub-pixel fit
  for (size_t i = 0; i < files.size(); ++i) {
    const std::string& f = files[i];
    RgbImage img = read_frame(f, pass, o);
    pass.width = img.width, pass.height = img.height;
    if (o.type == ProbeType::MirrorBall) {
      BallInImage ball;
      pass.fits.emplace_back();
      pass.seeded.push_back(0);
      if (o.ball) {
        ball = *o.ball;
      } else if (img.mirror_ball) {  // where probe register put it (core/image_io.h)
        ball = BallInImage{(*img.mirror_ball)[0], (*img.mirror_ball)[1], (*img.mirror_ball)[2]};
        pass.recorded.push_back(i);
      } else {
        try {
          FindBallReport fit;
          bool from_previous = false;
          ball = track_ball(img, o.seed_from_previous ? reference_agreement : 0.0, raw, fit, from_previous);
          pass.fits.back() = fit;
          pass.seeded.back() = from_previous;
          if (!fit.subpixel) reference_agreement = 0;  // the next frame searches from scratch
          else if (!from_previous) reference_agreement = fit.rim_agreement;
        } catch (const InputError& e) {
          throw InputError(fmt::format("{}: {}", f, e.what()));
        }
      }
      raw.cx.push_back(ball.cx), raw.cy.push_back(ball.cy), raw.r.push_back(ball.radius_px);
    } else if (files.size() > 1 && !o.fixed_geometry) {
      const ImageCircle c = find_image_circle(img);
      raw.cx.push_back(c.cx), raw.cy.push_back(c.cy), raw.r.push_back(c.r);
    }
    const double bytes = double(img.rgb.size()) * sizeof(float) + double(img.valid.size());
    if (pass.kept.size() == i && double(i + 1) * bytes <= o.kept_frames_bytes) pass.kept.push_back(std::move(img));
    if (step) step();
  }
  return pass;
}

CircleTrack track_to_use(const CircleTrack& raw, const UnwrapSequenceOptions& o) {
  CircleTrack track = raw;
  if (o.fixed_geometry && !raw.cx.empty())
    for (size_t i = 0; i < raw.cx.size(); ++i) track.cx[i] = raw.cx[0], track.cy[i] = raw.cy[0], track.r[i] = raw.r[0];
  if (o.smooth_track && raw.cx.size() > 1) {
    SmoothOptions so;
    so.static_probe = o.static_probe;
    track = smooth_track(raw, so);
  }
  return track;
}

// The share of the map's solid angle that holds valid pixels.
double valid_solid_angle_fraction(const EnvMap& map) {
  double valid = 0, all = 0;
  for (size_t p = 0; p < map.pixel_count(); ++p) {
    const double w = pixel_solid_angle(map, p);
    all += w;
    if (map.is_valid(p)) valid += w;
  }
  return all > 0 ? valid / all : 0.0;
}

// Power-weighted mean direction of the valid map (nullopt for a black map).
std::optional<Vec3> centroid(const EnvMap& map) {
  Vec3 c{0, 0, 0};
  for (size_t p = 0; p < map.pixel_count(); ++p)
    if (map.is_valid(p)) {
      const float* q = map.pixel(p);
      c = c + (luminance(q[0], q[1], q[2]) * pixel_solid_angle(map, p)) * pixel_direction(map, p);
    }
  if (!(length(c) > 0)) return std::nullopt;
  return normalize(c);
}

}  // namespace

UnwrapSequenceReport unwrap_probe_sequence(const std::vector<std::string>& files, const UnwrapSequenceOptions& o,
                                           const std::function<void(size_t frame, EnvMap& map)>& emit,
                                           const std::function<void()>& step) {
  UnwrapSequenceReport report;
  FirstPass pass = first_pass(files, o, report.detected, step);
  report.used = track_to_use(report.detected, o);
  const CircleTrack& track = report.used;
  const auto t0 = std::chrono::steady_clock::now();
  std::optional<CameraModel> base_model;
  std::optional<std::array<double, 3>> lens_circle;  // a calibrated lens's image circle, found on its first frame
  bool lens_circle_tried = false;
  std::vector<Vec3> centroids;
  CodeTable code_table;  // built at the first frame of codes, for their bit depth
  for (size_t i = 0; i < files.size(); ++i) {
    // A kept frame is needed only here: taken, not copied (25 MB at 1920 x 1080).
    RgbImage frame = i < pass.kept.size() ? std::move(pass.kept[i]) : read_frame(files[i], pass, o);
    EnvMap map;
    UnwrapSequenceReport::Frame fr;
    fr.file = files[i];
    if (frame.code_bits > 0) {  // camera codes: to radiance, in place (the ball was found on the codes)
      const CodeCurve curve = o.codes.value_or(CodeCurve{});
      if (code_table.bits != frame.code_bits) code_table = make_code_table(curve, frame.code_bits, files[i]);
      const CodesReport codes = linearise_codes(frame, code_table, files[i]);
      fr.codes = curve.name;
      fr.clipped_fraction = codes.clipped_fraction;
    }
    if (o.vignetting) {  // turned as the frame was: a fisheye is read as stored
      correct_vignetting(frame, vignetting_as_shown(*o.vignetting, o.type == ProbeType::Fisheye ? 1 : frame.orientation),
                         o.vignetting_file);
      frame.vignetting_corrected = true;
    }
    // The unwrappers' messages ("camera model is for 1032x778, image is 1280x960", "remap
    // source is 1x1") name no file: this frame's is put in front.
    try {
      if (o.type == ProbeType::MirrorBall) {
        const BallInImage ball{track.cx[i], track.cy[i], track.r[i]};
        UnwrapOptions uo;
        uo.blind_spot_deg = o.blind_spot_deg;
        uo.fill = o.fill;
        UnwrapReport ur;
        MirrorBallCamera cam = o.ball_camera;
        cam.world_from_probe = o.world_from_probe;
        map = unwrap_mirror_ball(frame, ball, cam, o.layout, o.width, o.height, uo, &ur);
        report.fill_power_share = ur.fill_power_share;
        fr.ball = ball;
        fr.ball_detected = BallInImage{report.detected.cx[i], report.detected.cy[i], report.detected.r[i]};
        fr.ball_fit = pass.fits[i];
        fr.ball_seeded = pass.seeded[i];
        fr.ball_recorded = std::find(pass.recorded.begin(), pass.recorded.end(), i) != pass.recorded.end();
        fr.valid_fraction = ur.valid_solid_angle_fraction;  // before any fill
      } else {
        if (!base_model)
          base_model = o.camera ? *o.camera
                                : camera_model_from_fisheye(equidistant_fisheye(
                                      pass.width, pass.height, o.fisheye_fov_deg > 0 ? o.fisheye_fov_deg : 180));
        CameraModel m = *base_model;
        if (!track.cx.empty()) {
          // Move the optical centre with the image circle, relative to the track's first frame.
          m.intrinsics[2] += track.cx[i] - track.cx[0];
          m.intrinsics[3] += track.cy[i] - track.cy[0];
          fr.circle = ImageCircle{track.cx[i], track.cy[i], track.r[i]};
        }
        CameraUnwrapOptions co;
        co.max_field_deg = o.fisheye_fov_deg > 0 ? o.fisheye_fov_deg / 2 : (o.camera ? 0 : 90);
        // A calibrated lens without --fov: its model images rays up to its own domain (180 deg
        // for Kannala-Brandt), past the lens's image circle, and the black around the disc was
        // mapped as valid dark sky. The circle found in the frame bounds it (lens_image_circle:
        // a clean disc on black only; a full-frame image keeps every pixel).
        if (o.camera && !(o.fisheye_fov_deg > 0)) {
          if (!track.cx.empty()) {
            co.image_circle = std::array<double, 3>{track.cx[i], track.cy[i], track.r[i] - 1.0};
          } else {
            if (!lens_circle_tried) lens_circle = lens_image_circle(frame), lens_circle_tried = true;
            co.image_circle = lens_circle;
          }
        }
        if (o.fill) co.fill.method = FillMethod::PushPull;
        FillReport fill;
        map = unwrap_with_camera(frame, m, o.world_from_probe * upward_camera_world_from_camera(), o.layout, o.width,
                                 o.height, co, &fill);
        report.fill_power_share = fill.filled_power_share;
      }
    } catch (const InputError& e) {
      if (std::string(e.what()).rfind(files[i], 0) == 0) throw;
      throw InputError(files[i] + ": " + e.what());
    }
    // A probe outside the image unwraps to nothing: refused before anything is written.
    if (o.type != ProbeType::MirrorBall) fr.valid_fraction = valid_solid_angle_fraction(map);
    if (!(fr.valid_fraction > 0))
      throw InputError(files[i] + ": the unwrapped map holds no valid pixel (is the " +
                       (o.type == ProbeType::MirrorBall ? "ball" : "image circle") + " inside the image?)");
    map.units = frame.units;
    map.world_from_probe = o.world_from_probe;
    map.vignetting_corrected = frame.vignetting_corrected;
    if (o.to_rec709 && !fr.codes.empty()) apply_colour_matrix(map.rgb, *o.to_rec709);  // a linear map of codes
    if (o.colour) apply_colour_match(map, *o.colour);
    if (auto c = centroid(map)) centroids.push_back(*c);
    emit(i, map);
    report.frames.push_back(std::move(fr));
    if (step) step();
  }
  report.unwrap_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (centroids.size() > 1) {
    double sum_deg = 0;
    for (size_t i = 1; i < centroids.size(); ++i) sum_deg += angle_between(centroids[i - 1], centroids[i]) * 180 / M_PI;
    report.map_jitter_deg = sum_deg / double(centroids.size() - 1);
  }
  return report;
}

}  // namespace lp
