// Reading and writing BVH motion capture files.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "motionkit/error.hpp"
#include "motionkit/skeleton.hpp"

namespace motionkit {

// Caps that bound what a file may make us allocate or recurse through; a file
// beyond them is rejected with a message naming the cap, before allocating.
struct BvhLimits {
  int max_joints = 10000;            // joints including end sites
  int max_depth = 256;               // nesting of JOINT blocks
  std::size_t max_frames = 50000000;
  std::size_t max_values = 500000000;  // frames x channels
};

// Parses BVH text. `source` names the file in messages, which read
// "<source>:<line>:<column>: <what> (saw '<token>')".
// Accepts CRLF, CR-only and LF line ends, tabs, blank lines, trailing spaces
// and a missing final newline; several ROOTs; 0 to 6 channels in any order on
// any joint. Throws Error on anything malformed; never crashes.
void ReadBvh(std::string_view text, std::string_view source, Skeleton* skeleton, Motion* motion,
             const BvhLimits& limits = BvhLimits());

// Writes skeleton and motion as BVH text such that ReadBvh gives back exactly
// the same numbers (shortest round-trip formatting). Throws Error when the
// skeleton does not validate or the motion does not fit it.
std::string WriteBvh(const Skeleton& skeleton, const Motion& motion);

}  // namespace motionkit
