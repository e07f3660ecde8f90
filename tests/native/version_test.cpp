#include "motionkit/version.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

TEST(Version, MatchesTheProjectVersion) {
  EXPECT_STREQ(motionkit::Version(), MOTIONKIT_VERSION_STRING);
  EXPECT_NE(std::string(motionkit::Version()), "0.0.0-dev");
}

TEST(Version, NamesTheEigenItWasBuiltWith) {
  const std::string eigen = motionkit::EigenVersion();
  // "3.4.0" on Debian 12, "5.0.x" on sid: a dotted triple either way.
  EXPECT_EQ(std::count(eigen.begin(), eigen.end(), '.'), 2) << eigen;
  EXPECT_TRUE(eigen[0] == '3' || eigen[0] == '5') << eigen;
}
