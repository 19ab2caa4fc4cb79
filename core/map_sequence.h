// A recorded sequence of environment maps on disk: files named on the command line, or
// a directory standing for the maps inside it (.exr, .hdr, .pfm, in name order), with
// the capture times of its `timestamps.txt` when present (one time in seconds per map,
// in the maps' order; blank lines and lines starting with '#' are skipped; core/timestamps.h:
// plain decimals, strictly increasing).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace lp {

struct MapSequence {
  std::vector<std::string> files;
  std::optional<std::vector<double>> timestamps_s;  // one per file, when recorded
  bool is_sequence() const { return files.size() > 1; }
};

// Throws InputError naming the directory with no maps, or the timestamps file and line
// that is not one decimal time or not after the one before, or whose count differs from
// the maps'.
MapSequence find_map_sequence(const std::vector<std::string>& inputs);

// Probe images named, or inside the directories named (.exr .hdr .pfm .png .jpg .jpeg
// .tif .tiff, any case), in name order. Throws InputError naming a directory with none.
std::vector<std::string> find_images(const std::vector<std::string>& inputs);

}  // namespace lp
