// The forwarders' one line (calib/mrcal_loader.cpp, live/mosquitto_loader.cpp): in the body
// of a function that stands in for a library's own, `real` is that function, `name` as the
// library's header declares it (so the compiler checks the signature), resolved through
// lp::lazy::library_symbol on the first call and kept.
#pragma once

#include "core/lazy_libs.h"

#define LP_LAZY_FUNCTION(library, what, name) \
  static const auto real = reinterpret_cast<decltype(&::name)>(lp::lazy::library_symbol(library, #name, what))
