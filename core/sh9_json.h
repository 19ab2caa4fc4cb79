// The JSON of SH9 coefficients, shared by sh.json (core/spherical_harmonics.h) and the
// "sh9" object of a light list (core/light_list.h). Internal to core.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/spherical_harmonics.h"

namespace lp {

// 9 rows [r, g, b], in basis order.
nlohmann::ordered_json sh9_rows_json(const Sh9& sh);
// Checks "order" (must be 2) and reads "coefficients" from `object`; throws InputError
// "source: ..." with `where` before the problem ("sh9: " inside a light list).
Sh9 sh9_from_json_object(const nlohmann::json& object, const std::string& source, const std::string& where);

}  // namespace lp
