#include "motionkit/version.hpp"

#include <Eigen/Core>

namespace motionkit {

#define MOTIONKIT_STR2(x) #x
#define MOTIONKIT_STR(x) MOTIONKIT_STR2(x)

const char* EigenVersion() {
  return MOTIONKIT_STR(EIGEN_WORLD_VERSION) "." MOTIONKIT_STR(EIGEN_MAJOR_VERSION) "." MOTIONKIT_STR(
      EIGEN_MINOR_VERSION);
}

}  // namespace motionkit
