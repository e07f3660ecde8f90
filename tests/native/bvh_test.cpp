#include "motionkit/bvh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <string_view>

namespace motionkit {
namespace {

struct Parsed {
  Skeleton skeleton;
  Motion motion;
};

Parsed Read(std::string_view text, const BvhLimits& limits = BvhLimits()) {
  Parsed parsed;
  ReadBvh(text, "test.bvh", &parsed.skeleton, &parsed.motion, limits);
  return parsed;
}

// The message ReadBvh throws, or "no error".
std::string ErrorOf(std::string_view text, const BvhLimits& limits = BvhLimits()) {
  try {
    Read(text, limits);
  } catch (const Error& error) {
    return error.what();
  }
  return "no error";
}

std::string Lines(std::initializer_list<std::string_view> lines) {
  std::string text;
  for (std::string_view line : lines) {
    text.append(line);
    text.push_back('\n');
  }
  return text;
}

std::string Replace(std::string text, std::string_view from, std::string_view to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// Numbered so that tests can spell positions out; the rows are lines 19 and 20.
const std::string kTwoJoints = Lines({
    "HIERARCHY",                                                                 // 1
    "ROOT Hips",                                                                 // 2
    "{",                                                                         // 3
    "  OFFSET 0 0 0",                                                            // 4
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",  // 5
    "  JOINT Chest",                                                             // 6
    "  {",                                                                       // 7
    "    OFFSET 0 5.5 -1",                                                       // 8
    "    CHANNELS 3 Zrotation Xrotation Yrotation",                              // 9
    "    End Site",                                                              // 10
    "    {",                                                                     // 11
    "      OFFSET 0 3 0",                                                        // 12
    "    }",                                                                     // 13
    "  }",                                                                       // 14
    "}",                                                                         // 15
    "MOTION",                                                                    // 16
    "Frames: 2",                                                                 // 17
    "Frame Time: 0.0333333",                                                     // 18
    "1 2 3 4 5 6 7 8 9",                                                         // 19
    "10 11 12 13 14 15 16 17 18",                                                // 20
});

using C = ChannelType;

void ExpectChannels(const Joint& joint, std::initializer_list<ChannelType> expected) {
  ASSERT_EQ(joint.channel_count, static_cast<int>(expected.size())) << joint.name;
  int c = 0;
  for (ChannelType type : expected) {
    EXPECT_EQ(joint.channels[static_cast<std::size_t>(c)], type) << joint.name << " channel " << c;
    ++c;
  }
}

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void ExpectSame(const Parsed& a, const Parsed& b) {
  ASSERT_EQ(a.skeleton.joints.size(), b.skeleton.joints.size());
  EXPECT_EQ(a.skeleton.channel_count, b.skeleton.channel_count);
  for (std::size_t i = 0; i < a.skeleton.joints.size(); ++i) {
    const Joint& x = a.skeleton.joints[i];
    const Joint& y = b.skeleton.joints[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.parent, y.parent) << x.name;
    EXPECT_EQ(x.end_site, y.end_site) << x.name;
    EXPECT_EQ(x.channel_count, y.channel_count) << x.name;
    for (int c = 0; c < std::min(x.channel_count, y.channel_count); ++c) {
      EXPECT_EQ(x.channels[static_cast<std::size_t>(c)], y.channels[static_cast<std::size_t>(c)])
          << x.name << " channel " << c;
    }
    EXPECT_EQ(x.first_channel, y.first_channel) << x.name;
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(SameBits(x.offset[k], y.offset[k])) << x.name;
  }
  EXPECT_TRUE(SameBits(a.motion.frame_time, b.motion.frame_time));
  ASSERT_EQ(a.motion.values.rows(), b.motion.values.rows());
  ASSERT_EQ(a.motion.values.cols(), b.motion.values.cols());
  for (Eigen::Index i = 0; i < a.motion.values.size(); ++i) {
    ASSERT_TRUE(SameBits(a.motion.values.data()[i], b.motion.values.data()[i]))
        << "value " << i << ": " << a.motion.values.data()[i] << " vs "
        << b.motion.values.data()[i];
  }
}

// ---- Layouts -------------------------------------------------------------------

TEST(ReadBvh, ReadsJointsEndSitesChannelsAndRows) {
  const Parsed p = Read(kTwoJoints);
  const auto& joints = p.skeleton.joints;
  ASSERT_EQ(joints.size(), 3u);
  EXPECT_EQ(joints[0].name, "Hips");
  EXPECT_EQ(joints[0].parent, -1);
  EXPECT_FALSE(joints[0].end_site);
  EXPECT_EQ(joints[0].offset, Eigen::Vector3d(0, 0, 0));
  ExpectChannels(joints[0], {C::kXposition, C::kYposition, C::kZposition, C::kZrotation,
                             C::kXrotation, C::kYrotation});
  EXPECT_EQ(joints[0].first_channel, 0);
  EXPECT_EQ(joints[1].name, "Chest");
  EXPECT_EQ(joints[1].parent, 0);
  EXPECT_EQ(joints[1].offset, Eigen::Vector3d(0, 5.5, -1));
  ExpectChannels(joints[1], {C::kZrotation, C::kXrotation, C::kYrotation});
  EXPECT_EQ(joints[1].first_channel, 6);
  EXPECT_EQ(joints[2].name, "Chest_end");
  EXPECT_EQ(joints[2].parent, 1);
  EXPECT_TRUE(joints[2].end_site);
  EXPECT_EQ(joints[2].channel_count, 0);
  EXPECT_EQ(joints[2].first_channel, 9);
  EXPECT_EQ(joints[2].offset, Eigen::Vector3d(0, 3, 0));
  EXPECT_EQ(p.skeleton.channel_count, 9);
  EXPECT_TRUE(p.skeleton.Validate()) << p.skeleton.Validate().message();
  EXPECT_EQ(p.motion.frame_time, 0.0333333);
  ASSERT_EQ(p.motion.frames(), 2);
  ASSERT_EQ(p.motion.values.cols(), 9);
  for (int f = 0; f < 2; ++f) {
    for (int c = 0; c < 9; ++c) EXPECT_EQ(p.motion.values(f, c), 9 * f + c + 1);
  }
}

TEST(ReadBvh, ReadsChannelsInAnyOrderAndCount) {
  const Parsed p = Read(Lines({
      "HIERARCHY",
      "ROOT A",
      "{",
      "  OFFSET 1 2 3",
      "  CHANNELS 2 Yrotation Zposition",
      "  JOINT B",
      "  {",
      "    OFFSET 0 0 0",
      "    CHANNELS 5 Zrotation Xposition Yrotation Yposition Xrotation",
      "    JOINT C",
      "    {",
      "      OFFSET 0 0 0",
      "      CHANNELS 1 Xrotation",
      "    }",
      "  }",
      "}",
      "MOTION",
      "Frames: 1",
      "Frame Time: 0.01",
      "1 2 3 4 5 6 7 8",
  }));
  const auto& joints = p.skeleton.joints;
  ASSERT_EQ(joints.size(), 3u);
  ExpectChannels(joints[0], {C::kYrotation, C::kZposition});
  ExpectChannels(joints[1],
                 {C::kZrotation, C::kXposition, C::kYrotation, C::kYposition, C::kXrotation});
  ExpectChannels(joints[2], {C::kXrotation});
  EXPECT_EQ(joints[1].first_channel, 2);
  EXPECT_EQ(joints[2].first_channel, 7);
  EXPECT_EQ(p.skeleton.channel_count, 8);
  EXPECT_EQ(p.motion.values(0, 7), 8);
}

TEST(ReadBvh, ReadsPositionChannelsOnNonRootJoints) {
  const Parsed p = Read(Replace(kTwoJoints, "CHANNELS 3 Zrotation Xrotation Yrotation",
                                "CHANNELS 3 Xposition Yposition Zposition"));
  ExpectChannels(p.skeleton.joints[1], {C::kXposition, C::kYposition, C::kZposition});
  EXPECT_EQ(p.motion.values(1, 8), 18);
}

TEST(ReadBvh, ReadsJointsWithoutChannels) {
  // "CHANNELS 0" and no CHANNELS line at all mean the same.
  const std::string text = Lines({
      "HIERARCHY",
      "ROOT A",
      "{",
      "  OFFSET 0 0 0",
      "  CHANNELS 0",
      "  JOINT B",
      "  {",
      "    OFFSET 1 0 0",
      "    CHANNELS 3 Xrotation Yrotation Zrotation",
      "    JOINT C",
      "    {",
      "      OFFSET 1 0 0",
      "    }",
      "  }",
      "}",
      "MOTION",
      "Frames: 2",
      "Frame Time: 0.5",
      "1 2 3",
      "4 5 6",
  });
  const Parsed p = Read(text);
  ASSERT_EQ(p.skeleton.joints.size(), 3u);
  EXPECT_EQ(p.skeleton.joints[0].channel_count, 0);
  EXPECT_EQ(p.skeleton.joints[1].first_channel, 0);
  EXPECT_EQ(p.skeleton.joints[2].channel_count, 0);
  EXPECT_EQ(p.skeleton.joints[2].first_channel, 3);
  EXPECT_FALSE(p.skeleton.joints[2].end_site);
  EXPECT_EQ(p.motion.values(1, 2), 6);
}

TEST(ReadBvh, ReadsAClipWithNoChannelsAtAll) {
  const Parsed p = Read(Lines({"HIERARCHY", "ROOT A", "{", "OFFSET 0 0 0", "}", "MOTION",
                               "Frames: 3", "Frame Time: 0.1", "", "", ""}));
  EXPECT_EQ(p.skeleton.channel_count, 0);
  EXPECT_EQ(p.motion.frames(), 3);
  EXPECT_EQ(p.motion.values.cols(), 0);
}

TEST(ReadBvh, ReadsZeroFrames) {
  const Parsed p = Read(Replace(Replace(kTwoJoints, "Frames: 2", "Frames: 0"),
                                "1 2 3 4 5 6 7 8 9\n10 11 12 13 14 15 16 17 18\n", ""));
  EXPECT_EQ(p.motion.frames(), 0);
  EXPECT_EQ(p.motion.values.cols(), 9);
}

TEST(ReadBvh, ReadsSeveralRoots) {
  const Parsed p = Read(Lines({
      "HIERARCHY",
      "ROOT A",
      "{",
      "  OFFSET 0 0 0",
      "  CHANNELS 3 Xposition Yposition Zposition",
      "  End Site",
      "  {",
      "    OFFSET 0 1 0",
      "  }",
      "}",
      "ROOT B",
      "{",
      "  OFFSET 5 0 0",
      "  CHANNELS 1 Zrotation",
      "  JOINT B1",
      "  {",
      "    OFFSET 0 1 0",
      "    CHANNELS 1 Xrotation",
      "  }",
      "}",
      "MOTION",
      "Frames: 1",
      "Frame Time: 0.04",
      "1 2 3 4 5",
  }));
  const auto& joints = p.skeleton.joints;
  ASSERT_EQ(joints.size(), 4u);
  EXPECT_EQ(joints[1].name, "A_end");
  EXPECT_EQ(joints[2].name, "B");
  EXPECT_EQ(joints[2].parent, -1);
  EXPECT_EQ(joints[2].first_channel, 3);
  EXPECT_EQ(joints[3].parent, 2);
  EXPECT_EQ(joints[3].first_channel, 4);
  EXPECT_EQ(p.motion.values(0, 4), 5);
}

TEST(ReadBvh, ToleratesLineEndsTabsBlankLinesAndTrailingSpaces) {
  const Parsed lf = Read(kTwoJoints);
  std::string crlf, cr;
  for (char c : kTwoJoints) {
    crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    cr += c == '\n' ? '\r' : c;
  }
  ExpectSame(Read(crlf), lf);
  ExpectSame(Read(cr), lf);
  std::string mixed = kTwoJoints;
  for (std::size_t i = 0, n = 0; i < mixed.size(); ++i) {
    if (mixed[i] != '\n') continue;
    if (n % 3 == 1) mixed.replace(i, 1, "\r\n"), ++i;
    if (n % 3 == 2) mixed[i] = '\r';
    ++n;
  }
  ExpectSame(Read(mixed), lf);
  std::string tabs;
  for (char c : kTwoJoints) tabs += c == ' ' ? std::string("\t \t") : std::string(1, c);
  ExpectSame(Read(tabs), lf);
  std::string loose;
  for (char c : kTwoJoints) loose += c == '\n' ? std::string("  \t\n\n \n") : std::string(1, c);
  ExpectSame(Read("\n\n" + loose), lf);
  ExpectSame(Read(kTwoJoints.substr(0, kTwoJoints.size() - 1)), lf);  // no final newline
  ExpectSame(Read(crlf.substr(0, crlf.size() - 2) + "   "), lf);
  ExpectSame(Read("\xEF\xBB\xBF" + kTwoJoints), lf);  // UTF-8 byte order mark
}

TEST(ReadBvh, ReadsBracesOnTheNameLineAndNamesWithSpaces) {
  const Parsed p = Read(Lines({
      "HIERARCHY",
      "ROOT Bip01 {",
      "  OFFSET 0 0 0 CHANNELS 1 Xrotation",
      "  JOINT Bip01  L\tThigh{ OFFSET 1 2 3 }",
      "}",
      "MOTION",
      "Frames: 1",
      "Frame Time: 1",
      "7",
  }));
  ASSERT_EQ(p.skeleton.joints.size(), 2u);
  EXPECT_EQ(p.skeleton.joints[0].name, "Bip01");
  EXPECT_EQ(p.skeleton.joints[1].name, "Bip01  L\tThigh");
  EXPECT_EQ(p.skeleton.joints[1].offset, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(p.motion.values(0, 0), 7);
}

TEST(ReadBvh, ReadsNumberSpellings) {
  const Parsed p = Read(
      Replace(Replace(kTwoJoints, "1 2 3 4 5 6 7 8 9", "+1 -2 3. .5 -.25 1e3 -2.5E-2 +0.125e+1 -0"),
              "OFFSET 0 5.5 -1", "OFFSET +0 5.5e0 -1."));
  const double expected[] = {1, -2, 3, 0.5, -0.25, 1000, -0.025, 1.25, -0.0};
  for (int c = 0; c < 9; ++c) EXPECT_TRUE(SameBits(p.motion.values(0, c), expected[c])) << c;
  EXPECT_EQ(p.skeleton.joints[1].offset, Eigen::Vector3d(0, 5.5, -1));
}

// ---- The real files ------------------------------------------------------------

// The GAMES-105 files live outside the repository. Missing, they fail the
// test on CI (CI=true) and skip it elsewhere.
bool LoadSharedFile(const std::string& name, std::string* text) {
  const std::string path = std::string(MOTIONKIT_SHARED_BVH_DIR) + "/" + name;
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  *text = buffer.str();
  return true;
}

bool OnCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string_view(ci) == "true";
}

#define LOAD_SHARED_OR_SKIP(name, text)                                                          \
  do {                                                                                           \
    if (!LoadSharedFile(name, text)) {                                                           \
      const std::string message = std::string("cannot read ") + MOTIONKIT_SHARED_BVH_DIR + "/" + \
                                  name + " (the shared GAMES-105 data)";                         \
      if (OnCi()) FAIL() << message << "; CI=true requires it";                                  \
      GTEST_SKIP() << message;                                                                   \
    }                                                                                            \
  } while (false)

void ExpectGames105Skeleton(const Skeleton& skeleton) {
  // 20 joints and 5 end sites; the root has 6 channels, the others 3.
  ASSERT_EQ(skeleton.joints.size(), 25u);
  EXPECT_EQ(skeleton.channel_count, 6 + 19 * 3);
  EXPECT_TRUE(skeleton.Validate()) << skeleton.Validate().message();
  int end_sites = 0;
  for (const Joint& joint : skeleton.joints) {
    if (joint.end_site) {
      ++end_sites;
      EXPECT_EQ(joint.name, skeleton.joints[static_cast<std::size_t>(joint.parent)].name + "_end");
    } else {
      ExpectChannels(
          joint,
          joint.parent < 0
              ? std::initializer_list<ChannelType>{C::kXposition, C::kYposition, C::kZposition,
                                                   C::kXrotation, C::kYrotation, C::kZrotation}
              : std::initializer_list<ChannelType>{C::kXrotation, C::kYrotation, C::kZrotation});
    }
  }
  EXPECT_EQ(end_sites, 5);
  EXPECT_EQ(skeleton.joints[0].name, "RootJoint");
}

TEST(ReadBvh, ReadsWalk60) {
  std::string text;
  LOAD_SHARED_OR_SKIP("walk60.bvh", &text);
  Parsed p;
  ReadBvh(text, "walk60.bvh", &p.skeleton, &p.motion);
  ExpectGames105Skeleton(p.skeleton);
  const auto& joints = p.skeleton.joints;
  EXPECT_EQ(joints[1].name, "lHip");
  EXPECT_EQ(joints[1].offset, Eigen::Vector3d(0.1, -0.051395, 0.0));
  EXPECT_EQ(joints[5].name, "lToeJoint_end");
  EXPECT_EQ(joints[5].parent, 4);
  EXPECT_EQ(joints[5].offset, Eigen::Vector3d(0.01, 0.002, 0.06));
  EXPECT_EQ(p.motion.frames(), 182);
  EXPECT_EQ(p.motion.values.cols(), 63);
  // The file says 0.016667: 1/60 to the six decimals it keeps.
  EXPECT_EQ(p.motion.frame_time, 0.016667);
  EXPECT_NEAR(p.motion.frame_time, 1.0 / 60.0, 1e-6);
  EXPECT_EQ(p.motion.values(0, 0), -0.001735);
  EXPECT_EQ(p.motion.values(0, 1), 0.855388);
  EXPECT_EQ(p.motion.values(181, 62), 1.565413);
  ExpectSame(Read(WriteBvh(p.skeleton, p.motion)), p);
}

TEST(ReadBvh, ReadsRunForward) {
  std::string text;
  LOAD_SHARED_OR_SKIP("run_forward.bvh", &text);
  Parsed p;
  ReadBvh(text, "run_forward.bvh", &p.skeleton, &p.motion);
  ExpectGames105Skeleton(p.skeleton);
  EXPECT_EQ(p.skeleton.joints[1].name, "pelvis_lowerback");
  EXPECT_EQ(p.skeleton.joints[4].name, "torso_head_end");
  EXPECT_EQ(p.skeleton.joints[4].offset, Eigen::Vector3d(0.0, 0.19265, 0.0));
  EXPECT_EQ(p.motion.frames(), 45);
  EXPECT_EQ(p.motion.values.cols(), 63);
  EXPECT_EQ(p.motion.frame_time, 0.016667);
  EXPECT_EQ(p.motion.values(0, 0), -5.480003);
  EXPECT_EQ(p.motion.values(44, 62), -0.046088);
  ExpectSame(Read(WriteBvh(p.skeleton, p.motion)), p);
}

// ---- Malformed files: one message each, with line and column --------------------

TEST(ReadBvhErrors, EmptyFile) {
  EXPECT_EQ(ErrorOf(""), "test.bvh:1:1: expected HIERARCHY (saw end of file)");
  EXPECT_EQ(ErrorOf(std::string_view()), "test.bvh:1:1: expected HIERARCHY (saw end of file)");
  EXPECT_EQ(ErrorOf("\n  \r\n\t"), "test.bvh:3:2: expected HIERARCHY (saw end of file)");
}

TEST(ReadBvhErrors, NotABvhFile) {
  EXPECT_EQ(ErrorOf("  hello world"), "test.bvh:1:3: expected HIERARCHY (saw 'hello')");
}

TEST(ReadBvhErrors, HierarchyWithoutRoot) {
  EXPECT_EQ(ErrorOf("HIERARCHY\nMOTION\n"), "test.bvh:2:1: expected ROOT (saw 'MOTION')");
}

TEST(ReadBvhErrors, TruncatedInOffset) {
  const std::string text = kTwoJoints.substr(0, kTwoJoints.find("5.5 -1") + 3);
  EXPECT_EQ(ErrorOf(text), "test.bvh:8:17: expected a number for OFFSET (saw end of file)");
}

TEST(ReadBvhErrors, TruncatedInChannels) {
  const std::string text = kTwoJoints.substr(0, kTwoJoints.find("Xrotation Yrotation\n    End"));
  EXPECT_EQ(ErrorOf(text), "test.bvh:9:26: expected a channel name (saw end of file)");
}

TEST(ReadBvhErrors, TruncatedInsideABlock) {
  const std::string text = kTwoJoints.substr(0, kTwoJoints.find("}\nMOTION"));
  EXPECT_EQ(ErrorOf(text), "test.bvh:15:1: expected '}' to close joint 'Hips' (saw end of file)");
}

TEST(ReadBvhErrors, TruncatedBeforeMotion) {
  const std::string text = kTwoJoints.substr(0, kTwoJoints.find("MOTION"));
  EXPECT_EQ(ErrorOf(text), "test.bvh:16:1: expected ROOT or MOTION (saw end of file)");
}

TEST(ReadBvhErrors, TruncatedInMotionHeader) {
  EXPECT_EQ(ErrorOf(kTwoJoints.substr(0, kTwoJoints.find("Frames:"))),
            "test.bvh:17:1: expected 'Frames:' (saw end of file)");
  EXPECT_EQ(ErrorOf(kTwoJoints.substr(0, kTwoJoints.find(" 2\nFrame T"))),
            "test.bvh:17:8: expected a frame count (saw end of file)");
  EXPECT_EQ(ErrorOf(kTwoJoints.substr(0, kTwoJoints.find("Time:"))),
            "test.bvh:18:7: expected 'Frame Time:' (saw end of file)");
  EXPECT_EQ(ErrorOf(kTwoJoints.substr(0, kTwoJoints.find(" 0.0333333"))),
            "test.bvh:18:12: expected a number for the frame time (saw end of file)");
}

TEST(ReadBvhErrors, FewerRowsThanFrames) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: 3")),
            "test.bvh:21:1: the file ends after 2 of 3 frames (saw end of file)");
}

TEST(ReadBvhErrors, TruncatedInARow) {
  const std::string text = kTwoJoints.substr(0, kTwoJoints.find(" 15 16"));
  EXPECT_EQ(ErrorOf(text),
            "test.bvh:20:15: frame 2 of 2 has 5 values, expected 9 (saw end of file)");
}

TEST(ReadBvhErrors, MoreRowsThanFrames) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: 1")),
            "test.bvh:20:1: more frame rows than 'Frames: 1' declares (saw '10')");
  EXPECT_EQ(ErrorOf(kTwoJoints + "\n  19\n"),
            "test.bvh:22:3: more frame rows than 'Frames: 2' declares (saw '19')");
}

TEST(ReadBvhErrors, TextAfterTheLastFrame) {
  EXPECT_EQ(ErrorOf(kTwoJoints + "MOTION\n"),
            "test.bvh:21:1: unexpected text after the last frame (saw 'MOTION')");
}

TEST(ReadBvhErrors, RowWithTooFewValues) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "10 11 12 13 14 15 16 17 18", "10 11 12 13 14 15 16 17  ")),
            "test.bvh:20:26: frame 2 of 2 has 8 values, expected 9 (saw end of line)");
}

TEST(ReadBvhErrors, RowSplitOverTwoLines) {
  // Rows are line-based: a frame's values must all be on its line.
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4 5 6 7 8 9", "1 2 3 4\r\n5 6 7 8 9")),
            "test.bvh:19:8: frame 1 of 2 has 4 values, expected 9 (saw end of line)");
}

TEST(ReadBvhErrors, RowWithTooManyValues) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4 5 6 7 8 9", "1 2 3 4 5 6 7 8 9 99 x 7")),
            "test.bvh:19:19: frame 1 of 2 has 12 values, expected 9 (saw '99')");
}

TEST(ReadBvhErrors, NonNumericValue) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 abc 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw 'abc')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 3.5.1 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw '3.5.1')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 3,5 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw '3,5')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 +-3 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw '+-3')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 0x1F 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw '0x1F')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "1 2 3 4", "1 2 3} 4")),
            "test.bvh:19:5: frame 1 of 2, value 3: expected a number (saw '3}')");
}

TEST(ReadBvhErrors, NonFiniteValue) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "16 17", "16 nan")),
            "test.bvh:20:22: frame 2 of 2, value 8: value is not finite (saw 'nan')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "16 17", "16 -inf")),
            "test.bvh:20:22: frame 2 of 2, value 8: value is not finite (saw '-inf')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "16 17", "16 +Infinity")),
            "test.bvh:20:22: frame 2 of 2, value 8: value is not finite (saw '+Infinity')");
  EXPECT_EQ(
      ErrorOf(Replace(kTwoJoints, "16 17", "16 1e999")),
      "test.bvh:20:22: frame 2 of 2, value 8: number out of range for a double (saw '1e999')");
}

TEST(ReadBvhErrors, NonFiniteOffset) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "OFFSET 0 3 0", "OFFSET 0 NaN 0")),
            "test.bvh:12:16: OFFSET is not finite (saw 'NaN')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "OFFSET 0 3 0", "OFFSET 0 Y 0")),
            "test.bvh:12:16: expected a number for OFFSET (saw 'Y')");
}

TEST(ReadBvhErrors, UnknownKeyword) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "    End Site", "    ROTATION 1")),
            "test.bvh:10:5: unknown keyword in joint 'Chest' (saw 'ROTATION')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "HIERARCHY", "HIERARCHY\nHIERARCHY")),
            "test.bvh:2:1: expected ROOT (saw 'HIERARCHY')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "MOTION", "MOTIONS")),
            "test.bvh:16:1: expected ROOT or MOTION (saw 'MOTIONS')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames 2")),
            "test.bvh:17:1: expected 'Frames:' (saw 'Frames')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frame Time:", "FrameTime:")),
            "test.bvh:18:1: expected 'Frame Time:' (saw 'FrameTime:')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "End Site", "End Sight")),
            "test.bvh:10:9: expected 'Site' after 'End' (saw 'Sight')");
}

TEST(ReadBvhErrors, KeywordsOutOfPlace) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "  JOINT Chest", "  OFFSET 1 1 1\n  JOINT Chest")),
            "test.bvh:6:3: unexpected OFFSET in joint 'Hips': it comes once, right after '{' "
            "(saw 'OFFSET')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "  }\n}", "  }\n  CHANNELS 0\n}")),
            "test.bvh:15:3: unexpected CHANNELS in joint 'Hips': they come once, right after "
            "OFFSET (saw 'CHANNELS')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "    OFFSET 0 5.5 -1\n", "")),
            "test.bvh:8:5: expected OFFSET in joint 'Chest' (saw 'CHANNELS')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "      OFFSET 0 3 0", "      OFFSET 0 3 0 CHANNELS 0")),
            "test.bvh:12:20: expected '}' to close the End Site of 'Chest' (saw 'CHANNELS')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "      OFFSET 0 3 0", "      OFFSET 0 3 0 JOINT X")),
            "test.bvh:12:20: expected '}' to close the End Site of 'Chest' (saw 'JOINT')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "  JOINT Chest", "  ROOT Chest")),
            "test.bvh:6:3: expected '}' to close joint 'Hips' (saw 'ROOT')");
}

TEST(ReadBvhErrors, UnbalancedBraces) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "}\nMOTION", "}\n}\nMOTION")),
            "test.bvh:16:1: unbalanced '}': no joint is open (saw '}')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "  }\n}\nMOTION", "  }\nMOTION")),
            "test.bvh:15:1: expected '}' to close joint 'Hips' (saw 'MOTION')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "ROOT Hips\n{", "ROOT Hips\n{\n{")),
            "test.bvh:4:1: expected OFFSET in joint 'Hips' (saw '{')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "  JOINT Chest\n  {", "  JOINT Chest\n")),
            "test.bvh:8:5: expected '{' to open joint 'Chest' (saw 'OFFSET')");
}

TEST(ReadBvhErrors, MissingJointName) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "ROOT Hips", "ROOT   ")),
            "test.bvh:2:8: expected a joint name after ROOT (saw end of line)");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "JOINT Chest\n  {", "JOINT {")),
            "test.bvh:6:9: expected a joint name after JOINT (saw '{')");
}

TEST(ReadBvhErrors, DuplicateJointName) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "JOINT Chest", "JOINT Hips")),
            "test.bvh:6:9: duplicate joint name 'Hips' (saw 'Hips')");
  // An end site's generated name counts too.
  EXPECT_EQ(
      ErrorOf(Replace(kTwoJoints, "    }\n  }\n}",
                      "    }\n    JOINT Chest_end\n    {\n      OFFSET 0 0 0\n    }\n  }\n}")),
      "test.bvh:14:11: duplicate joint name 'Chest_end', already given to the End Site of "
      "'Chest' (saw 'Chest_end')");
}

TEST(ReadBvhErrors, ChannelCountOutOfRange) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "CHANNELS 3", "CHANNELS 7")),
            "test.bvh:9:14: expected a channel count from 0 to 6 (saw '7')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "CHANNELS 3", "CHANNELS -1")),
            "test.bvh:9:14: expected a channel count from 0 to 6 (saw '-1')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "CHANNELS 3", "CHANNELS 99999999999999999999999")),
            "test.bvh:9:14: expected a channel count from 0 to 6 (saw '99999999999999999999999')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "CHANNELS 3", "CHANNELS 3.0")),
            "test.bvh:9:14: expected a channel count from 0 to 6 (saw '3.0')");
}

TEST(ReadBvhErrors, UnknownChannelName) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Zrotation Xrotation Yrotation\n    End",
                            "Zrotation Wrotation Yrotation\n    End")),
            "test.bvh:9:26: unknown channel name (saw 'Wrotation')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "CHANNELS 3", "CHANNELS 4")),
            "test.bvh:10:5: unknown channel name (saw 'End')");
}

TEST(ReadBvhErrors, NestingDeeperThanTheLimit) {
  BvhLimits limits;
  limits.max_depth = 1;  // a root and its children, no grandchildren
  EXPECT_EQ(ErrorOf(kTwoJoints, limits),
            "test.bvh:10:5: joints nested deeper than limits.max_depth (1) (saw 'End')");
  limits.max_depth = 2;
  EXPECT_EQ(ErrorOf(kTwoJoints, limits), "no error");

  // The default limit stops a deep chain without recursing.
  std::string deep = "HIERARCHY\nROOT J0\n{\nOFFSET 0 0 0\n";
  for (int i = 1; i <= 300; ++i) deep += "JOINT J" + std::to_string(i) + "\n{\nOFFSET 0 0 0\n";
  EXPECT_EQ(ErrorOf(deep),
            "test.bvh:773:1: joints nested deeper than limits.max_depth (256) "
            "(saw 'JOINT')");
}

TEST(ReadBvhErrors, MoreJointsThanTheLimit) {
  BvhLimits limits;
  limits.max_joints = 2;
  EXPECT_EQ(ErrorOf(kTwoJoints, limits),
            "test.bvh:10:5: more joints than limits.max_joints (2) (saw 'End')");
}

TEST(ReadBvhErrors, MoreFramesThanTheLimit) {
  BvhLimits limits;
  limits.max_frames = 1;
  EXPECT_EQ(ErrorOf(kTwoJoints, limits),
            "test.bvh:17:9: more frames than limits.max_frames (1) (saw '2')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: 99999999999999999999999")),
            "test.bvh:17:9: more frames than limits.max_frames (50000000) "
            "(saw '99999999999999999999999')");
}

TEST(ReadBvhErrors, MoreValuesThanTheLimit) {
  BvhLimits limits;
  limits.max_values = 17;
  EXPECT_EQ(ErrorOf(kTwoJoints, limits),
            "test.bvh:17:9: 2 frames of 9 channels are more values than limits.max_values (17) "
            "(saw '2')");
  limits.max_values = 18;
  EXPECT_EQ(ErrorOf(kTwoJoints, limits), "no error");
}

TEST(ReadBvhErrors, HugeFrameCountInATinyFile) {
  // Within the caps, but the file cannot hold the rows: the truncation is
  // found without allocating 40M x 9 doubles.
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: 40000000")),
            "test.bvh:21:1: the file ends after 2 of 40000000 frames (saw end of file)");
}

TEST(ReadBvhErrors, NegativeOrNonNumericFrames) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: -1")),
            "test.bvh:17:9: negative frame count (saw '-1')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: two")),
            "test.bvh:17:9: expected a frame count (saw 'two')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: 2.0")),
            "test.bvh:17:9: expected a frame count (saw '2.0')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "Frames: 2", "Frames: +2")), "no error");
}

TEST(ReadBvhErrors, NegativeOrNonFiniteFrameTime) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "0.0333333", "-0.0333333")),
            "test.bvh:18:13: negative frame time (saw '-0.0333333')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "0.0333333", "inf")),
            "test.bvh:18:13: the frame time is not finite (saw 'inf')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "0.0333333", "nan")),
            "test.bvh:18:13: the frame time is not finite (saw 'nan')");
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "0.0333333", "1/30")),
            "test.bvh:18:13: expected a number for the frame time (saw '1/30')");
}

TEST(ReadBvhErrors, TextAfterTheFrameTime) {
  EXPECT_EQ(ErrorOf(Replace(kTwoJoints, "0.0333333\n", "0.0333333 1 2 3\n")),
            "test.bvh:18:23: unexpected text after the frame time: frame rows start on the next "
            "line (saw '1')");
}

TEST(ReadBvhErrors, PositionsCountLinesForEveryLineEnd) {
  std::string cr = Replace(kTwoJoints, "16 17", "16 x");
  for (char& c : cr) c = c == '\n' ? '\r' : c;
  EXPECT_EQ(ErrorOf(cr), "test.bvh:20:22: frame 2 of 2, value 8: expected a number (saw 'x')");
  std::string crlf;
  for (char c : Replace(kTwoJoints, "16 17", "16 x"))
    crlf += c == '\n' ? "\r\n" : std::string(1, c);
  EXPECT_EQ(ErrorOf(crlf), "test.bvh:20:22: frame 2 of 2, value 8: expected a number (saw 'x')");
}

TEST(ReadBvhErrors, QuotesBinaryAndLongTokensSafely) {
  EXPECT_EQ(ErrorOf(std::string("HIERARCHY\nROOT A\n{\x01\xff\xc3\xa9\n")),
            "test.bvh:3:2: expected OFFSET in joint 'A' (saw '\\x01\\xffé')");
  EXPECT_EQ(ErrorOf(std::string(100, 'x')),
            "test.bvh:1:1: expected HIERARCHY (saw '" + std::string(40, 'x') + "...')");
  EXPECT_EQ(ErrorOf(std::string("HIER\0ARCHY", 10)),
            "test.bvh:1:1: expected HIERARCHY (saw 'HIER\\x00ARCHY')");
}

TEST(ReadBvhErrors, NamesTheSource) {
  Skeleton skeleton;
  Motion motion;
  try {
    ReadBvh("ROOT", "/data/clip.bvh", &skeleton, &motion);
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_STREQ(error.what(), "/data/clip.bvh:1:1: expected HIERARCHY (saw 'ROOT')");
  }
}

TEST(ReadBvhErrors, LeavesOutputsUntouchedOnFailure) {
  Parsed p = Read(kTwoJoints);
  const Parsed before = p;
  EXPECT_THROW(ReadBvh(Replace(kTwoJoints, "16 17", "16 x"), "x", &p.skeleton, &p.motion), Error);
  ExpectSame(p, before);
}

TEST(ReadBvhErrors, RejectsNullOutputs) {
  Motion motion;
  EXPECT_THROW(ReadBvh(kTwoJoints, "x", nullptr, &motion), Error);
}

// ---- Skeleton ------------------------------------------------------------------

TEST(Skeleton, FindsJointsByName) {
  const Parsed p = Read(kTwoJoints);
  EXPECT_EQ(p.skeleton.Find("Hips"), 0);
  EXPECT_EQ(p.skeleton.Find("Chest_end"), 2);
  EXPECT_EQ(p.skeleton.Find("Head"), -1);
  EXPECT_EQ(p.skeleton.Find(""), -1);
}

TEST(Skeleton, NamesChannels) {
  EXPECT_STREQ(ChannelName(ChannelType::kXposition), "Xposition");
  EXPECT_STREQ(ChannelName(ChannelType::kYposition), "Yposition");
  EXPECT_STREQ(ChannelName(ChannelType::kZposition), "Zposition");
  EXPECT_STREQ(ChannelName(ChannelType::kXrotation), "Xrotation");
  EXPECT_STREQ(ChannelName(ChannelType::kYrotation), "Yrotation");
  EXPECT_STREQ(ChannelName(ChannelType::kZrotation), "Zrotation");
}

TEST(Skeleton, ValidateNamesTheFaultyJoint) {
  const Skeleton good = Read(kTwoJoints).skeleton;
  ASSERT_TRUE(good.Validate());
  const auto message = [&](auto change) {
    Skeleton s = good;
    change(s);
    return s.Validate().message();
  };
  EXPECT_EQ(message([](Skeleton& s) { s.joints[1].parent = 1; }),
            "skeleton: joint 1 'Chest' has parent 1; a parent must come before its children (or "
            "be -1 for a root)");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[1].parent = -2; }),
            "skeleton: joint 1 'Chest' has parent -2; a parent must come before its children (or "
            "be -1 for a root)");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[1].name = ""; }),
            "skeleton: joint 1 has an empty name");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[2].name = "Hips"; }),
            "skeleton: joints 0 and 2 are both named 'Hips'");
  EXPECT_EQ(
      message([](Skeleton& s) {
        Joint child = s.joints[2];
        child.name = "Tip";
        child.parent = 2;
        s.joints.push_back(child);
      }),
      "skeleton: joint 3 'Tip' is a child of end site 'Chest_end'; end sites have no children");
  EXPECT_EQ(message([](Skeleton& s) {
              s.joints[2].channel_count = 1;
              s.channel_count = 10;
            }),
            "skeleton: end site joint 2 'Chest_end' has 1 channels; end sites have none");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[0].channel_count = 7; }),
            "skeleton: joint 0 'Hips' has 7 channels; 0 to 6 are allowed");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[1].channels[2] = static_cast<ChannelType>(9); }),
            "skeleton: joint 1 'Chest' channel 2 has the unknown type 9");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[1].first_channel = 5; }),
            "skeleton: joint 1 'Chest' starts at column 5 but the joints before it use 6 columns "
            "(columns follow joint order)");
  EXPECT_EQ(message([](Skeleton& s) { s.channel_count = 8; }),
            "skeleton: channel_count is 8 but the joints have 9 channels");
  EXPECT_EQ(message([](Skeleton& s) { s.joints[2].offset.y() = std::nan(""); }),
            "skeleton: joint 2 'Chest_end' has a non-finite offset");
  EXPECT_TRUE(Skeleton().Validate());
}

// ---- Writing -------------------------------------------------------------------

TEST(WriteBvh, WritesTheStandardLayout) {
  Parsed p = Read(kTwoJoints);
  p.motion.values(1, 3) = -0.1;
  EXPECT_EQ(WriteBvh(p.skeleton, p.motion),
            "HIERARCHY\n"
            "ROOT Hips\n"
            "{\n"
            "\tOFFSET 0 0 0\n"
            "\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
            "\tJOINT Chest\n"
            "\t{\n"
            "\t\tOFFSET 0 5.5 -1\n"
            "\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n"
            "\t\tEnd Site\n"
            "\t\t{\n"
            "\t\t\tOFFSET 0 3 0\n"
            "\t\t}\n"
            "\t}\n"
            "}\n"
            "MOTION\n"
            "Frames: 2\n"
            "Frame Time: 0.0333333\n"
            "1 2 3 4 5 6 7 8 9\n"
            "10 11 12 -0.1 14 15 16 17 18\n");
}

TEST(WriteBvh, WritesSeveralRootsAndJointsWithoutChannels) {
  const std::string text = Lines({"HIERARCHY", "ROOT A", "{", "\tOFFSET 0 0 0", "\tCHANNELS 0", "}",
                                  "ROOT B", "{", "\tOFFSET 1 0 0", "\tCHANNELS 1 Yposition", "}",
                                  "MOTION", "Frames: 1", "Frame Time: 0", "2.5"});
  const Parsed p = Read(text);
  EXPECT_EQ(WriteBvh(p.skeleton, p.motion), text);
}

// A skeleton with every layout: several roots, 0 to 6 channels in shuffled
// orders, end sites, position channels anywhere.
Parsed RandomClip(std::mt19937_64& random, int frames) {
  Parsed clip;
  Skeleton& s = clip.skeleton;
  std::uniform_int_distribution<int> channels(0, 6);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<int> open;
  int column = 0;
  for (int i = 0; i < 40; ++i) {
    Joint joint;
    // Close a random number of open blocks; end sites always close.
    while (!open.empty() &&
           (s.joints[static_cast<std::size_t>(open.back())].end_site || random() % 3 == 0)) {
      open.pop_back();
    }
    joint.parent = open.empty() ? -1 : open.back();
    joint.end_site = joint.parent >= 0 && random() % 4 == 0;
    joint.name = joint.end_site ? s.joints[static_cast<std::size_t>(joint.parent)].name + "_end"
                                : "joint " + std::to_string(i);
    if (s.Find(joint.name) >= 0) joint.end_site = false, joint.name = "j" + std::to_string(i);
    joint.offset = Eigen::Vector3d(unit(random), unit(random), unit(random)) * 100.0;
    if (!joint.end_site) {
      joint.channel_count = channels(random);
      std::array<ChannelType, 6> all = {C::kXposition, C::kYposition, C::kZposition,
                                        C::kXrotation, C::kYrotation, C::kZrotation};
      std::shuffle(all.begin(), all.end(), random);
      joint.channels = all;
    }
    joint.first_channel = column;
    column += joint.channel_count;
    s.joints.push_back(joint);
    open.push_back(i);
  }
  s.channel_count = column;
  clip.motion.frame_time = 1.0 / 120.0;
  clip.motion.values.resize(frames, column);
  for (Eigen::Index k = 0; k < clip.motion.values.size(); ++k) {
    // Any finite bit pattern: subnormals, 1e-300, 1e300, -0 and all between.
    double value;
    do {
      const std::uint64_t bits = random();
      std::memcpy(&value, &bits, sizeof value);
    } while (!std::isfinite(value));
    clip.motion.values.data()[k] = value;
  }
  return clip;
}

TEST(WriteBvh, RoundTripsExactly) {
  std::mt19937_64 random(20261121);
  for (int trial = 0; trial < 20; ++trial) {
    Parsed clip = RandomClip(random, 50);
    ASSERT_TRUE(clip.skeleton.Validate()) << clip.skeleton.Validate().message();
    if (clip.skeleton.channel_count > 0) {
      // Extremes at fixed places.
      const double extremes[] = {5e-324,  -5e-324, DBL_MIN,   -DBL_MAX,
                                 DBL_MAX, 0.0,     -0.0,      1e-300,
                                 1e300,   0.1,     1.0 / 3.0, 123456789.123456789};
      for (std::size_t k = 0; k < std::size(extremes); ++k) {
        clip.motion.values(0, static_cast<Eigen::Index>(k) % clip.skeleton.channel_count) =
            extremes[k];
        clip.motion.values(1, 0) = extremes[k];
      }
    }
    const std::string text = WriteBvh(clip.skeleton, clip.motion);
    const Parsed back = Read(text);
    ExpectSame(back, clip);
    EXPECT_EQ(WriteBvh(back.skeleton, back.motion), text);
  }
}

TEST(WriteBvh, RejectsWhatItCannotWrite) {
  const Parsed good = Read(kTwoJoints);
  const auto message = [&](auto change) {
    Parsed p = good;
    change(p);
    try {
      WriteBvh(p.skeleton, p.motion);
    } catch (const Error& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message([](Parsed&) {}), "no error");
  EXPECT_EQ(message([](Parsed& p) { p.skeleton.channel_count = 8; }),
            "skeleton: channel_count is 8 but the joints have 9 channels");
  EXPECT_EQ(message([](Parsed& p) { p.motion.values.resize(2, 8); }),
            "WriteBvh: the motion has 8 columns but the skeleton has 9 channels");
  EXPECT_EQ(message([](Parsed& p) { p.motion.values(1, 7) = std::nan(""); }),
            "WriteBvh: frame 2, column 7 (joint 1 'Chest' Xrotation) is not finite");
  EXPECT_EQ(message([](Parsed& p) { p.motion.values(0, 0) = -HUGE_VAL; }),
            "WriteBvh: frame 1, column 0 (joint 0 'Hips' Xposition) is not finite");
  EXPECT_EQ(message([](Parsed& p) { p.motion.frame_time = -1; }),
            "WriteBvh: the frame time must be finite and not negative, got -1.000000");
  EXPECT_EQ(message([](Parsed& p) {
              p.skeleton = Skeleton();
              p.motion.values.resize(0, 0);
            }),
            "WriteBvh: the skeleton has no joints");
  for (const char* name : {" Chest", "Chest\t", "Ch{est", "Ch}est", "Ch\nest", "Ch\rest"}) {
    EXPECT_EQ(message([&](Parsed& p) { p.skeleton.joints[1].name = name; }),
              "WriteBvh: joint 1 '" + std::string(name) +
                  "': a BVH name cannot be blank at either end or hold braces or line breaks");
  }
  EXPECT_EQ(message([](Parsed& p) { p.skeleton.joints[2].parent = -1; }),
            "WriteBvh: joint 2 'Chest_end' is an end site without a parent");
  // Parents come first, but B is not inside A's block.
  const Parsed roots = Read(
      Lines({"HIERARCHY", "ROOT A", "{", "OFFSET 0 0 0", "}", "ROOT B", "{", "OFFSET 0 0 0",
             "JOINT C", "{", "OFFSET 0 0 0", "}", "}", "MOTION", "Frames: 0", "Frame Time: 1"}));
  Skeleton shuffled = roots.skeleton;
  shuffled.joints[2].parent = 0;
  ASSERT_TRUE(shuffled.Validate());
  try {
    WriteBvh(shuffled, roots.motion);
    FAIL() << "no error";
  } catch (const Error& error) {
    EXPECT_STREQ(error.what(),
                 "WriteBvh: joint 2 'C' does not follow its parent 'A' depth-first; BVH nests "
                 "every joint inside its parent's block");
  }
}

TEST(WriteBvh, KeepsNamesWithInnerSpaces) {
  Parsed p = Read(kTwoJoints);
  p.skeleton.joints[1].name = "Bip01 L  Thigh";
  p.skeleton.joints[2].name = "Bip01 L  Thigh_end";
  ExpectSame(Read(WriteBvh(p.skeleton, p.motion)), p);
}

}  // namespace
}  // namespace motionkit
