#pragma once

namespace motionkit {

// Kept in step with CMakeLists.txt's project(VERSION) by the build, which
// passes MOTIONKIT_VERSION_STRING; the fallback only serves IDE parsing.
#ifndef MOTIONKIT_VERSION_STRING
#define MOTIONKIT_VERSION_STRING "0.0.0-dev"
#endif

inline const char* Version() { return MOTIONKIT_VERSION_STRING; }

// Which Eigen the core was compiled against: "3.4.0", "5.0.0", ...
const char* EigenVersion();

}  // namespace motionkit
