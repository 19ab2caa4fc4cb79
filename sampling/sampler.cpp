#include "sampling/sampler.h"

#include <fmt/format.h>

#include "core/error.h"
#include "sampling/methods.h"

namespace lp {

std::string_view to_string(Method method) {
  switch (method) {
    case Method::Pharr: return "pharr";
    case Method::Hemigon: return "hemigon";
    case Method::Q2Tree: return "q2tree";
    case Method::MedianCut: return "mediancut";
  }
  return "?";
}

std::optional<Method> method_from_string(std::string_view name) {
  for (Method m : all_methods())
    if (to_string(m) == name) return m;
  return std::nullopt;
}

std::vector<Method> all_methods() { return {Method::Pharr, Method::Hemigon, Method::Q2Tree, Method::MedianCut}; }

std::unique_ptr<Sampler> make_sampler(Method method, const SamplerOptions& options) {
  switch (method) {
    case Method::Pharr: return make_pharr_sampler(options);
    case Method::Hemigon: return make_hemigon_sampler(options);
    case Method::Q2Tree: return make_q2tree_sampler(options);
    case Method::MedianCut: return make_median_cut_sampler(options);
  }
  throw InputError("unknown sampling method");
}

LightList sample(const EnvMap& map, int n, Method method, const SamplerOptions& options) {
  if (n <= 0) throw InputError(fmt::format("--n must be positive, got {}", n));
  auto sampler = make_sampler(method, options);
  sampler->prepare(map);
  LightList list;
  list.method = std::string(to_string(method));
  list.units = map.units;
  list.lights = sampler->place(n);
  return list;
}

}  // namespace lp
