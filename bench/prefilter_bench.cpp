// Speed of the GGX prefiltered cube chain on the procedural scene at latlong 1024x512, per
// level-0 face size (the whole chain down to 16-texel faces), and of the DFG table.
// Accuracy is in tests/render/prefilter_test.cpp and docs/exporters.md.
#include <benchmark/benchmark.h>

#include "eval/synthetic_scene.h"
#include "render/prefilter.h"

namespace {

using namespace lp;

void BM_PrefilterChain(benchmark::State& state) {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 1024, 512);
  PrefilterOptions o;
  o.face_size = int(state.range(0));
  for (auto _ : state) benchmark::DoNotOptimize(prefilter_ggx(map, o));
}
BENCHMARK(BM_PrefilterChain)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DfgTable(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(compute_dfg_table(int(state.range(0))));
}
BENCHMARK(BM_DfgTable)->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
