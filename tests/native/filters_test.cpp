#include "motionkit/filters.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <tuple>

namespace motionkit {
namespace {

RowMatrixXd FilterChannels(const RowMatrixXd& values, const FilterSettings& settings) {
  RowMatrixXd out(values.rows(), values.cols());
  FilterChannelsJob job(values, settings, out);
  job.Run();
  return out;
}

RowMatrixXd FilterRotations(const RowMatrixXd& quaternions, const FilterSettings& settings) {
  RowMatrixXd out(quaternions.rows(), quaternions.cols());
  FilterRotationsJob job(quaternions, settings, out);
  job.Run();
  return out;
}

FilterSettings Kind(FilterKind kind, double fps = 30.0) {
  FilterSettings settings;
  settings.kind = kind;
  settings.fps = fps;
  return settings;
}

// The message Run() throws, or "" when it does not.
template <class Job>
std::string RunError(const RowMatrixXd& input, const FilterSettings& settings) {
  RowMatrixXd out(input.rows(), input.cols());
  Job job(input, settings, out);
  try {
    job.Run();
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

const FilterKind kAllKinds[] = {FilterKind::kButterworth, FilterKind::kGaussian, FilterKind::kMedian,
                                FilterKind::kOneEuro};

// The Butterworth filter's published response after the bilinear transform
// with a prewarped cut-off: |H(f)|^2 = 1 / (1 + (tan(pi f / fs) / tan(pi fc / fs))^(2N)),
// which the forward-backward run applies once, with no phase. A sinusoid in the
// middle of a long clip (the ends' transients decayed) comes out scaled by it.
TEST(Filters, ButterworthGainIsThePublishedResponse) {
  constexpr double kPi = 3.14159265358979323846;
  const Eigen::Index frames = 6000;
  for (const auto& [order, cutoff, fps] : {std::tuple{4, 7.0, 30.0}, std::tuple{6, 2.0, 120.0},
                                           std::tuple{8, 2.0, 60.0}, std::tuple{3, 10.0, 24.0}}) {
    FilterSettings settings = Kind(FilterKind::kButterworth, fps);
    settings.order = order;
    settings.cutoff = cutoff;
    for (double ratio : {0.5, 1.0, 1.3}) {
      const double f = ratio * cutoff, w = 2.0 * kPi * f / fps;
      RowMatrixXd values(frames, 2);
      for (Eigen::Index i = 0; i < frames; ++i) {
        values(i, 0) = std::sin(w * static_cast<double>(i));
        values(i, 1) = std::cos(w * static_cast<double>(i));
      }
      const RowMatrixXd out = FilterChannels(values, settings);
      const double x = std::tan(kPi * f / fps) / std::tan(kPi * cutoff / fps);
      const double gain = 1.0 / (1.0 + std::pow(x, 2.0 * order));
      // Zero phase: each output is the input times the gain. The middle third
      // is thousands of frames from either end, where the slowest pole's
      // transient has decayed far below rounding. What is left is rounding in
      // the sections, a few ulps times each one's noise gain (the bound
      // tests/python/test_filters.py derives): measured 2e-14 to 7.4e-13 here,
      // the most for order 3 near the Nyquist frequency.
      double worst = 0.0;
      for (Eigen::Index i = frames / 3; i < 2 * frames / 3; ++i) {
        worst = std::max({worst, std::abs(out(i, 0) - gain * values(i, 0)), std::abs(out(i, 1) - gain * values(i, 1))});
      }
      EXPECT_LT(worst, 1e-11) << "order " << order << ", " << f << " Hz at " << fps << " fps, gain " << gain;
    }
  }
}

TEST(Filters, ConstantChannelsStayConstant) {
  RowMatrixXd values(120, 3);
  values.col(0).setConstant(2.5);
  values.col(1).setConstant(-40.0);
  values.col(2).setZero();
  for (FilterKind kind : kAllKinds) {
    const RowMatrixXd out = FilterChannels(values, Kind(kind));
    EXPECT_LT((out - values).cwiseAbs().maxCoeff(), 1e-12) << FilterKindName(kind);
  }
}

TEST(Filters, GaussianAndMedianKeepAStepWithinItsLevels) {
  RowMatrixXd values(60, 1);
  for (Eigen::Index i = 0; i < 60; ++i) values(i, 0) = i < 25 ? -1.0 : 3.0;
  for (FilterKind kind : {FilterKind::kGaussian, FilterKind::kMedian}) {
    FilterSettings settings = Kind(kind);
    settings.sigma = 3.0;
    settings.size = 7;
    const RowMatrixXd out = FilterChannels(values, settings);
    EXPECT_GE(out.minCoeff(), -1.0) << FilterKindName(kind);
    EXPECT_LE(out.maxCoeff(), 3.0) << FilterKindName(kind);
  }
  // A median does not move a step at all.
  FilterSettings median = Kind(FilterKind::kMedian);
  median.size = 7;
  EXPECT_EQ(FilterChannels(values, median), values);
}

TEST(Filters, MedianRemovesASpike) {
  RowMatrixXd values = RowMatrixXd::Constant(30, 1, 1.0);
  values(12, 0) = 50.0;
  values(13, 0) = -50.0;
  const RowMatrixXd out = FilterChannels(values, Kind(FilterKind::kMedian));
  EXPECT_EQ(out, RowMatrixXd::Constant(30, 1, 1.0));
}

// bones constant-speed rotations q_b exp(t omega_b), each bone's frames of alternating sign.
RowMatrixXd ConstantSpeedRotations(Eigen::Index frames, Eigen::Index bones) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  RowMatrixXd q(frames, 4 * bones);
  for (Eigen::Index b = 0; b < bones; ++b) {
    const Eigen::Quaterniond start = Eigen::Quaterniond(normal(random), normal(random), normal(random), normal(random)).normalized();
    const Eigen::Vector3d omega(normal(random), normal(random), normal(random));  // about 1.7 rad per frame at most
    for (Eigen::Index i = 0; i < frames; ++i) {
      const Eigen::Vector3d v = 0.2 * static_cast<double>(i) * omega;
      Eigen::Quaterniond r = start * Eigen::Quaterniond(Eigen::AngleAxisd(v.norm(), v.normalized()));
      if (i % 3 == 1) r.coeffs() = -r.coeffs();
      q.row(i).segment<4>(4 * b) << r.w(), r.x(), r.y(), r.z();
    }
  }
  return q;
}

// The angle between two rotations given as unit quaternions, accurate for tiny angles.
double AngleBetween(const Eigen::Vector4d& a, Eigen::Vector4d b) {
  if (a.dot(b) < 0.0) b = -b;
  return 4.0 * std::atan2((a - b).norm(), (a + b).norm());
}

TEST(Filters, ConstantSpeedRotationComesBackOnEveryFrame) {
  const RowMatrixXd q = ConstantSpeedRotations(200, 5);
  for (FilterKind kind : {FilterKind::kButterworth, FilterKind::kGaussian, FilterKind::kMedian}) {
    FilterSettings settings = Kind(kind, 24.0);
    settings.sigma = 2.5;
    const RowMatrixXd out = FilterRotations(q, settings);
    double worst = 0.0;
    for (Eigen::Index i = 0; i < q.rows(); ++i) {
      for (Eigen::Index b = 0; b < 5; ++b) {
        const Eigen::Vector4d filtered = out.row(i).segment<4>(4 * b).transpose();
        worst = std::max(worst, AngleBetween(q.row(i).segment<4>(4 * b).transpose(), filtered));
        EXPECT_NEAR(filtered.norm(), 1.0, 1e-12);
        if (i > 0) {
          EXPECT_GE(filtered.dot(out.row(i - 1).segment<4>(4 * b).transpose()), 0.0);
        }
      }
    }
    EXPECT_LT(worst, 1e-9) << FilterKindName(kind);
  }
}

TEST(Filters, RotationOutputStartsWithTheInputsSign) {
  RowMatrixXd q = ConstantSpeedRotations(40, 1);
  q.row(0) = -q.row(0);
  const RowMatrixXd out = FilterRotations(q, Kind(FilterKind::kGaussian));
  EXPECT_GT(out.row(0).dot(q.row(0)), 0.0);
}

TEST(Filters, BadParametersNameTheKindAndTheNumbers) {
  const RowMatrixXd values = RowMatrixXd::Zero(10, 2);
  FilterSettings settings = Kind(FilterKind::kButterworth);
  settings.cutoff = 16.0;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings),
            "butterworth: cutoff 16 Hz is at or above the Nyquist frequency 15 Hz of a 30 fps clip");
  settings.cutoff = 0.0;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "butterworth: cutoff must be a positive number of Hz, not 0");
  settings.cutoff = 7.0;
  settings.order = 9;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "butterworth: order must be 1 to 8, not 9");
  settings.order = 4;
  EXPECT_EQ(RunError<FilterChannelsJob>(RowMatrixXd::Zero(1, 2), settings),
            "butterworth: needs at least 2 frames, the clip has 1");
  settings.fps = -24.0;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "butterworth: fps must be a positive number, not -24");

  settings = Kind(FilterKind::kGaussian);
  settings.sigma = 0.0;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings),
            "gaussian: sigma must be above 0 and at most 10000 frames, not 0");
  settings = Kind(FilterKind::kMedian);
  settings.size = 4;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "median: size must be odd and at least 3, not 4");
  settings.size = 11;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "median: size 11 is longer than the clip's 10 frames");
  settings = Kind(FilterKind::kOneEuro);
  settings.beta = -0.5;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "one_euro: beta must be finite and >= 0, not -0.5");
  settings.beta = 0.0;
  settings.min_cutoff = 0.0;
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "one_euro: min_cutoff must be a positive number of Hz, not 0");
  settings.min_cutoff = 1.0;
  settings.d_cutoff = std::numeric_limits<double>::infinity();
  EXPECT_EQ(RunError<FilterChannelsJob>(values, settings), "one_euro: d_cutoff must be a positive number of Hz, not inf");
}

TEST(Filters, BadSamplesNameTheirPlace) {
  RowMatrixXd values = RowMatrixXd::Zero(10, 3);
  values(6, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(RunError<FilterChannelsJob>(values, Kind(FilterKind::kGaussian)),
            "filter_channels: the value of channel 2 at frame 6 is nan, not a finite number");

  RowMatrixXd q = ConstantSpeedRotations(10, 3);
  q(4, 5) *= 1.5;
  EXPECT_EQ(RunError<FilterRotationsJob>(q, Kind(FilterKind::kGaussian)).rfind(
                "filter_rotations: the quaternion of bone 1 at frame 4 has length ", 0),
            0u);
  q = ConstantSpeedRotations(10, 3);
  q(8, 11) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(RunError<FilterRotationsJob>(q, Kind(FilterKind::kGaussian)),
            "filter_rotations: the quaternion of bone 2 at frame 8 is not finite");
  EXPECT_EQ(RunError<FilterRotationsJob>(RowMatrixXd::Zero(10, 7), Kind(FilterKind::kGaussian)),
            "filter_rotations: quaternions must be (frames, 4 * bones) and the output as large; got 10 x 7 and 10 x 7");
}

TEST(Filters, KindsParseByName) {
  for (FilterKind kind : kAllKinds) EXPECT_EQ(ParseFilterKind(FilterKindName(kind)), kind);
  EXPECT_FALSE(ParseFilterKind("savgol"));
}

}  // namespace
}  // namespace motionkit
