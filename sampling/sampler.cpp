#include "sampling/sampler.h"
