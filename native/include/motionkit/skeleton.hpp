// A skeleton and its motion as BVH files express them. Joints are stored
// depth-first (every parent index is smaller than its children's), end sites
// included, so every pass over a skeleton is one forward loop without
// recursion.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// A BVH channel. Rotations are Euler angles in degrees, composed in the order
// the joint lists them (intrinsic: "Zrotation Xrotation Yrotation" is
// R = Rz Rx Ry, scipy's 'ZXY'). Position channels give the joint's translation
// from its parent, in the parent's frame, replacing the OFFSET's component.
enum class ChannelType : std::uint8_t {
  kXposition = 0,
  kYposition = 1,
  kZposition = 2,
  kXrotation = 3,
  kYrotation = 4,
  kZrotation = 5,
};

inline bool IsRotation(ChannelType c) { return static_cast<int>(c) >= 3; }
// 0, 1, 2 for X, Y, Z.
inline int ChannelAxis(ChannelType c) { return static_cast<int>(c) % 3; }
// "Xposition", ..., "Zrotation".
const char* ChannelName(ChannelType c);

constexpr int kMaxChannelsPerJoint = 6;

struct Joint {
  std::string name;  // end sites are named "<parent>_end", the GAMES-105 convention
  int parent = -1;   // index into Skeleton::joints, smaller than this joint's; -1 for a root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // from the parent, in the parent's frame
  bool end_site = false;                            // BVH "End Site": no channels, no children
  int channel_count = 0;                            // 0 to 6
  std::array<ChannelType, kMaxChannelsPerJoint> channels{};  // in file order
  int first_channel = 0;  // column of channels[0] in a motion row
};

struct Skeleton {
  std::vector<Joint> joints;
  int channel_count = 0;  // columns of a motion row: the sum over joints

  // Parents before children, names unique and non-empty, end sites childless
  // and channel-less, channel columns contiguous in joint order, offsets finite.
  Status Validate() const;
  // Index of the joint with that name, or -1.
  int Find(std::string_view name) const;
};

struct Motion {
  double frame_time = 0.0;  // seconds per frame ("Frame Time:")
  RowMatrixXd values;       // frames x Skeleton::channel_count, as in the file (degrees)

  Eigen::Index frames() const { return values.rows(); }
};

}  // namespace motionkit
