// Speed of the environment-map distribution and the reflected-radiance estimators on the
// procedural scene at latlong 256x128 (the eval size) and 1024x512: distribution build per
// frame, samples per second of the map and the lobe, and estimates per second of MIS, BIS
// and one SMC frame step at 16 samples. Accuracy is in `lightprobe eval estimators`.
#include <benchmark/benchmark.h>

#include <cmath>
#include <map>
#include <memory>

#include "eval/synthetic_scene.h"
#include "render/estimators.h"
#include "render/smc.h"

namespace {

using namespace lp;

const EnvMap& scene_latlong(int width) {
  static std::map<int, EnvMap> cache;
  auto it = cache.find(width);
  if (it == cache.end()) it = cache.emplace(width, render_scene(describe_scene(), Layout::LatLong, width, width / 2)).first;
  return it->second;
}

std::shared_ptr<const EnvDistribution> scene_distribution(int width) {
  static std::map<int, std::shared_ptr<const EnvDistribution>> cache;
  auto it = cache.find(width);
  if (it == cache.end()) it = cache.emplace(width, std::make_shared<const EnvDistribution>(scene_latlong(width))).first;
  return it->second;
}

ShadingPoint glossy_point() {
  const Vec3 n = normalize(Vec3{0.5, 0.3, 0.8});
  return {n, normalize(Vec3{0.2, 0.1, 1.0}), Brdf{LobeType::BlinnPhong, {0.9, 0.9, 0.9}, 100}, {}};
}

void BM_EnvDistributionBuild(benchmark::State& state) {
  const EnvMap& map = scene_latlong(int(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(EnvDistribution(map));
  state.counters["pixels/s"] = benchmark::Counter(double(map.pixel_count()) * double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EnvDistributionBuild)->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_EnvDistributionSample(benchmark::State& state) {
  const auto d = scene_distribution(int(state.range(0)));
  Rng rng(1);
  for (auto _ : state) benchmark::DoNotOptimize(d->sample(rng.uniform3()));
  state.counters["samples/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EnvDistributionSample)->Arg(256)->Arg(1024);

void BM_EnvDistributionPdf(benchmark::State& state) {
  const auto d = scene_distribution(int(state.range(0)));
  Rng rng(2);
  for (auto _ : state) {
    const double z = 1 - 2 * rng.uniform(), phi = 2 * M_PI * rng.uniform(), s = std::sqrt(1 - z * z);
    benchmark::DoNotOptimize(d->pdf({s * std::cos(phi), s * std::sin(phi), z}));
  }
  state.counters["lookups/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EnvDistributionPdf)->Arg(256)->Arg(1024);

void BM_LobeSample(benchmark::State& state) {
  const ShadingPoint p = glossy_point();
  Rng rng(3);
  for (auto _ : state) {
    const double u1 = rng.uniform(), u2 = rng.uniform();
    benchmark::DoNotOptimize(sample_lobe(p.brdf, p.normal, p.view, u1, u2));
  }
  state.counters["samples/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_LobeSample);

// range(0): 0 MIS, 1 BIS (lobe proposals, M = 8 N), 2 BIS with half the proposals from the map.
void BM_Estimate(benchmark::State& state) {
  const auto d = scene_distribution(256);
  const ShadingPoint p = glossy_point();
  Rng rng(4);
  const int n = 16;
  for (auto _ : state) {
    if (state.range(0) == 0) benchmark::DoNotOptimize(estimate_mis(*d, p, {n / 2, n / 2}, rng));
    else benchmark::DoNotOptimize(estimate_bis(*d, p, {n, 8, state.range(0) == 2 ? 0.5 : 0.0}, rng));
  }
  state.counters["estimates/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["samples/s"] = benchmark::Counter(double(state.iterations()) * n, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Estimate)->Arg(0)->Arg(1)->Arg(2);

// One SMC frame step (16 particles) on a static map: reweight, maybe resample, one MH move.
void BM_SmcStep(benchmark::State& state) {
  const auto d = scene_distribution(256);
  SmcOptions o;
  o.particles = 16;
  o.init_proposal_map_share = 0.5;
  SmcEstimator smc(glossy_point(), o, 5);
  smc.step(d);
  for (auto _ : state) benchmark::DoNotOptimize(smc.step(d));
  state.counters["estimates/s"] = benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SmcStep);

}  // namespace
