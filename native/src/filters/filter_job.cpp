// The filters' settings, their one dispatch by kind, and the job over scalar
// channels.
#include <cmath>
#include <string>

#include "filter_internal.hpp"

namespace motionkit {
namespace {

using internal::Number;

bool PositiveFinite(double value) { return std::isfinite(value) && value > 0.0; }

Status ValidateButterworth(const FilterSettings& s, Eigen::Index frames) {
  if (s.order < 1 || s.order > 8) {
    return Status::Fail("butterworth: order must be 1 to 8, not " + std::to_string(s.order));
  }
  if (!PositiveFinite(s.cutoff)) {
    return Status::Fail("butterworth: cutoff must be a positive number of Hz, not " + Number(s.cutoff));
  }
  if (s.cutoff >= 0.5 * s.fps) {
    return Status::Fail("butterworth: cutoff " + Number(s.cutoff) + " Hz is at or above the Nyquist frequency " +
                        Number(0.5 * s.fps) + " Hz of a " + Number(s.fps) + " fps clip");
  }
  if (frames < 2) return Status::Fail("butterworth: needs at least 2 frames, the clip has " + std::to_string(frames));
  return Status::Ok();
}

Status ValidateOneEuro(const FilterSettings& s) {
  if (!PositiveFinite(s.min_cutoff)) {
    return Status::Fail("one_euro: min_cutoff must be a positive number of Hz, not " + Number(s.min_cutoff));
  }
  if (!std::isfinite(s.beta) || s.beta < 0.0) {
    return Status::Fail("one_euro: beta must be finite and >= 0, not " + Number(s.beta));
  }
  if (!PositiveFinite(s.d_cutoff)) {
    return Status::Fail("one_euro: d_cutoff must be a positive number of Hz, not " + Number(s.d_cutoff));
  }
  return Status::Ok();
}

}  // namespace

std::optional<FilterKind> ParseFilterKind(std::string_view name) {
  for (FilterKind kind : {FilterKind::kButterworth, FilterKind::kGaussian, FilterKind::kMedian, FilterKind::kOneEuro}) {
    if (name == FilterKindName(kind)) return kind;
  }
  return std::nullopt;
}

const char* FilterKindName(FilterKind kind) {
  switch (kind) {
    case FilterKind::kButterworth: return "butterworth";
    case FilterKind::kGaussian: return "gaussian";
    case FilterKind::kMedian: return "median";
    case FilterKind::kOneEuro: return "one_euro";
  }
  return "unknown";
}

Status FilterSettings::Validate(Eigen::Index frames) const {
  const std::string name = FilterKindName(kind);
  if (!PositiveFinite(fps)) return Status::Fail(name + ": fps must be a positive number, not " + Number(fps));
  if (frames < 1) return Status::Fail(name + ": the clip has no frames");
  switch (kind) {
    case FilterKind::kButterworth: return ValidateButterworth(*this, frames);
    case FilterKind::kGaussian:
      if (!(sigma > 0.0 && sigma <= kMaxGaussianSigma)) {
        return Status::Fail("gaussian: sigma must be above 0 and at most " + Number(kMaxGaussianSigma) +
                            " frames, not " + Number(sigma));
      }
      return Status::Ok();
    case FilterKind::kMedian:
      if (size < 3 || size % 2 == 0) return Status::Fail("median: size must be odd and at least 3, not " + std::to_string(size));
      if (size > frames) {
        return Status::Fail("median: size " + std::to_string(size) + " is longer than the clip's " +
                            std::to_string(frames) + " frames");
      }
      return Status::Ok();
    case FilterKind::kOneEuro: return ValidateOneEuro(*this);
  }
  return Status::Fail(name + ": unknown filter kind");
}

namespace internal {

FilterDesign DesignFilter(const FilterSettings& settings) {
  FilterDesign design{settings, {}, {}};
  if (settings.kind == FilterKind::kButterworth) {
    design.butterworth = DesignButterworth(settings.order, settings.cutoff, settings.fps);
  } else if (settings.kind == FilterKind::kGaussian) {
    design.gaussian = GaussianHalfKernel(settings.sigma);
  }
  return design;
}

ScalarFilter::ScalarFilter(const FilterDesign& design, Eigen::Index frames) : design_(design) {
  if (design.settings.kind == FilterKind::kButterworth) {
    const Eigen::Index pad = ButterworthPadding(design.butterworth, frames);
    scratch_.resize(static_cast<std::size_t>(kLanes * (frames + 2 * std::max<Eigen::Index>(pad, 0))));
  } else {
    in_.resize(static_cast<std::size_t>(frames));
    out_.resize(static_cast<std::size_t>(frames));
    if (design.settings.kind == FilterKind::kMedian) scratch_.resize(static_cast<std::size_t>(design.settings.size));
  }
}

void ScalarFilter::Apply(const double* in, Eigen::Index n, double* out) { Apply(in, 1, 1, n, out, 1); }

void ScalarFilter::Apply(const double* in, Eigen::Index in_stride, int lanes, Eigen::Index n, double* out,
                         Eigen::Index out_stride) {
  if (design_.settings.kind == FilterKind::kButterworth) {
    ButterworthFilter(design_.butterworth, in, in_stride, lanes, n, out, out_stride, scratch_.data());
    return;
  }
  for (int l = 0; l < lanes; ++l) {
    for (Eigen::Index i = 0; i < n; ++i) in_[static_cast<std::size_t>(i)] = in[i * in_stride + l];
    double* const x = in_.data();
    double* const y = out_.data();
    switch (design_.settings.kind) {
      case FilterKind::kGaussian: GaussianFilter(design_.gaussian, x, n, y); break;
      case FilterKind::kMedian: MedianFilter(design_.settings.size, x, n, y, scratch_.data()); break;
      case FilterKind::kOneEuro: OneEuroFilter(design_.settings, x, n, y); break;
      case FilterKind::kButterworth: break;
    }
    for (Eigen::Index i = 0; i < n; ++i) out[i * out_stride + l] = y[i];
  }
}

}  // namespace internal

Status FilterChannelsJob::Validate() const {
  if (filtered.rows() != values.rows() || filtered.cols() != values.cols()) {
    return Status::Fail("filter_channels: the output is " + std::to_string(filtered.rows()) + " x " +
                        std::to_string(filtered.cols()) + " for values " + std::to_string(values.rows()) +
                        " x " + std::to_string(values.cols()));
  }
  const Status status = settings.Validate(values.rows());
  if (!status) return status;
  for (Eigen::Index i = 0; i < values.rows(); ++i) {
    for (Eigen::Index c = 0; c < values.cols(); ++c) {
      if (!std::isfinite(values(i, c))) {
        return Status::Fail("filter_channels: the value of channel " + std::to_string(c) + " at frame " +
                            std::to_string(i) + " is " + Number(values(i, c)) + ", not a finite number");
      }
    }
  }
  return Status::Ok();
}

void FilterChannelsJob::Run() {
  Validate().ThrowIfFailed();
  const internal::FilterDesign design = internal::DesignFilter(settings);
  const Eigen::Index frames = values.rows();
  internal::ForEachRange(values.cols(), threads, [&](Eigen::Index begin, Eigen::Index end) {
    internal::ScalarFilter filter(design, frames);
    for (Eigen::Index c = begin; c < end; c += internal::kLanes) {
      const int lanes = static_cast<int>(std::min<Eigen::Index>(internal::kLanes, end - c));
      filter.Apply(values.data() + c, values.outerStride(), lanes, frames, filtered.data() + c,
                   filtered.outerStride());
    }
  });
}

}  // namespace motionkit
