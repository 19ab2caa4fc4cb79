// What the command handlers share: parsing of option values and the table options of
// `tables` and `eval shading`. Every function throws lp::InputError naming the option (or
// the file) it refuses.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cli/command_table.h"
#include "core/envmap.h"
#include "core/vec3.h"
#include "probe/camera_codes.h"
#include "sampling/sampler.h"

namespace lp {
struct BoardSpec;
struct LightUnitsOptions;
struct ShadingOptions;
enum class ResponseCurve;
enum class Scenario;
}  // namespace lp

namespace lp::cli {

// --nside as given: 0 for the command's default, else check_nside; a negative one was
// taken for the default (healpix 64 or 32) with exit 0.
int given_nside(int nside);
// Comma-separated items, empty ones kept (so that "mis," names an empty estimator).
std::vector<std::string> split_commas(const std::string& text);
// --methods: comma-separated method names or "all".
std::vector<Method> parse_method_list(const std::string& text);
// --scenarios: comma-separated scenario names (eval/synthetic_sequence.h) or "all".
std::vector<Scenario> parse_scenarios(const std::string& text);
void parse_size(const std::string& text, const char* option, int* width, int* height);
// parse_size for an image or map size, within core/limits.h.
void parse_image_size(const std::string& text, const char* option, int* width, int* height);
std::vector<int> parse_int_list(const std::string& text, const char* option);
// parse_int_list of light counts, each within core/limits.h.
std::vector<int> parse_light_counts(const std::string& text, const char* option);
// --frames, --views and the like within core/limits.h (positivity is the caller's rule).
void check_frame_count(const char* option, long long count);
// --rotation: "yaw,pitch,roll" in degrees or 9 numbers (row-major world_from_probe), as parse_numbers reads them.
Mat3 parse_rotation(const std::string& text);
// --n of sample and stream: a positive count within core/limits.h, or 0 for "auto".
int light_count(const std::string& text);
// Comma-separated numbers ('1/40' allowed), exactly `count` of them (0: any).
std::vector<double> parse_numbers(const std::string& text, const char* option, size_t count = 0);
// --layout and friends: empty means "not given".
std::optional<Layout> optional_layout(const std::string& name, const char* option);
// Target (width, height) of convert/synth from --size/--nside for `layout`, like `like`
// when given (about as many pixels), else the layout's default; within core/limits.h.
// check_target_flags checks --size and --nside alone, before any input is read.
void target_geometry(Layout layout, const std::string& size, int nside, const EnvMap* like, int* w, int* h);
void check_target_flags(const std::string& size, int nside);
// --size with a healpix target, or --nside with another: refused, not ignored (a healpix
// unwrap took --size 64x32's... nothing, and --nside with latlong changed nothing).
void refuse_misplaced_geometry(Layout layout, const std::string& size, int nside);
// --board COLSxROWS inner corners and --square in mm.
BoardSpec board_from(const std::string& text, double square_mm);
// --response linear|gamma|scurve of the synthetic brackets.
ResponseCurve curve_from(const std::string& name);
// --codes: a curve's name (srgb, linear), or a camera response from `hdr response` (exp g(z)
// per level).
CodeCurve code_curve(const std::string& codes);

// --exposure, --scale, --normalize-illuminance: the units a relative map's lights or SH9 are
// exported in (sampling/light_units.h), shared by `sample` and `sh`.
struct UnitFlags {
  std::string exposure, scale, normalize_illuminance;  // empty: not given
  void declare(Flags& f);
  LightUnitsOptions options() const;
};

// The table options shared by `tables` and `eval shading` (Havran 2005 section 4).
struct ShadingTableArgs {
  std::string method = "pharr";     // a progressive sampler: pharr|hemigon
  int n = 256;                      // |H| (the lights of the diffuse tables)
  int low_per_high = 8;             // |L| / |H|
  int regions = 256;                // S_H culling regions
  int cone_regions = 512;           // S_L regions
  int lut = 64;                     // cube-map LUT texels per face edge
  double cone_deg = 8;              // cone half-angle gamma/2 around the reflected direction
  int k = 256;                      // at most k L lights per cone
  int q = 0;                        // clustering to at most Q lights (0: |H| / 4)
  bool region_copies = false;       // shader reads per-region copies instead of index lists
};
void declare_table_options(Flags& f, ShadingTableArgs& t);
// The validated table options (the messages name the option).
ShadingOptions shading_options(const ShadingTableArgs& t);
// --method of the tables: a progressive sampler (pharr or hemigon).
Method progressive_method(const std::string& name);

}  // namespace lp::cli
