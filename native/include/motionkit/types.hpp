// Array types shared by the core and the bindings. Row-major so that numpy's
// default (C-order) arrays map onto them without a copy.
#pragma once

#include <Eigen/Core>

namespace motionkit {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Views onto caller-owned memory: jobs never own their inputs or outputs.
using ConstVectorView = Eigen::Ref<const Eigen::VectorXd>;
using ConstMatrixView = Eigen::Ref<const RowMatrixXd>;
using MatrixViewF = Eigen::Ref<RowMatrixXf>;

}  // namespace motionkit
