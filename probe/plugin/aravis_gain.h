// A GenICam camera's gain in dB, from the feature that holds it. Apart from the source so
// that the rule is tested without a camera (tests/probe/aravis_gain_test.cpp).
#pragma once

#include <cctype>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

namespace lp {

// The gain features, in the order Aravis' arv_camera_get_gain reads them.
inline constexpr const char* kGainFeatures[] = {"Gain", "GainAbs", "GainRaw"};

enum class GainUnit { Db, Linear, Unknown };

// How `feature` counts. SFNC's "Gain" (and the older "GainAbs") is in dB unless its node
// names another unit; a node in "x" or "times" is a linear factor. "GainRaw" counts the
// device's own steps, whose size only the vendor's manual gives: read as dB, a raw 120
// divided the frames by 10^6.
inline GainUnit gain_feature_unit(std::string_view feature, std::string_view unit) {
  if (feature != "Gain" && feature != "GainAbs") return GainUnit::Unknown;
  std::string u;
  for (char c : unit)
    if (!std::isspace(static_cast<unsigned char>(c))) u += char(std::tolower(static_cast<unsigned char>(c)));
  if (u.empty() || u == "db") return GainUnit::Db;
  if (u == "x" || u == "times") return GainUnit::Linear;
  return GainUnit::Unknown;
}

// `feature`'s value in dB, or nothing when it is not known to be in dB.
inline std::optional<double> gain_feature_db(std::string_view feature, std::string_view unit, double value) {
  if (!std::isfinite(value)) return std::nullopt;
  switch (gain_feature_unit(feature, unit)) {
    case GainUnit::Db: return value;
    case GainUnit::Linear: return value > 0 ? std::optional<double>(20.0 * std::log10(value)) : std::nullopt;
    case GainUnit::Unknown: break;
  }
  return std::nullopt;
}

// The value to write to `feature` for `db` decibels; nothing when its unit is unknown.
inline std::optional<double> gain_feature_value(std::string_view feature, std::string_view unit, double db) {
  switch (gain_feature_unit(feature, unit)) {
    case GainUnit::Db: return db;
    case GainUnit::Linear: return std::pow(10.0, db / 20.0);
    case GainUnit::Unknown: break;
  }
  return std::nullopt;
}

}  // namespace lp
