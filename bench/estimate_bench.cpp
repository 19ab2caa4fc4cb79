// Cost of the probe-less mode: metering one frame's metadata, updating the quadtree with it
// (split + ancestor chain), and a look-up that yields six lights, on the walk-through track.
#include <benchmark/benchmark.h>

#include "estimate/light_quadtree.h"
#include "estimate/metadata_track.h"
#include "estimate/walkthrough.h"

namespace {

using namespace lp;

const Track& walk() {
  static const Track t = [] {
    WalkthroughOptions o;
    o.rays_x = 8;
    return make_walkthrough_track(default_room(), o);
  }();
  return t;
}

void BM_MeterFrame(benchmark::State& state) {
  const Track& t = walk();
  size_t i = 0;
  for (auto _ : state) {
    const TrackFrame& f = t.frames[i++ % t.frames.size()];
    benchmark::DoNotOptimize(meter_frame(f.metadata, t.camera, f.source));
  }
}
BENCHMARK(BM_MeterFrame);

// The whole walk into a fresh tree (root 16 m, cells down to 1 m): time per frame.
void BM_BuildModel(benchmark::State& state) {
  const Track& t = walk();
  BuildModelOptions b;
  b.quadtree.root_size = 16;
  for (auto _ : state) benchmark::DoNotOptimize(build_model(t, t.camera, b).nodes().size());
  state.SetItemsProcessed(int64_t(state.iterations()) * int64_t(t.frames.size()));
}
BENCHMARK(BM_BuildModel)->Unit(benchmark::kMicrosecond);

void BM_LightsAt(benchmark::State& state) {
  const Track& t = walk();
  BuildModelOptions b;
  b.quadtree.root_size = 16;
  const LightQuadtree model = build_model(t, t.camera, b);
  double x = 0.5;
  for (auto _ : state) {
    x = x > 7.5 ? 0.5 : x + 0.37;
    benchmark::DoNotOptimize(state.range(0) ? model.lights_shrunk(x, 3.0, 20) : model.lights_at(x, 3.0));
  }
}
BENCHMARK(BM_LightsAt)->Arg(0)->Arg(1);

}  // namespace
