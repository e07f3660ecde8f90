// Packing of keyframe data into the layout Blender's F-curves take in bulk
// (keyframe_points.foreach_set("co", ...)): per curve, interleaved
// [frame0, value0, frame1, value1, ...] as 32-bit floats.
#pragma once

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Interleaves one shared frame column with many value rows.
//   frames: n key times, strictly increasing, finite.
//   values: c × n, row k holds curve k's values, finite.
//   co:     c × 2n, caller-owned output.
// Validate() rejects non-finite input naming the curve and key, so NaN and
// infinity never reach an F-curve.
struct KeyframeCoJob {
  KeyframeCoJob(ConstVectorView frames_in, ConstMatrixView values_in, MatrixViewF co_out)
      : frames(frames_in), values(values_in), co(co_out) {}

  ConstVectorView frames;
  ConstMatrixView values;
  MatrixViewF co;

  Status Validate() const;
  // Fills co; throws Error when Validate() fails.
  void Run();
};

}  // namespace motionkit
