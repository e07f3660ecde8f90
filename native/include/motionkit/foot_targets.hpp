// Footskate cleanup's IK targets (docs/contacts.md): per contact of a foot
// point one plant (the point's mean over the contact), the point blended to
// the plant of its nearest contact by a smoothstep ramp over blend_frames
// frames on either side, a point not (fully) planted carried along with its
// foot's other point, and each foot's two targets put the distance apart that
// its two points keep on that frame (the correction shared in proportion to
// 1 - weight, so that a planted point does not move). The add-on's
// foot_contacts.py holds the same steps in numpy as the reference a test
// compares this job with.
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

using ConstBoolMatrixView =
    Eigen::Ref<const Eigen::Matrix<bool, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

// Caller-owned buffers; Run() allocates only per contact (plants, intervals)
// and one frames-long scratch for the feet's median span, never per frame.
//   points:   frames x 3P, P foot points (x y z each), finite
//   contacts: frames x P, true where a point stands
//   rigid:    (a, b) point pairs a bone's length apart (ankle, ball of one foot),
//             each point in at most one pair
//   targets:  frames x 3P out
//   weights:  frames x P out, 1 in contacts, 0 away from them
struct FootTargetsJob {
  FootTargetsJob(ConstMatrixView points_in, ConstBoolMatrixView contacts_in, int blend_frames_in,
                 std::vector<std::array<int, 2>> rigid_in, Eigen::Ref<RowMatrixXd> targets_out,
                 Eigen::Ref<RowMatrixXd> weights_out)
      : points(points_in),
        contacts(contacts_in),
        blend_frames(blend_frames_in),
        rigid(std::move(rigid_in)),
        targets(targets_out),
        weights(weights_out) {}

  ConstMatrixView points;
  ConstBoolMatrixView contacts;
  int blend_frames;
  std::vector<std::array<int, 2>> rigid;
  Eigen::Ref<RowMatrixXd> targets;
  Eigen::Ref<RowMatrixXd> weights;

  // Shapes agree, blend_frames >= 0, pairs name distinct points in range,
  // every point is finite (else names the point and frame).
  Status Validate() const;
  void Run();
};

}  // namespace motionkit
