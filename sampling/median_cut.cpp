// Placeholder until the method lands: the factory exists so that everything links.
#include "core/error.h"
#include "sampling/methods.h"

namespace lp {

std::unique_ptr<Sampler> make_median_cut_sampler(const SamplerOptions&) { throw InputError("median_cut is not implemented yet"); }

}  // namespace lp
