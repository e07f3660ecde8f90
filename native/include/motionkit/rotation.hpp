// Euler angles, quaternions and matrices for all six axis orders.
//
// Orders are intrinsic, as BVH channel lists and scipy's upper-case orders:
// kZXY means R = Rz(a0) * Rx(a1) * Ry(a2), angles[k] about the k-th letter.
// (Blender's Euler modes are extrinsic: its 'XYZ' is R = Rz Ry Rx, which is
// our kZYX with the angles reversed; see BlenderEulerMode.)
// Quaternions are (w, x, y, z) wherever they are stored in arrays.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include <Eigen/Geometry>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class EulerOrder : std::uint8_t { kXYZ, kXZY, kYXZ, kYZX, kZXY, kZYX };

// "XYZ", ..., "ZYX" (upper case) or nothing.
std::optional<EulerOrder> ParseEulerOrder(std::string_view text);
const char* EulerOrderName(EulerOrder order);
// The Blender rotation_mode string with the same rotation: the reversed letters.
const char* BlenderEulerMode(EulerOrder order);
// Axis index (0 = X, 1 = Y, 2 = Z) of the k-th rotation of the order.
int EulerAxis(EulerOrder order, int k);

Eigen::Matrix3d EulerToMatrix(const Eigen::Vector3d& radians, EulerOrder order);
Eigen::Quaterniond EulerToQuaternion(const Eigen::Vector3d& radians, EulerOrder order);

// Principal angles: first and last in (-pi, pi], middle in [-pi/2, pi/2]
// (for the Tait-Bryan orders). At gimbal lock the last angle is 0.
Eigen::Vector3d MatrixToEuler(const Eigen::Matrix3d& rotation, EulerOrder order);
Eigen::Vector3d QuaternionToEuler(const Eigen::Quaterniond& q, EulerOrder order);

// The Euler triple for `rotation` closest to `previous` (no 2*pi jumps and the
// better of the two equivalent solutions), as Blender's
// Matrix.to_euler(order, compat) picks it, so that curves stay continuous.
Eigen::Vector3d MatrixToEulerCompatible(const Eigen::Matrix3d& rotation, EulerOrder order,
                                        const Eigen::Vector3d& previous);
Eigen::Vector3d QuaternionToEulerCompatible(const Eigen::Quaterniond& q, EulerOrder order,
                                            const Eigen::Vector3d& previous);

// Many bones' quaternions to Euler angles in one call: quaternions (n, 4k)
// w x y z, out (n, 3k); column group c is one bone's sequence, each row made
// the triple closest to the row before (the first to previous's 3 angles of
// that group; previous may be empty for zeros) when continuous, as
// QuaternionToEulerCompatible. Groups spread over `threads` threads (0: every
// core); the same numbers whatever the count. Fails naming the row and group
// of a zero or non-finite quaternion, before anything is written.
Status QuaternionsToEulers(ConstMatrixView quaternions, EulerOrder order, Eigen::Ref<RowMatrixXd> out,
                           bool continuous, const Eigen::VectorXd& previous, int threads = 0);

// Quaternion channels as F-curves take them: k bones' w x y z quaternions (n, 4k) as out (4k, n), row 4j + c
// bone j's component c over the n rows, each bone's quaternions kept on one hemisphere from row to row (the
// first on the side of previous' quaternion j, previous 4k long, or with w >= 0 when it is empty), as Blender's
// keying keeps a curve from jumping. Bones spread over `threads` threads (0: every core); the same numbers
// whatever the count. Fails naming the row and bone of a zero or non-finite quaternion, before anything is
// written.
Status QuaternionChannels(ConstMatrixView quaternions, const Eigen::VectorXd& previous, Eigen::Ref<RowMatrixXd> out,
                          int threads = 0);

}  // namespace motionkit
