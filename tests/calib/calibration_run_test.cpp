// From image files to camera files and the report (calib/calibration_run.h, board_detect.h
// detect_boards): what `lightprobe calib geometric` prints and writes.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <unistd.h>

#include "calib/calibration_run.h"
#include "calib/projection_difference.h"
#include "calib/synthetic_boards.h"
#include "core/error.h"
#include "core/file_io.h"
#include "tests/calib/test_cameras.h"

namespace lp {
namespace {

namespace fs = std::filesystem;
using calib_test::detections_of;
using calib_test::kb190;

const BoardSpec kBoard{10, 7, 40};

fs::path temp_dir(const std::string& name) {
  // The pid: other checkouts may run the same tests at the same time.
  const fs::path d = fs::temp_directory_path() /
                     ("lightprobe_calibration_run_test_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  for (std::string l; std::getline(ss, l);) out.push_back(l);
  return out;
}

TEST(CalibrationRun, DetectsEveryImageAndRefusesMixedSizes) {
  SyntheticBoardsOptions o;
  o.views = 4;
  o.board = BoardSpec{9, 6, 30};
  o.camera = CameraModel{"LENSMODEL_PINHOLE", {600, 600, 399.5, 299.5}, 800, 600};
  o.field_deg = 0;
  const SyntheticBoards boards = synthesize_boards(o);
  const fs::path dir = temp_dir("detect");
  std::vector<std::string> paths;
  for (size_t i = 0; i < boards.images.size(); ++i) {
    const CameraImage& im = boards.images[i];
    cv::Mat m(im.height, im.width, CV_8U);
    for (int k = 0; k < im.width * im.height; ++k) m.data[k] = uint8_t(std::lround(im.rgb[size_t(3 * k)] * 255));
    paths.push_back((dir / ("board_" + std::to_string(i) + ".png")).string());
    ASSERT_TRUE(cv::imwrite(paths.back(), m));
  }
  int calls = 0;
  const BoardDetections d = detect_boards(paths, o.board, {}, [&] { ++calls; });  // from worker threads
  EXPECT_EQ(calls, 4);
  EXPECT_EQ(d.found, 4);
  EXPECT_EQ(d.width, 800);
  EXPECT_EQ(d.height, 600);
  ASSERT_EQ(d.corners.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    ASSERT_EQ(d.corners[i].size(), 54u);
    EXPECT_EQ(d.corners[i], d.per_image[i].corners);
    EXPECT_EQ(d.corners[i], detect_board(read_camera_image(paths[i]), o.board).corners);  // order-independent
  }
  // Another resolution, or a file that cannot be read: the first such image, by name.
  const std::string small = (dir / "small.png").string();
  cv::imwrite(small, cv::Mat(300, 400, CV_8U, cv::Scalar(128)));
  try {
    detect_boards({paths[0], small, "/nonexistent.png"}, o.board);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("small.png: 400x300 differs"), std::string::npos) << e.what();
  }
  EXPECT_THROW(detect_boards({"/nonexistent.png", paths[0]}, o.board), InputError);
}

// A view given twice (a copy of a file), a second frame of a board that did not move (0.05 px
// of noise) and one of it labelled from the other end (turned half a turn) are each used
// once: the answer is that of the views without them, and the report names them. A copy had
// been refused, which refused a whole set for one duplicate; a second frame had been taken as
// a view, one in each half of a split (a held-out view a fitted one). A view 1 px away is a
// view of its own.
TEST(CalibrationRun, AViewRepeatedIsUsedOnceAndSaid) {
  const CameraModel truth = kb190();
  const auto views = project_board_views(truth, kBoard, 6, 70, 600, 0.1, 3, 93);
  ASSERT_GE(views.size(), 5u);
  const GeometricCalibration plain = calibrate_detections(detections_of(views, truth), kBoard);
  auto repeated = views;
  repeated.push_back(views[1]);  // view_N: a copy
  auto noisy = views[3];
  for (size_t k = 0; k < noisy.size(); ++k) noisy[k][k % 2] += (k % 3 == 0 ? 0.05 : -0.05);
  repeated.push_back(noisy);  // a second frame
  repeated.push_back(std::vector<std::array<double, 2>>(views[2].rbegin(), views[2].rend()));  // half a turn
  const size_t n = views.size();
  const GeometricCalibration run = calibrate_detections(detections_of(repeated, truth), kBoard);
  EXPECT_EQ(run.result.selected, plain.result.selected);
  EXPECT_NEAR(run.result.model.rms_reprojection_px, plain.result.model.rms_reprojection_px, 1e-9);
  EXPECT_NEAR(run.result.cross_validation_px, plain.result.cross_validation_px, 1e-9);
  ASSERT_EQ(run.notes.size(), 1u);
  EXPECT_EQ(run.notes[0], fmt::format("3 views repeat an earlier one, each used once: view_{}.png = view_1.png (0.00 px), "
                                      "view_{}.png = view_3.png (0.05 px), view_{}.png = view_2.png (0.00 px)",
                                      n, n + 1, n + 2));
  EXPECT_EQ(run.result.views[n].why, "left out: the same view as view_1.png (corners 0.00 px RMS apart)");
  EXPECT_FALSE(run.result.views[n + 1].used);
  // One pixel off: another view.
  auto moved = views;
  moved.push_back(views[1]);
  for (auto& c : moved.back()) c[0] += 1.0;
  EXPECT_TRUE(calibrate_detections(detections_of(moved, truth), kBoard).notes.empty());
  // Four views of which two are one: three distinct views cannot calibrate.
  const std::vector<std::vector<std::array<double, 2>>> three = {views[0], views[1], views[2], views[0]};
  try {
    calibrate_detections(detections_of(three, truth), kBoard);
    ADD_FAILURE() << "three distinct views were calibrated";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "only 3 distinct views: 1 of the 4 with a board repeat an earlier one (view_3.png = "
                           "view_0.png (0.00 px)); at least 4 are needed");
  }
}

TEST(CalibrationRun, NoBoardButOneOfAnotherSizeSaysWhichSize) {
  const CameraModel truth = kb190();
  BoardDetections d = detections_of(std::vector<std::vector<std::array<double, 2>>>(5), truth);
  d.per_image[2].other_cols = 9;
  d.per_image[2].other_rows = 6;
  try {
    calibrate_detections(d, BoardSpec{7, 5, 30});
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "no 7x5 board found in any of the 5 images: found 9x6 inner corners, --board says 7x5");
  }
}

// A fit of every view worse than held out by half again is said (a solve in a worse minimum
// than its halves'; 0.87-0.99 on the shared sets), in the summary and in --json.
TEST(CalibrationRun, AFitWorseThanHeldOutIsSaid) {
  const CameraModel truth = kb190();
  const auto corners = project_board_views(truth, kBoard, 8, 70, 600, 0.1, 3, 93);
  GeometricCalibrationOptions o;
  o.calibrate.model = "LENSMODEL_KANNALA_BRANDT";
  o.calibrate.leverage = false;
  o.calibrate.uncertainty = false;
  GeometricCalibration run = calibrate_detections(detections_of(corners, truth), kBoard, o);
  const CalibrationResult& r = run.result;
  ASSERT_GT(r.heldout_rms_px, 0);
  EXPECT_LT(r.model.rms_reprojection_px, r.heldout_rms_px);
  EXPECT_EQ(run.summary().find("should not be worse than held out"), std::string::npos);
  EXPECT_FALSE(nlohmann::json::parse(run.to_json())["fit_worse_than_heldout"].get<bool>());
  run.result.model.rms_reprojection_px = 1.6 * r.heldout_rms_px;  // as the stuck plumb_bob fit's 3.6x
  EXPECT_NE(run.summary().find("should not be worse than held out"), std::string::npos) << run.summary();
  EXPECT_TRUE(nlohmann::json::parse(run.to_json())["fit_worse_than_heldout"].get<bool>());
}

// Five views of an audit's 125 deg rational lens (1920x1080, a 10x4 board of 15 mm squares,
// its poses): no model's halves agree (413 px apart), and a model 287 px from the truth was
// written with a warning. Refused now, saying what would help.
TEST(CalibrationRun, ViewsThatDetermineNoModelAreRefused) {
  const CameraModel truth{"LENSMODEL_OPENCV8",
                          {981.9364352, 981.3548498, 941.1374453, 501.2320725, 0.1968207354, 0.006188415119,
                           -0.001461512005, -0.0006631984682, 0.009842191225, 0.6790123243, 0.08447071094,
                           0.01430840574},
                          1920, 1080};
  const BoardSpec board{10, 4, 15};
  const std::vector<std::array<double, 6>> poses = {{-0.210186, 0.188763, -0.228376, 200.075356, 297.606177, 1616.133358},
                             {0.176490, -0.652219, -0.045230, -1213.452749, 616.902168, 658.396855},
                             {0.851716, -0.936898, 0.143662, -1060.037936, -532.225160, 574.388779},
                             {-0.016799, -0.614690, -0.180628, -1550.560331, 949.444567, 816.334394},
                             {-0.288894, -0.514700, -0.090401, -849.103584, 617.720300, 1363.909283}};
  const auto corners = calib_test::corners_at_poses(truth, board, poses, 0.047, 302);
  ASSERT_EQ(corners.size(), poses.size());
  GeometricCalibrationOptions o;
  o.calibrate.leverage = false;
  o.calibrate.uncertainty = false;
  try {
    const GeometricCalibration run = calibrate_detections(detections_of(corners, truth), board, o);
    ADD_FAILURE() << "written: " << run.result.selected << ", cross-validation " << run.result.cross_validation_px
                  << " px, " << projection_difference(run.result.model, truth, {}, 16).median_px << " px from the truth";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("no model is determined by these views: models of two halves of them (", 0),
              0u)
        << e.what();
  }
}

TEST(CalibrationRun, SummaryAndJsonReportTheResultAndTheFilesWritten) {
  const CameraModel truth = kb190();
  const auto corners = project_board_views(truth, kBoard, 8, 70, 600, 0.1, 3, 93);
  GeometricCalibrationOptions o;
  o.calibrate.model = "LENSMODEL_KANNALA_BRANDT";
  GeometricCalibration run = calibrate_detections(detections_of(corners, truth), kBoard, o);
  const fs::path dir = temp_dir("report");
  const std::string out = (dir / "cam.cameramodel").string();
  write_calibration_files(run, out);
  // Kannala-Brandt is not an mrcal model: YAML only, said in one line.
  ASSERT_EQ(run.written.size(), 1u);
  EXPECT_EQ(run.written[0], (dir / "cam.yaml").string());
  EXPECT_TRUE(fs::exists(dir / "cam.yaml"));
  EXPECT_FALSE(fs::exists(out));
  ASSERT_EQ(run.notes.size(), 2u);
  EXPECT_EQ(run.notes[0], "LENSMODEL_KANNALA_BRANDT is not an mrcal model: writing OpenCV YAML only (" + run.written[0] +
                             "; mrcal's tools cannot read it)");
  // A 190 degree lens: cv::fisheye cannot take its rays beyond 90 degrees, said.
  EXPECT_EQ(run.notes[1].rfind(run.written[0] + ": the model maps the frame's edges to rays up to ", 0), 0u) << run.notes[1];
  EXPECT_FALSE(run.optimization_inputs);
  EXPECT_TRUE(run.uncertainty_picture);
  for (const char* p : {"_residuals.png", "_coverage.png", "_uncertainty.png"})
    EXPECT_TRUE(fs::exists(run.picture_stem + p)) << p;

  const std::string text = run.summary();
  std::printf("%s", text.c_str());
  const auto lines = lines_of(text);
  ASSERT_GE(lines.size(), 10u);
  EXPECT_EQ(lines[0], run.notes[0]);
  EXPECT_EQ(lines[1], run.notes[1]);
  EXPECT_EQ(lines[2].rfind("8 of 8 images have the 10x7 board (0.00 s); solved in ", 0), 0u) << lines[2];
  EXPECT_EQ(lines[3].rfind("model ", 0), 0u);
  EXPECT_EQ(lines[4].rfind("LENSMODEL_KANNALA_BRANDT ", 0), 0u);
  EXPECT_NE(lines[4].find("<- chosen"), std::string::npos);
  EXPECT_EQ(lines[5], "model LENSMODEL_KANNALA_BRANDT as requested; " + std::to_string(run.result.corners_rejected) +
                          " of 560 corners rejected as outliers");
  EXPECT_NE(text.find("projection uncertainty (1 sigma, rays at infinity; headline: jackknife):\n"), std::string::npos);
  EXPECT_EQ(lines.back(), "wrote " + run.written[0] + "; pictures " + run.picture_stem + "_residuals.png, " +
                              run.picture_stem + "_coverage.png, " + run.picture_stem + "_uncertainty.png");

  const nlohmann::json j = nlohmann::json::parse(run.to_json());
  EXPECT_EQ(j["selected"], "LENSMODEL_KANNALA_BRANDT");
  EXPECT_EQ(j["lensmodel"], "LENSMODEL_KANNALA_BRANDT");
  EXPECT_EQ(j["intrinsics"].get<std::vector<double>>(), run.result.model.intrinsics);
  EXPECT_EQ(j["output"].get<std::vector<std::string>>(), run.written);
  EXPECT_EQ(j["rms_px"].get<double>(), run.result.model.rms_reprojection_px);
  EXPECT_TRUE(j["cross_validation_noise_px"].is_null());  // a forced model: not measured (NaN)
  EXPECT_TRUE(j["before_dropping"].is_null());
  EXPECT_EQ(j["views"].size(), 8u);
  EXPECT_EQ(j["images"][3]["file"], "view_3.png");
  EXPECT_EQ(j["table"].size(), 1u);
  EXPECT_EQ(j["uncertainty"]["headline"], "jackknife");
  EXPECT_EQ(j["uncertainty"]["plot"], run.picture_stem + "_uncertainty.png");
  EXPECT_EQ(j["views_with_board"], 8);
  // The board warp, by default kept only where it repays its parameters: on this flat board
  // decided flat, said in one line with the numbers that decided, the comparison per split
  // in --json.
  const BoardWarpChoice& c = run.result.board_warp_choice;
  ASSERT_TRUE(c.decided) << c.why;
  EXPECT_FALSE(c.keep);
  EXPECT_FALSE(run.result.board_warp.fitted);
  EXPECT_NE(text.find("board taken as flat: the warp does not repay its parameters over 8 splits: with it the "
                      "held-out RMS is "),
            std::string::npos);
  EXPECT_TRUE(j["board_warp"].is_null());
  EXPECT_EQ(j["board_warp_choice"]["kept"], false);
  EXPECT_EQ(j["board_warp_choice"]["tested"], true);
  EXPECT_EQ(j["board_warp_choice"]["model"], "LENSMODEL_KANNALA_BRANDT");
  EXPECT_EQ(j["board_warp_choice"]["splits"], 8);
  EXPECT_EQ(j["board_warp_choice"]["heldout_splits_px"]["flat"].get<std::vector<double>>(), c.flat.heldout_px);
  EXPECT_EQ(j["board_warp_choice"]["heldout_gain_px"].get<double>(), c.challenge.gain_px);
  // --board-warp on: its line and its key, with the values and deviations of the result.
  o.calibrate.board_warp_auto = false;
  const GeometricCalibration on = calibrate_detections(detections_of(corners, truth), kBoard, o);
  const BoardWarpReport& w = on.result.board_warp;
  ASSERT_TRUE(w.fitted);
  ASSERT_TRUE(std::isfinite(w.sd_mm[0]) && std::isfinite(w.sd_mm[1]));
  char line[160];
  std::snprintf(line, sizeof line, "board warp (peak deflection along x, y): %.3f, %.3f mm (+- %.3f, +- %.3f)\n",
                w.mm[0], w.mm[1], w.sd_mm[0], w.sd_mm[1]);
  EXPECT_NE(on.summary().find(line), std::string::npos) << line;
  const nlohmann::json jon = nlohmann::json::parse(on.to_json());
  EXPECT_EQ(jon["board_warp"]["x2_mm"].get<double>(), w.mm[0]);
  EXPECT_EQ(jon["board_warp"]["y2_sd_mm"].get<double>(), w.sd_mm[1]);
  EXPECT_TRUE(jon["board_warp_choice"].is_null());  // not asked
  EXPECT_LT(std::abs(w.mm[0]), 3 * w.sd_mm[0]);      // the truth is flat
  // --board-warp off: the board taken as flat, said, and null in --json.
  o.calibrate.board_warp = false;
  const GeometricCalibration flat = calibrate_detections(detections_of(corners, truth), kBoard, o);
  EXPECT_FALSE(flat.result.board_warp.fitted);
  EXPECT_NE(flat.summary().find("board taken as flat (no board warp fitted)\n"), std::string::npos);
  EXPECT_TRUE(nlohmann::json::parse(flat.to_json())["board_warp"].is_null());
  EXPECT_TRUE(nlohmann::json::parse(flat.to_json())["board_warp_choice"].is_null());
  // Auto decided flat is the same model as off, up to the outlier stage (run with the warp).
  EXPECT_LT(projection_difference(run.result.model, flat.result.model, {}, 16, false).rms_px, 0.01);
}

// Four views: halves of two have no jackknife noise, yet the model is chosen, and the summary
// says how (it said "as requested" when nothing was requested).
TEST(CalibrationRun, FourViewsSayTheModelWasChosenNotRequested) {
  const CameraModel truth = kb190();
  const auto corners = project_board_views(truth, kBoard, 4, 70, 600, 0.1, 3, 93);
  GeometricCalibrationOptions o;
  o.calibrate.leverage = false;
  o.calibrate.uncertainty = false;
  const GeometricCalibration run = calibrate_detections(detections_of(corners, truth), kBoard, o);
  ASSERT_GT(run.result.table.size(), 1u);
  const std::string text = run.summary();
  EXPECT_TRUE(std::isnan(run.result.cv_noise_px)) << run.result.cv_noise_px << " with " << corners.size() << " views";
  EXPECT_EQ(text.find("as requested"), std::string::npos) << text;
  EXPECT_NE(text.find("chosen: " + run.result.selected + ", "), std::string::npos) << text;
  // Four views are too few to judge the board warp (BoardWarpChoiceOptions::min_views): kept
  // untested, said in one line and in --json.
  EXPECT_TRUE(run.result.board_warp.fitted);
  EXPECT_FALSE(run.result.board_warp_choice.decided);
  EXPECT_NE(text.find("  (the warp kept untested: 4 views, fewer than the 6 it takes to judge it)\n"), std::string::npos)
      << text;
  const nlohmann::json j = nlohmann::json::parse(run.to_json());
  EXPECT_EQ(j["board_warp_choice"]["tested"], false);
  EXPECT_EQ(j["board_warp_choice"]["kept"], true);
  EXPECT_FALSE(j["board_warp"].is_null());
}

TEST(CalibrationRun, DropsTheMostInfluentialViewAndReportsBothAnswers) {
  const CameraModel truth = kb190();
  auto corners = project_board_views(truth, kBoard, 9, 40, 600, 0.1, 11, 93);
  corners.push_back(project_board_views(truth, kBoard, 1, 85, 500, 0.1, 12, 93).at(0));  // the only rim view
  GeometricCalibrationOptions o;
  o.calibrate.model = "LENSMODEL_KANNALA_BRANDT";
  o.calibrate.uncertainty = false;
  o.drop_influential = 1;
  GeometricCalibration run = calibrate_detections(detections_of(corners, truth), kBoard, o);
  ASSERT_EQ(run.dropped.size(), 1u);
  const size_t rim = corners.size() - 1;
  EXPECT_EQ(run.dropped[0].view, rim);
  ASSERT_TRUE(run.before_dropping.has_value());
  EXPECT_TRUE(run.corners[rim].empty());
  EXPECT_FALSE(run.result.views[rim].used);
  EXPECT_EQ(run.result.views[rim].why.rfind("dropped: influential", 0), 0u) << run.result.views[rim].why;
  const std::string text = run.summary();
  EXPECT_NE(text.find("dropped influential view: view_" + std::to_string(rim) + ".png ("), std::string::npos) << text;
  EXPECT_NE(text.find("with all views: LENSMODEL_KANNALA_BRANDT (cross-validation "), std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(run.to_json());
  EXPECT_EQ(j["dropped_views"][0]["file"], "view_" + std::to_string(rim) + ".png");
  EXPECT_EQ(j["before_dropping"]["selected"], "LENSMODEL_KANNALA_BRANDT");
}

TEST(CalibrationRun, WritesBothFormatsForAnMrcalModelWithAnOpenCVForm) {
  const CameraModel truth{"LENSMODEL_PINHOLE", {900, 902, 639.2, 481.7}, 1280, 960};
  const auto corners = project_board_views(truth, kBoard, 8, 25, 900, 0.1, 5, 34);
  GeometricCalibrationOptions o;
  o.calibrate.model = "LENSMODEL_PINHOLE";
  o.calibrate.leverage = false;
  o.calibrate.uncertainty = false;
  GeometricCalibration run = calibrate_detections(detections_of(corners, truth), kBoard, o);
  const fs::path dir = temp_dir("both");
  write_calibration_files(run, (dir / "cam.cameramodel").string(), (dir / "pictures").string());
  EXPECT_EQ(run.written, (std::vector<std::string>{(dir / "cam.cameramodel").string(), (dir / "cam.yaml").string()}));
  EXPECT_TRUE(run.notes.empty());
  EXPECT_EQ(run.picture_stem, (dir / "pictures" / "cam").string());
  EXPECT_FALSE(run.uncertainty_picture);
  EXPECT_EQ(read_camera_model((dir / "cam.yaml").string()).intrinsics, run.result.model.intrinsics);
  EXPECT_EQ(read_camera_model((dir / "cam.cameramodel").string()).intrinsics, run.result.model.intrinsics);
  // mrcal's optimization_inputs ride along (tests/calib/consumers/mrcal_consumer.sh runs mrcal
  // on them); lightprobe's reader (mrcal's C parser) reads past them.
  EXPECT_TRUE(run.optimization_inputs);
  const std::string text = read_text_file((dir / "cam.cameramodel").string());
  EXPECT_NE(text.find("\n    'icam_intrinsics': 0,\n"), std::string::npos);
  EXPECT_NE(text.find("\n    'optimization_inputs': b'"), std::string::npos);
  ASSERT_EQ(run.result.solve.views.size(), corners.size());
  EXPECT_EQ(run.result.solve.observations[2][7][0], corners[2][7][0]);
  EXPECT_NE(run.summary().find("the .cameramodel carries mrcal's optimization_inputs"), std::string::npos);
  EXPECT_TRUE(nlohmann::json::parse(run.to_json())["optimization_inputs"].get<bool>());
  // Checked before the work: the output's type and directory.
  EXPECT_THROW(check_calibration_output((dir / "cam.txt").string()), InputError);
  EXPECT_THROW(check_calibration_output((dir / "missing" / "cam.yaml").string()), InputError);
  EXPECT_NO_THROW(check_calibration_output((dir / "cam.yml").string()));
  // Too few views with the board.
  auto three = detections_of(corners, truth);
  for (size_t i = 3; i < three.corners.size(); ++i) {
    three.corners[i].clear();
    three.per_image[i].found = false;
  }
  three.found = 3;
  EXPECT_THROW(calibrate_detections(three, kBoard, o), InputError);
}

}  // namespace
}  // namespace lp
