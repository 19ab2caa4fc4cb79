// eval estimators: the command line of eval/estimators_eval.h (MIS, BIS and SMC
// reflected-radiance estimators: error, temporal noise, time).
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>

#include "cli/commands.h"
#include "cli/eval_handlers.h"
#include "cli/progress_bar.h"
#include "cli/report.h"
#include "core/error.h"
#include "core/limits.h"
#include "eval/estimators_eval.h"

namespace lp::cli {

namespace {

// Comma-separated items, empty ones kept (so that "mis," names an empty estimator).
std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> out;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    out.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return out;
}

std::vector<Scenario> parse_scenarios(const std::string& text) {
  if (text == "all") return all_scenarios();
  std::vector<Scenario> out;
  for (const std::string& name : split_commas(text)) {
    const auto s = scenario_from_string(name);
    if (!s) throw InputError(fmt::format("--scenarios: unknown scenario '{}'", name));
    out.push_back(*s);
  }
  return out;
}

}  // namespace

int run_eval_estimators(const EvalEstimatorsArgs& args, const Output& out) {
  EvalEstimatorsOptions o;
  o.inputs = args.inputs;
  check_frame_count("--frames", args.frames);
  o.frames = args.frames;
  o.repeats = args.repeats;
  o.bis_m = args.bis_m;
  o.ray_cost_us = args.ray_cost_us;
  o.sweep = args.sweep;
  o.seed = args.seed;
  o.output_dir = args.output_dir;
  std::string budgets = args.budgets;
  if (args.quick) {  // the demo: short, and no sweep
    o.frames = std::min(o.frames, 4);
    o.repeats = 2;
    if (budgets == EvalEstimatorsArgs{}.budgets) budgets = "4,16,64";
    o.sweep = false;
  }
  o.budgets = parse_int_list(budgets, "--budgets");
  o.estimators = split_commas(args.estimators);
  parse_image_size(args.size, "--size", &o.width, &o.height);
  o.scenarios = parse_scenarios(args.scenarios);
  return evaluate_and_report("eval estimators", out, [&](const EvalProgress& p) { return evaluate_estimators(o, p); });
}

}  // namespace lp::cli
