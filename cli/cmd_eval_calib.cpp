// eval calib: the command line of eval/calib_eval.h (our geometric calibration next to
// OpenCV run alone on the same detected corners, and a sweep on synthetic corners).
#include "calib/board_detect.h"
#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/progress_bar.h"
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
  return evaluate_and_report("eval calib", out, [&](const EvalProgress& p) { return evaluate_calib(o, p); });
}

}  // namespace lp::cli
