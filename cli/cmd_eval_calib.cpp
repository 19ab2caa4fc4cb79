// eval calib: the command line of eval/calib_eval.h (our geometric calibration next to
// OpenCV run alone on the same detected corners, and a sweep on synthetic corners).
#include "calib/board_detect.h"
#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/report.h"
#include "core/error.h"
#include "eval/calib_eval.h"

namespace lp::cli {

int run_eval_calib(const EvalCalibArgs& args, const Output& out) {
  EvalCalibOptions o;
  o.images = args.images;
  parse_size(args.board, "--board", &o.board.cols, &o.board.rows);
  o.board.square_mm = args.square_mm;
  o.sweep = args.sweep;
  o.output_dir = args.output_dir;
  const EvalCalibReport report = evaluate_calib(o, out.progress);
  say(out, "{}", report.summary());
  emit_json(out, report.to_json());
  return 0;
}

}  // namespace lp::cli
