// libFuzzer target for the BVH reader. Any input must either be rejected with
// motionkit::Error or give a valid clip that WriteBvh writes and ReadBvh reads
// back bit for bit. Anything else (a crash, a sanitizer report, another
// exception, a round trip that differs) is a finding: run tools/fuzz_bvh.sh.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "motionkit/bvh.hpp"

namespace {

using motionkit::Motion;
using motionkit::Skeleton;

[[noreturn]] void Finding(const char* what, const std::string& detail) {
  std::fprintf(stderr, "bvh_fuzz: %s: %s\n", what, detail.c_str());
  std::abort();
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Field by field; an empty string when equal, else what differs.
std::string Difference(const Skeleton& a, const Motion& am, const Skeleton& b, const Motion& bm) {
  if (a.joints.size() != b.joints.size()) return "joint count";
  if (a.channel_count != b.channel_count) return "channel count";
  for (std::size_t i = 0; i < a.joints.size(); ++i) {
    const motionkit::Joint& x = a.joints[i];
    const motionkit::Joint& y = b.joints[i];
    if (x.name != y.name || x.parent != y.parent || x.end_site != y.end_site ||
        x.channel_count != y.channel_count || x.first_channel != y.first_channel ||
        x.channels != y.channels) {
      return "joint " + std::to_string(i);
    }
    for (int k = 0; k < 3; ++k) {
      if (!SameBits(x.offset[k], y.offset[k])) return "offset of joint " + std::to_string(i);
    }
  }
  if (!SameBits(am.frame_time, bm.frame_time)) return "frame time";
  if (am.values.rows() != bm.values.rows() || am.values.cols() != bm.values.cols()) {
    return "motion shape";
  }
  for (Eigen::Index k = 0; k < am.values.size(); ++k) {
    if (!SameBits(am.values.data()[k], bm.values.data()[k])) return "value " + std::to_string(k);
  }
  return {};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  Skeleton skeleton;
  Motion motion;
  try {
    motionkit::ReadBvh(text, "fuzz.bvh", &skeleton, &motion);
  } catch (const motionkit::Error& error) {
    // Rejected: the message must carry a position.
    if (std::strncmp(error.what(), "fuzz.bvh:", 9) != 0)
      Finding("message without position", error.what());
    return 0;
  }
  const motionkit::Status valid = skeleton.Validate();
  if (!valid) Finding("ReadBvh returned an invalid skeleton", valid.message());
  if (motion.values.cols() != skeleton.channel_count)
    Finding("motion columns", "differ from channels");

  std::string written;
  Skeleton skeleton2;
  Motion motion2;
  try {
    written = motionkit::WriteBvh(skeleton, motion);
  } catch (const motionkit::Error& error) {
    Finding("WriteBvh rejected what ReadBvh accepted", error.what());
  }
  try {
    motionkit::ReadBvh(written, "fuzz.bvh", &skeleton2, &motion2);
  } catch (const motionkit::Error& error) {
    Finding("ReadBvh rejected what WriteBvh wrote", error.what());
  }
  const std::string difference = Difference(skeleton, motion, skeleton2, motion2);
  if (!difference.empty()) Finding("round trip changed the clip", difference);
  return 0;
}
