// Internal: one factory per method, each defined in the method's own file.
#pragma once

#include <memory>

#include "sampling/sampler.h"

namespace lp {

std::unique_ptr<Sampler> make_pharr_sampler(const SamplerOptions& options);
std::unique_ptr<Sampler> make_hemigon_sampler(const SamplerOptions& options);
std::unique_ptr<Sampler> make_q2tree_sampler(const SamplerOptions& options);
std::unique_ptr<Sampler> make_median_cut_sampler(const SamplerOptions& options);

}  // namespace lp
