// Machine-vision cameras (Mono12, BayerRG12 ...) saved to 16-bit PNG or TIFF keep their codes
// in the low bits: a highlight clipped at 4095 reads as 4095 / 65535, and whatever knows only
// 65535 as saturated takes it for a valid value (a fused bracket's brightest pixel came out at
// 1/900 of the truth's; an unwrap reported no clipped pixels). Shared by hdr/bracket (brackets)
// and probe/unwrap_sequence (single frames and sequences).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace lp {

struct SensorWhiteLevel {
  long code = 0;        // the code the clipping piles up at; 0: the codes are right as they are
  size_t at_top = 0;    // values at that code
};

// From 16-bit codes (values k / 65535, any channels): where they never reach the container's
// top half and pile up at their largest code (at least 16 values, and 1 in 10,000), and that
// code is a sensor's white level 2^N - 1 (N = 8 .. 15), that code.
// Without clipping, noise spreads the brightest values over many codes; a dark image that
// clips nowhere is left as it is (its codes are linear in the container's scale too).
SensorWhiteLevel find_sensor_white_level(const std::vector<const std::vector<float>*>& images);

// Codes read at that white level, in place: k >= code -> 1, else k / code.
void read_at_white_level(std::vector<float>& values, long code);

// The bits of a white level: 4095 -> 12.
int white_level_bits(long code);

// One white level for a sequence of 16-bit frames (probe unwrap, stream replay), decided at
// the first frame and kept: a frame that clips nowhere must not be read at another scale
// than its neighbours.
class SequenceWhiteLevel {
 public:
  // Reads a 16-bit frame's `values` at the sequence's white level, in place, and returns the
  // bits its codes now have (16: the container's own). The frame that finds a level says so
  // in one warning naming `file`; a later frame with codes above it throws InputError.
  int read(std::vector<float>& values, const std::string& file);

 private:
  long code_ = -1;  // -1 undecided, 0 the container's own
};

}  // namespace lp
