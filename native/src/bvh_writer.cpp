// BVH writer. Numbers use std::to_chars' shortest form, which from_chars reads
// back to the same double, so ReadBvh(WriteBvh(x)) == x bit for bit.
#include <charconv>
#include <cmath>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "motionkit/bvh.hpp"

namespace motionkit {
namespace {

// Longest shortest-form double: "-2.2250738585072014e-308" is 24 characters.
constexpr std::size_t kMaxNumberChars = 32;

void AppendNumber(std::string* out, double value) {
  char buffer[kMaxNumberChars];
  const std::to_chars_result result = std::to_chars(buffer, buffer + sizeof buffer, value);
  out->append(buffer, static_cast<std::size_t>(result.ptr - buffer));
}

void AppendIndent(std::string* out, std::size_t depth) { out->append(depth, '\t'); }

std::string JointLabel(const Skeleton& skeleton, std::size_t index) {
  return "joint " + std::to_string(index) + " '" + skeleton.joints[index].name + "'";
}

// ReadBvh takes a name as the rest of its line up to a brace, trimmed.
bool IsWritableName(std::string_view name) {
  if (name.empty()) return false;
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\v' || c == '\f'; };
  if (blank(name.front()) || blank(name.back())) return false;
  return name.find_first_of("{}\r\n") == std::string_view::npos;
}

// Everything WriteBvh needs beyond Skeleton::Validate: BVH's own shape
// (depth-first blocks, end sites under a joint, names that survive a reading)
// and a motion that fits the skeleton.
void CheckWritable(const Skeleton& skeleton, const Motion& motion) {
  skeleton.Validate().ThrowIfFailed();
  if (skeleton.joints.empty()) throw Error("WriteBvh: the skeleton has no joints");
  std::vector<int> open;  // ancestors of the joint being checked, as the writer will nest them
  for (std::size_t i = 0; i < skeleton.joints.size(); ++i) {
    const Joint& joint = skeleton.joints[i];
    if (!joint.end_site && !IsWritableName(joint.name)) {
      throw Error("WriteBvh: " + JointLabel(skeleton, i) +
                  ": a BVH name cannot be blank at either end or hold braces or line breaks");
    }
    if (joint.end_site && joint.parent < 0) {
      throw Error("WriteBvh: " + JointLabel(skeleton, i) + " is an end site without a parent");
    }
    while (!open.empty() && open.back() != joint.parent) open.pop_back();
    if (joint.parent >= 0 && open.empty()) {
      throw Error("WriteBvh: " + JointLabel(skeleton, i) + " does not follow its parent '" +
                  skeleton.joints[static_cast<std::size_t>(joint.parent)].name +
                  "' depth-first; BVH nests every joint inside its parent's block");
    }
    open.push_back(static_cast<int>(i));
  }
  if (motion.values.cols() != skeleton.channel_count) {
    throw Error("WriteBvh: the motion has " + std::to_string(motion.values.cols()) +
                " columns but the skeleton has " + std::to_string(skeleton.channel_count) +
                " channels");
  }
  if (!std::isfinite(motion.frame_time) || motion.frame_time < 0.0) {
    throw Error("WriteBvh: the frame time must be finite and not negative, got " +
                std::to_string(motion.frame_time));
  }
  // Row-major: the scan is contiguous.
  for (Eigen::Index f = 0; f < motion.values.rows(); ++f) {
    for (Eigen::Index c = 0; c < motion.values.cols(); ++c) {
      if (std::isfinite(motion.values(f, c))) continue;
      std::size_t joint = 0;
      while (skeleton.joints[joint].first_channel + skeleton.joints[joint].channel_count <= c) {
        ++joint;
      }
      const Joint& owner = skeleton.joints[joint];
      throw Error("WriteBvh: frame " + std::to_string(f + 1) + ", column " + std::to_string(c) +
                  " (" + JointLabel(skeleton, joint) + " " +
                  ChannelName(owner.channels[static_cast<std::size_t>(c - owner.first_channel)]) +
                  ") is not finite");
    }
  }
}

void AppendHierarchy(const Skeleton& skeleton, std::string* out) {
  out->append("HIERARCHY\n");
  std::vector<int> open;
  const auto close = [&] {
    open.pop_back();
    AppendIndent(out, open.size());
    out->append("}\n");
  };
  for (std::size_t i = 0; i < skeleton.joints.size(); ++i) {
    const Joint& joint = skeleton.joints[i];
    while (!open.empty() && open.back() != joint.parent) close();
    const std::size_t depth = open.size();
    AppendIndent(out, depth);
    if (joint.end_site) {
      out->append("End Site\n");
    } else {
      out->append(joint.parent < 0 ? "ROOT " : "JOINT ");
      out->append(joint.name);
      out->push_back('\n');
    }
    AppendIndent(out, depth);
    out->append("{\n");
    AppendIndent(out, depth + 1);
    out->append("OFFSET");
    for (int axis = 0; axis < 3; ++axis) {
      out->push_back(' ');
      AppendNumber(out, joint.offset[axis]);
    }
    out->push_back('\n');
    if (!joint.end_site) {
      AppendIndent(out, depth + 1);
      out->append("CHANNELS ");
      out->append(std::to_string(joint.channel_count));
      for (int c = 0; c < joint.channel_count; ++c) {
        out->push_back(' ');
        out->append(ChannelName(joint.channels[static_cast<std::size_t>(c)]));
      }
      out->push_back('\n');
    }
    open.push_back(static_cast<int>(i));
  }
  while (!open.empty()) close();
}

void AppendMotion(const Motion& motion, std::string* out) {
  out->append("MOTION\nFrames: ");
  out->append(std::to_string(motion.values.rows()));
  out->append("\nFrame Time: ");
  AppendNumber(out, motion.frame_time);
  out->push_back('\n');
  const auto columns = static_cast<std::size_t>(motion.values.cols());
  for (Eigen::Index f = 0; f < motion.values.rows(); ++f) {
    // Format straight into the string: grow it by a row's worst case, then
    // trim to what was written.
    const std::size_t start = out->size();
    out->resize(start + columns * (kMaxNumberChars + 1) + 1);
    char* write = out->data() + start;
    char* const limit = out->data() + out->size();
    const double* row = motion.values.data() + static_cast<std::size_t>(f) * columns;
    for (std::size_t c = 0; c < columns; ++c) {
      if (c != 0) *write++ = ' ';
      write = std::to_chars(write, limit, row[c]).ptr;
    }
    *write++ = '\n';
    out->resize(static_cast<std::size_t>(write - out->data()));
  }
}

}  // namespace

std::string WriteBvh(const Skeleton& skeleton, const Motion& motion) {
  CheckWritable(skeleton, motion);
  std::string out;
  // About 20 characters a value; one allocation for a typical clip.
  out.reserve(skeleton.joints.size() * 96 + static_cast<std::size_t>(motion.values.size()) * 20 +
              64);
  AppendHierarchy(skeleton, &out);
  AppendMotion(motion, &out);
  return out;
}

}  // namespace motionkit
