// Plain files: reading text (CSV, JSON, lists) and the rules that tell files apart by
// their extension. With core/image_io.h (images, maps, atomic writes) the only place the
// library opens files. Failures throw InputError naming the file and the problem.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace lp {

// The whole file as bytes. InputError "<path>: cannot open <what>: <reason>" when it cannot
// be read, or "<path>: larger than <max_bytes> bytes" (a text input that large is a mistake).
// max_bytes 0: the text-file limit of core/limits.h.
std::string read_text_file(const std::string& path, const std::string& what = "", size_t max_bytes = 0);

// The extension of the file name in `path`, lower case, with its dot (".exr"); "" when the
// name has none (a dot in a folder name does not count).
std::string lower_extension(const std::string& path);

// Image files by extension, case-insensitive. Radiance files hold floats read as stored
// (.exr, .hdr, .pic, .rgbe, .pfm); camera images hold code values (.png, .jpg, .jpeg,
// .tif, .tiff).
bool is_radiance_file(const std::string& path);
bool is_camera_image_file(const std::string& path);

// The order of a folder's frames: names compared with their runs of digits as numbers, so
// frame_2 comes before frame_10 (capture tools number frames without padding); names that
// differ only in leading zeros fall back to plain order. The order folders are read in.
bool frame_name_less(const std::string& a, const std::string& b);

// `text` without the blanks (spaces, tabs, line ends) around it.
std::string trim_blanks(std::string_view text);

// The number in `text` (surrounding blanks ignored), or nullopt when it is anything but one
// finite decimal number: "40%", "0x10", "0.10 lin", "nan" and "" are not numbers.
std::optional<double> parse_decimal(std::string_view text);

}  // namespace lp
