// Reading a body's field through one carrier bone's motion: the read BodySampleJob and BodyArmJob share.
// Internal to native/src.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>

#include "motionkit/body_sample.hpp"
#include "motionkit/types.hpp"

namespace motionkit::internal {

// How a carrier bone has moved on one frame: a point p of the armature's space is at
// to_rest * (p - head) + rest_head in the field's rest space.
struct CarrierMotion {
  int bone;
  Eigen::Quaterniond to_rest;
  Eigen::Vector3d head;
  Eigen::Vector3d rest_head;
  Eigen::Vector3i low, high;  // the box of the cells it owns (the whole grid where none is given)
  Eigen::Vector3d centre;     // that box's ball where the pose has it (armature space), and its radius squared
  double reach_squared;
  Eigen::Matrix3d to_cells;   // p's place in the grid's cells at rest: to_cells p + shift
  Eigen::Vector3d shift;
};

// The field's carrier c (an index into field.carriers) as the pose (orientations frames x 4B, heads
// frames x 3B) has it on frame.
CarrierMotion Motion(const BodyFieldView& field, std::size_t c, const ConstMatrixView& orientations,
                     const ConstMatrixView& heads, Eigen::Index frame);

// The trilinear distance at p (the armature's space) read through the carrier's motion where it owns the
// nearest cell, and its gradient in the armature's space when slope is given; +inf (the slope untouched)
// off the grid or where another bone owns the cell.
double ReadThrough(const BodyFieldView& field, const CarrierMotion& motion, const Eigen::Vector3d& p,
                   Eigen::Vector3d* slope);

}  // namespace motionkit::internal
