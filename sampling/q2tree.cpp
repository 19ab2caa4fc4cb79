// Placeholder until the method lands: the factory exists so that everything links.
#include "core/error.h"
#include "sampling/methods.h"

namespace lp {

std::unique_ptr<Sampler> make_q2tree_sampler(const SamplerOptions&) { throw InputError("q2tree is not implemented yet"); }

}  // namespace lp
