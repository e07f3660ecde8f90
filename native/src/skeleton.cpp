#include "motionkit/skeleton.hpp"

#include <cmath>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>

namespace motionkit {
namespace {

std::string JointLabel(const Skeleton& skeleton, std::size_t index) {
  return "joint " + std::to_string(index) + " '" + skeleton.joints[index].name + "'";
}

}  // namespace

const char* ChannelName(ChannelType c) {
  switch (c) {
    case ChannelType::kXposition: return "Xposition";
    case ChannelType::kYposition: return "Yposition";
    case ChannelType::kZposition: return "Zposition";
    case ChannelType::kXrotation: return "Xrotation";
    case ChannelType::kYrotation: return "Yrotation";
    case ChannelType::kZrotation: return "Zrotation";
  }
  // A value cast from a corrupt integer: name it rather than crash on null.
  return "unknown";
}

Status Skeleton::Validate() const {
  // Parent and column indices are ints.
  if (joints.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    return Status::Fail("skeleton: " + std::to_string(joints.size()) + " joints are too many");
  }
  std::unordered_map<std::string_view, std::size_t> seen;
  seen.reserve(joints.size());
  long long column = 0;  // wide: the sum must not overflow before it is compared
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const Joint& joint = joints[i];
    if (joint.name.empty()) {
      return Status::Fail("skeleton: joint " + std::to_string(i) + " has an empty name");
    }
    const auto [it, inserted] = seen.emplace(joint.name, i);
    if (!inserted) {
      return Status::Fail("skeleton: joints " + std::to_string(it->second) + " and " +
                          std::to_string(i) + " are both named '" + joint.name + "'");
    }
    if (joint.parent < -1 || joint.parent >= static_cast<int>(i)) {
      return Status::Fail("skeleton: " + JointLabel(*this, i) + " has parent " +
                          std::to_string(joint.parent) +
                          "; a parent must come before its children (or be -1 for a root)");
    }
    if (joint.parent >= 0 && joints[static_cast<std::size_t>(joint.parent)].end_site) {
      return Status::Fail("skeleton: " + JointLabel(*this, i) + " is a child of end site '" +
                          joints[static_cast<std::size_t>(joint.parent)].name +
                          "'; end sites have no children");
    }
    if (joint.channel_count < 0 || joint.channel_count > kMaxChannelsPerJoint) {
      return Status::Fail("skeleton: " + JointLabel(*this, i) + " has " +
                          std::to_string(joint.channel_count) + " channels; 0 to 6 are allowed");
    }
    if (joint.end_site && joint.channel_count != 0) {
      return Status::Fail("skeleton: end site " + JointLabel(*this, i) + " has " +
                          std::to_string(joint.channel_count) + " channels; end sites have none");
    }
    for (int c = 0; c < joint.channel_count; ++c) {
      const int type = static_cast<int>(joint.channels[static_cast<std::size_t>(c)]);
      if (type < 0 || type > static_cast<int>(ChannelType::kZrotation)) {
        return Status::Fail("skeleton: " + JointLabel(*this, i) + " channel " + std::to_string(c) +
                            " has the unknown type " + std::to_string(type));
      }
    }
    if (joint.first_channel != column) {
      return Status::Fail("skeleton: " + JointLabel(*this, i) + " starts at column " +
                          std::to_string(joint.first_channel) + " but the joints before it use " +
                          std::to_string(column) + " columns (columns follow joint order)");
    }
    column += joint.channel_count;
    if (!joint.offset.allFinite()) {
      return Status::Fail("skeleton: " + JointLabel(*this, i) + " has a non-finite offset");
    }
  }
  if (channel_count != column) {
    return Status::Fail("skeleton: channel_count is " + std::to_string(channel_count) +
                        " but the joints have " + std::to_string(column) + " channels");
  }
  return Status::Ok();
}

int Skeleton::Find(std::string_view name) const {
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (joints[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace motionkit
