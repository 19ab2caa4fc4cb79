// Placeholder until the method lands: the factory exists so that everything links.
#include "core/error.h"
#include "sampling/methods.h"

namespace lp {

std::unique_ptr<Sampler> make_pharr_sampler(const SamplerOptions&) { throw InputError("pharr is not implemented yet"); }

}  // namespace lp
