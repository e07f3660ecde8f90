#include "motionkit/version.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>

// The add-on's bl_info version, read from addon/__init__.py: a source the build does not derive the
// native version from (CMakeLists.txt's project version is where MOTIONKIT_VERSION_STRING comes from).
std::string AddonVersion() {
  std::ifstream in(std::string(MOTIONKIT_SOURCE_DIR) + "/addon/__init__.py");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::smatch match;
  if (!std::regex_search(text, match, std::regex(R"("version":\s*\((\d+),\s*(\d+),\s*(\d+)\))"))) return "";
  return match[1].str() + "." + match[2].str() + "." + match[3].str();
}

TEST(Version, MatchesTheAddonsVersion) {
  const std::string addon = AddonVersion();
  ASSERT_FALSE(addon.empty()) << "no bl_info version in addon/__init__.py";
  EXPECT_EQ(std::string(motionkit::Version()), addon);
  EXPECT_NE(std::string(motionkit::Version()), "0.0.0-dev");
}

TEST(Version, NamesTheEigenItWasBuiltWith) {
  const std::string eigen = motionkit::EigenVersion();
  // "3.4.0" on Debian 12, "5.0.x" on sid: a dotted triple either way.
  EXPECT_EQ(std::count(eigen.begin(), eigen.end(), '.'), 2) << eigen;
  EXPECT_TRUE(eigen[0] == '3' || eigen[0] == '5') << eigen;
}
