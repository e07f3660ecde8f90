// The interpolation jobs: names, validation and the Run() drivers.
#include "motionkit/interpolation.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

#include "interpolation_internal.hpp"
#include "time_checks.hpp"

namespace motionkit {
namespace {

using interpolation_detail::CurveExtras;
using interpolation_detail::CurveKeys;
using interpolation_detail::Index;

struct NamedInterpolant {
  const char* name;
  Interpolant kind;
};
constexpr NamedInterpolant kNames[] = {
    {"stepped", Interpolant::kStepped},
    {"linear", Interpolant::kLinear},
    {"polynomial", Interpolant::kPolynomial},
    {"natural", Interpolant::kNaturalSpline},
    {"clamped", Interpolant::kClampedSpline},
    {"periodic", Interpolant::kPeriodicSpline},
    {"not-a-knot", Interpolant::kNotAKnotSpline},
    {"hermite", Interpolant::kHermite},
    {"catmull-rom", Interpolant::kCatmullRom},
    {"centripetal", Interpolant::kCentripetalCatmullRom},
    {"chordal", Interpolant::kChordalCatmullRom},
    {"kochanek-bartels", Interpolant::kKochanekBartels},
    {"monotone", Interpolant::kMonotone},
};

std::string Str(double v) { return std::to_string(v); }
std::string Str(Index v) { return std::to_string(v); }

bool Given(const std::optional<ConstVectorView>& v) { return v.has_value() && v->size() > 0; }

// Sizes of the option arrays that the kind reads. `keys` entries per key
// array, `ends` per end slope, `components` columns of the slopes.
Status CheckOptionSizes(const std::string& where, const InterpolationOptions& o, Index keys,
                        Index ends, Index components) {
  if (o.interpolant == Interpolant::kClampedSpline) {
    for (const auto* end : {&o.start_slope, &o.end_slope}) {
      if (end->has_value() && (*end)->size() != ends) {
        return Status::Fail(where + "clamped " + (end == &o.start_slope ? "start" : "end") +
                            "_slope must have " + Str(ends) + " entries, got " +
                            Str((*end)->size()));
      }
    }
  }
  if (o.interpolant == Interpolant::kHermite) {
    if (!o.slopes) return Status::Fail(where + "hermite needs slopes, one per key and component");
    if (o.slopes->rows() != keys || o.slopes->cols() != components) {
      return Status::Fail(where + "hermite slopes must be " + Str(keys) + " x " + Str(components) +
                          ", got " + Str(o.slopes->rows()) + " x " + Str(o.slopes->cols()));
    }
  }
  if (o.interpolant == Interpolant::kKochanekBartels) {
    const std::pair<const char*, const std::optional<ConstVectorView>*> arrays[] = {
        {"tension", &o.tension}, {"continuity", &o.continuity}, {"bias", &o.bias}};
    for (const auto& [name, array] : arrays) {
      if (Given(*array) && (*array)->size() != keys) {
        return Status::Fail(where + name + " must have " + Str(keys) + " entries (one per key) " +
                            "or none, got " + Str((*array)->size()));
      }
    }
  }
  return Status::Ok();
}

// The option arrays of the kind, cut at key `first` (and end slope `curve`).
CurveExtras Extras(const InterpolationOptions& o, Index first, Index curve) {
  CurveExtras e;
  switch (o.interpolant) {
    case Interpolant::kClampedSpline:
      if (o.start_slope) e.start_slope = o.start_slope->data() + curve;
      if (o.end_slope) e.end_slope = o.end_slope->data() + curve;
      break;
    case Interpolant::kHermite:
      e.slopes_stride = o.slopes->outerStride();
      e.slopes = o.slopes->data() + first * e.slopes_stride;
      break;
    case Interpolant::kKochanekBartels:
      if (Given(o.tension)) e.tension = o.tension->data() + first;
      if (Given(o.continuity)) e.continuity = o.continuity->data() + first;
      if (Given(o.bias)) e.bias = o.bias->data() + first;
      break;
    default:
      break;
  }
  return e;
}

// Everything about one curve's keys that can be wrong; `where` names the job
// and curve, so messages read "interpolate curves: curve 3, key 7 ...".
Status CheckCurve(const std::string& where, Interpolant kind, const CurveKeys& k,
                  const CurveExtras& e) {
  if (k.n == 0) return Status::Fail(where + "there are no keys");
  const bool scalar = k.d == 1;
  auto component = [scalar](Index j) { return scalar ? std::string() : ", component " + Str(j); };
  for (Index i = 0; i < k.n; ++i) {
    if (!internal::TimeInOrder(k.t, i)) return internal::TimeOrderFailure(k.t, i, where, internal::kKeyTimes);
    for (Index j = 0; j < k.d; ++j) {
      if (!std::isfinite(k.y_at(i, j))) {
        return Status::Fail(where + "value of key " + Str(i) + " (time " + Str(k.t[i]) + ")" +
                            component(j) + " is not finite");
      }
      if (e.slopes && !std::isfinite(e.slopes[i * e.slopes_stride + j])) {
        return Status::Fail(where + "hermite slope of key " + Str(i) + component(j) +
                            " is not finite");
      }
    }
    const std::pair<const char*, const double*> tcb[] = {
        {"tension", e.tension}, {"continuity", e.continuity}, {"bias", e.bias}};
    for (const auto& [name, array] : tcb) {
      if (array && !std::isfinite(array[i])) {
        return Status::Fail(where + name + " of key " + Str(i) + " is not finite");
      }
    }
  }
  for (Index j = 0; j < k.d; ++j) {
    if (e.start_slope && !std::isfinite(e.start_slope[j])) {
      return Status::Fail(where + "clamped start slope" + component(j) + " is not finite");
    }
    if (e.end_slope && !std::isfinite(e.end_slope[j])) {
      return Status::Fail(where + "clamped end slope" + component(j) + " is not finite");
    }
    if (kind == Interpolant::kPeriodicSpline && k.y_at(0, j) != k.y_at(k.n - 1, j)) {
      return Status::Fail(where + "a periodic spline needs the last key equal to the first, but" +
                          (scalar ? std::string() : " component " + Str(j) + " is") + " " +
                          Str(k.y_at(0, j)) + " at key 0 and " + Str(k.y_at(k.n - 1, j)) +
                          " at key " + Str(k.n - 1));
    }
  }
  return Status::Ok();
}

Status CheckEvalTimes(const std::string& where, const ConstVectorView& eval_times) {
  for (Index s = 0; s < eval_times.size(); ++s) {
    if (!std::isfinite(eval_times[s])) {
      return Status::Fail(where + "eval time " + Str(s) + " is not finite");
    }
  }
  return Status::Ok();
}

Status CheckShape(const std::string& where, const char* what, Index rows, Index cols,
                  Index want_rows, Index want_cols) {
  if (rows == want_rows && cols == want_cols) return Status::Ok();
  return Status::Fail(where + what + " must be " + Str(want_rows) + " x " + Str(want_cols) +
                      ", got " + Str(rows) + " x " + Str(cols));
}

CurveKeys Keys(const ConstVectorView& times, const ConstMatrixView& values) {
  return {times.data(), times.size(), values.data(), values.outerStride(), values.cols()};
}

// Scratch layout for one curve of n keys and d components.
struct Layout {
  double* slopes_in;
  double* slopes_out;
  double* coeffs;
  double* work;  // slope work, or the polynomial's weights
};

Layout Carve(InterpolationScratch& scratch, Index n, Index d) {
  const Index slopes = n * d, coeffs = std::max<Index>(n - 1, 1) * d * 4;
  const Index total = 2 * slopes + coeffs + interpolation_detail::SlopeWorkSize(n);
  if (static_cast<Index>(scratch.buffer.size()) < total) scratch.buffer.resize(total);
  double* base = scratch.buffer.data();
  return {base, base + slopes, base + 2 * slopes, base + 2 * slopes + coeffs};
}

// Prepares one curve (slopes and cubics, or polynomial weights) in `at`.
void Prepare(Interpolant kind, const CurveKeys& keys, const CurveExtras& extras, const Layout& at) {
  switch (kind) {
    case Interpolant::kPolynomial:
      interpolation_detail::BarycentricWeights(keys, at.work);
      return;
    case Interpolant::kStepped:
      interpolation_detail::SteppedCoefficients(keys, at.coeffs);
      return;
    default:
      interpolation_detail::HermiteSlopes(kind, keys, extras, at.slopes_in, at.slopes_out, at.work);
      interpolation_detail::HermiteCoefficients(keys, at.slopes_in, at.slopes_out, at.coeffs);
      return;
  }
}

}  // namespace

const char* InterpolantName(Interpolant kind) {
  for (const auto& named : kNames) {
    if (named.kind == kind) return named.name;
  }
  return "unknown";
}

std::optional<Interpolant> ParseInterpolant(std::string_view name) {
  for (const auto& named : kNames) {
    if (name == named.name) return named.kind;
  }
  return std::nullopt;
}

const char* InterpolantNames() {
  return "stepped, linear, polynomial, natural, clamped, periodic, not-a-knot, hermite, "
         "catmull-rom, centripetal, chordal, kochanek-bartels, monotone";
}

bool IsHermiteForm(Interpolant kind) {
  return kind != Interpolant::kStepped && kind != Interpolant::kPolynomial;
}

Status HermiteFormJob::Validate() const {
  const std::string where = "hermite form: ";
  if (!IsHermiteForm(options.interpolant)) {
    return Status::Fail(where + "'" + InterpolantName(options.interpolant) + "' " +
                        (options.interpolant == Interpolant::kStepped
                             ? "keys are constant between keys and have no Hermite slopes; "
                               "write them as CONSTANT keys"
                             : "is one polynomial through all keys, not a piecewise cubic; "
                               "sample it instead"));
  }
  if (values.rows() != times.size() || values.cols() < 1) {
    return Status::Fail(where + "values must be " + Str(times.size()) +
                        " x d (d >= 1, one row per key time), got " + Str(values.rows()) + " x " +
                        Str(values.cols()));
  }
  const Index n = times.size(), d = values.cols();
  for (Status s : {CheckShape(where, "slopes_in", slopes_in.rows(), slopes_in.cols(), n, d),
                   CheckShape(where, "slopes_out", slopes_out.rows(), slopes_out.cols(), n, d),
                   CheckOptionSizes(where, options, n, d, d)}) {
    if (!s) return s;
  }
  return CheckCurve(where, options.interpolant, Keys(times, values), Extras(options, 0, 0));
}

void HermiteFormJob::Run() {
  Validate().ThrowIfFailed();
  const CurveKeys keys = Keys(times, values);
  InterpolationScratch own;
  const Layout at = Carve(scratch ? *scratch : own, keys.n, keys.d);
  interpolation_detail::HermiteSlopes(options.interpolant, keys, Extras(options, 0, 0),
                                      at.slopes_in, at.slopes_out, at.work);
  for (Index i = 0; i < keys.n; ++i) {
    for (Index j = 0; j < keys.d; ++j) {
      slopes_in(i, j) = at.slopes_in[i * keys.d + j];
      slopes_out(i, j) = at.slopes_out[i * keys.d + j];
    }
  }
}

Status InterpolateJob::Validate() const {
  const std::string where = "interpolate: ";
  if (values.rows() != times.size() || values.cols() < 1) {
    return Status::Fail(where + "values must be " + Str(times.size()) +
                        " x d (d >= 1, one row per key time), got " + Str(values.rows()) + " x " +
                        Str(values.cols()));
  }
  const Index n = times.size(), d = values.cols(), m = eval_times.size();
  if (Status s = CheckShape(where, "samples", samples.rows(), samples.cols(), m, d); !s) return s;
  if (derivatives) {
    if (Status s = CheckShape(where, "derivatives", derivatives->rows(), derivatives->cols(), m, d);
        !s) {
      return s;
    }
  }
  if (Status s = CheckOptionSizes(where, options, n, d, d); !s) return s;
  if (Status s = CheckCurve(where, options.interpolant, Keys(times, values), Extras(options, 0, 0));
      !s) {
    return s;
  }
  return CheckEvalTimes(where, eval_times);
}

void InterpolateJob::Run() {
  Validate().ThrowIfFailed();
  const CurveKeys keys = Keys(times, values);
  InterpolationScratch own;
  const Layout at = Carve(scratch ? *scratch : own, keys.n, keys.d);
  Prepare(options.interpolant, keys, Extras(options, 0, 0), at);
  const Index m = eval_times.size();
  double* dout = derivatives ? derivatives->data() : nullptr;
  const Index dstride = derivatives ? derivatives->outerStride() : 0;
  if (options.interpolant == Interpolant::kPolynomial) {
    interpolation_detail::EvaluatePolynomial(keys, at.work, eval_times.data(), m, samples.data(),
                                             samples.outerStride(), dout, dstride);
    return;
  }
  const bool sorted = interpolation_detail::IsSorted(eval_times.data(), m);
  interpolation_detail::EvaluateCubic<false>(keys, at.coeffs, eval_times.data(), m, sorted,
                                             samples.data(), samples.outerStride(), dout, dstride);
}

Status InterpolateCurvesJob::Validate() const {
  const std::string where = "interpolate curves: ";
  const Index curves = offsets.size() - 1, total = times.size();
  if (curves < 0) return Status::Fail(where + "offsets needs curves + 1 entries");
  if (values.size() != total) {
    return Status::Fail(where + "times has " + Str(total) + " entries but values " +
                        Str(values.size()));
  }
  if (offsets[0] != 0 || offsets[curves] != total) {
    return Status::Fail(where + "offsets must run from 0 to the number of keys (" + Str(total) +
                        "), got " + Str(Index{offsets[0]}) + " to " + Str(Index{offsets[curves]}));
  }
  for (Index c = 0; c < curves; ++c) {
    if (offsets[c + 1] <= offsets[c]) {
      return Status::Fail(where + "curve " + Str(c) + " has no keys (offsets " +
                          Str(Index{offsets[c]}) + ", " + Str(Index{offsets[c + 1]}) + ")");
    }
  }
  const Index m = eval_times.size();
  if (Status s = CheckShape(where, "samples", samples.rows(), samples.cols(), curves, m); !s) {
    return s;
  }
  if (derivatives) {
    if (Status s =
            CheckShape(where, "derivatives", derivatives->rows(), derivatives->cols(), curves, m);
        !s) {
      return s;
    }
  }
  if (Status s = CheckOptionSizes(where, options, total, curves, 1); !s) return s;
  for (Index c = 0; c < curves; ++c) {
    const Index first = offsets[c];
    const CurveKeys keys{times.data() + first, offsets[c + 1] - first, values.data() + first, 1, 1};
    if (Status s = CheckCurve(where + "curve " + Str(c) + ", ", options.interpolant, keys,
                              Extras(options, first, c));
        !s) {
      return s;
    }
  }
  return CheckEvalTimes(where, eval_times);
}

void InterpolateCurvesJob::Run() {
  Validate().ThrowIfFailed();
  const Index curves = offsets.size() - 1, m = eval_times.size();
  Index most = 1;
  for (Index c = 0; c < curves; ++c) most = std::max<Index>(most, offsets[c + 1] - offsets[c]);
  InterpolationScratch own;
  const Layout at = Carve(scratch ? *scratch : own, most, 1);
  const bool sorted = interpolation_detail::IsSorted(eval_times.data(), m);
  for (Index c = 0; c < curves; ++c) {
    const Index first = offsets[c];
    const CurveKeys keys{times.data() + first, offsets[c + 1] - first, values.data() + first, 1, 1};
    Prepare(options.interpolant, keys, Extras(options, first, c), at);
    double* out = samples.row(c).data();
    double* dout = derivatives ? derivatives->row(c).data() : nullptr;
    if (options.interpolant == Interpolant::kPolynomial) {
      interpolation_detail::EvaluatePolynomial(keys, at.work, eval_times.data(), m, out, 1, dout, 1);
    } else {
      interpolation_detail::EvaluateCubic<true>(keys, at.coeffs, eval_times.data(), m, sorted, out,
                                                1, dout, 1);
    }
  }
}

}  // namespace motionkit
