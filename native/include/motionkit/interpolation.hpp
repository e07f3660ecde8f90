// Interpolation of keys at non-uniform times, for resampling animation curves.
//
// Keys: times t_0 < t_1 < ... < t_{n-1} (strictly increasing, finite, n >= 1)
// and values n x d (row i = key i, d >= 1 components: a scalar curve, a
// location, ...). Every interpolant but kPolynomial is a piecewise cubic
// Hermite (kStepped: constant per segment), which is what a Blender F-curve
// key with Bezier handles is; HermiteFormJob gives its end slopes so the
// add-on can write exact Bezier keys.
//
// Outside [t_0, t_{n-1}] every interpolant holds the end value with derivative
// 0, as Blender's F-curves extrapolate by default ('CONSTANT'). One key gives a
// constant. Inside, a curve passes through every key exactly (bit for bit).
#pragma once

#include <optional>
#include <string_view>
#include <vector>

#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

enum class Interpolant : int {
  kStepped,     // holds the left key's value until the next key
  kLinear,      // straight lines between keys
  kPolynomial,  // one polynomial of degree n - 1 through all keys (barycentric
                // Lagrange form); oscillates near the ends (Runge), for teaching
  // C2 cubic splines, one tridiagonal solve; equal to scipy's CubicSpline with
  // the bc_type of the same name.
  kNaturalSpline,   // second derivative 0 at both ends
  kClampedSpline,   // given first derivatives at both ends (default 0)
  kPeriodicSpline,  // first and last values must be equal; C2 across the wrap
  kNotAKnotSpline,  // third derivative continuous at t_1 and t_{n-2} (scipy's default)
  kHermite,         // caller-given slopes, n x d (= scipy's CubicHermiteSpline)
  // Catmull-Rom in time: slope at an interior key (P_{i+1} - P_{i-1}) /
  // (t_{i+1} - t_{i-1}); at the end keys the one-sided secant
  // (P_1 - P_0) / (t_1 - t_0) and (P_{n-1} - P_{n-2}) / (t_{n-1} - t_{n-2}).
  kCatmullRom,
  // Barry-Goldman Catmull-Rom with knots s_{i+1} = s_i + |P_{i+1} - P_i|^alpha
  // over the d-dimensional values (alpha 0.5 centripetal, 1 chordal). Each
  // segment's cubic in s is mapped linearly onto [t_i, t_{i+1}], so keys keep
  // their times; the slopes on either side of a key then differ by the ratio
  // of the chord-per-time rates of the two segments (same direction: the path
  // through space is G1, the curve in time is not C1). End keys take the
  // chord towards their one neighbour, as kCatmullRom. Coincident keys
  // (P_{i+1} == P_i) make a constant segment with slope 0 at both its ends,
  // and a key beside such a segment takes its tangent from its other chord
  // alone, as an end key would: no division by zero, no NaN.
  kCentripetalCatmullRom,
  kChordalCatmullRom,
  // Kochanek-Bartels with per-key tension T, continuity C, bias B, adjusted
  // for uneven key spacing (Kochanek & Bartels 1984, section 5): at key i,
  //   slope_in  = (a_in  (P_i - P_{i-1}) + b_in  (P_{i+1} - P_i)) / (t_{i+1} - t_{i-1})
  //   slope_out = (a_out (P_i - P_{i-1}) + b_out (P_{i+1} - P_i)) / (t_{i+1} - t_{i-1})
  //   a_in  = (1-T)(1-C)(1+B), b_in  = (1-T)(1+C)(1-B),
  //   a_out = (1-T)(1+C)(1+B), b_out = (1-T)(1-C)(1-B).
  // T = C = B = 0 gives kCatmullRom bit for bit; C != 0 gives different in
  // and out slopes (a corner). An end key mirrors its neighbour
  // (P_{-1} = 2 P_0 - P_1 at t_0 - (t_1 - t_0), likewise at the far end), so
  // its T, C, B still act and 0, 0, 0 gives Catmull-Rom's one-sided end.
  kKochanekBartels,
  kMonotone,  // PCHIP, = scipy's PchipInterpolator (its slopes and end rules): no overshoot
};

// The name the Python bindings use ("natural", "catmull-rom", ...).
const char* InterpolantName(Interpolant kind);
std::optional<Interpolant> ParseInterpolant(std::string_view name);
// All names, comma separated, for error messages.
const char* InterpolantNames();
// Whether HermiteFormJob can express the kind (all but stepped and polynomial).
bool IsHermiteForm(Interpolant kind);

// Settings of one interpolation; the optional arrays are views onto caller
// memory (emplace them: options.slopes.emplace(my_matrix)), which must outlive
// the jobs given these options. A view of a strided expression holds its own
// copy, which a job's copy of the options still points into: emplace plain
// arrays, maps or contiguous blocks.
// For InterpolateJob and HermiteFormJob (one curve of d components):
//   start_slope, end_slope: kClampedSpline's first derivatives at t_0 and
//     t_{n-1}, d each; absent means 0 (scipy's bc_type='clamped').
//   slopes: kHermite's slopes, n x d; required for it.
//   tension, continuity, bias: kKochanekBartels, n each; absent or empty means 0.
// For InterpolateCurvesJob (c scalar curves back to back): the per-key arrays
// follow the keys' layout (slopes total x 1, tension... total each) and
// start_slope, end_slope hold one value per curve.
struct InterpolationOptions {
  Interpolant interpolant = Interpolant::kNaturalSpline;
  std::optional<ConstVectorView> start_slope;
  std::optional<ConstVectorView> end_slope;
  std::optional<ConstMatrixView> slopes;
  std::optional<ConstVectorView> tension;
  std::optional<ConstVectorView> continuity;
  std::optional<ConstVectorView> bias;
};

// Working memory of the jobs below. Pass the same one to repeated jobs to
// allocate only when a larger problem comes along.
struct InterpolationScratch {
  std::vector<double> buffer;
};

// The Hermite form of a curve. Contract (what the add-on relies on to write
// exact Blender Bezier keys): on [t_i, t_{i+1}] the curve is the cubic
// Hermite with end values y_i, y_{i+1} and end slopes slopes_out[i],
// slopes_in[i + 1], in value per time unit. As a Bezier in (time, value):
//   right handle of key i     = (t_i + h/3,     y_i     + slopes_out[i] h/3),
//   left handle of key i + 1  = (t_{i+1} - h/3, y_{i+1} - slopes_in[i+1] h/3),
// h = t_{i+1} - t_i, which Blender evaluates exactly as this cubic (its time
// is then linear in the Bezier parameter) as long as it does not recompute
// the handles: write them as FREE (kinds with in != out slopes) or ALIGNED. slopes_in[0] and
// slopes_out[n-1] face outside the keys: they continue the end segments
// (slopes_in[0] = slopes_out[0], slopes_out[n-1] = slopes_in[n-1]); the
// curve itself extrapolates flat. kLinear gives the secant slopes; kStepped
// and kPolynomial have no Hermite form and fail Validate().
struct HermiteFormJob {
  HermiteFormJob(ConstVectorView times_in, ConstMatrixView values_in,
                 const InterpolationOptions& options_in, Eigen::Ref<RowMatrixXd> slopes_in_out,
                 Eigen::Ref<RowMatrixXd> slopes_out_out)
      : times(times_in),
        values(values_in),
        options(options_in),
        slopes_in(slopes_in_out),
        slopes_out(slopes_out_out) {}

  ConstVectorView times;            // n
  ConstMatrixView values;           // n x d
  InterpolationOptions options;
  Eigen::Ref<RowMatrixXd> slopes_in;   // n x d, output
  Eigen::Ref<RowMatrixXd> slopes_out;  // n x d, output
  InterpolationScratch* scratch = nullptr;  // optional, reused across jobs

  Status Validate() const;
  void Run();
};

// One curve of d components evaluated at m times, in any order (sorted times
// walk the segments; others binary search). Writes samples (m x d) and, when
// given, the analytic derivative d/dt (m x d; 0 for kStepped and outside the
// keys; at t_{n-1} the left derivative).
struct InterpolateJob {
  InterpolateJob(ConstVectorView times_in, ConstMatrixView values_in,
                 const InterpolationOptions& options_in, ConstVectorView eval_times_in,
                 Eigen::Ref<RowMatrixXd> samples_out)
      : times(times_in),
        values(values_in),
        options(options_in),
        eval_times(eval_times_in),
        samples(samples_out) {}

  ConstVectorView times;    // n
  ConstMatrixView values;   // n x d
  InterpolationOptions options;
  ConstVectorView eval_times;            // m
  Eigen::Ref<RowMatrixXd> samples;       // m x d, output
  std::optional<Eigen::Ref<RowMatrixXd>> derivatives;  // m x d, output when given
  InterpolationScratch* scratch = nullptr;

  Status Validate() const;
  void Run();
};

// Many independent scalar curves, each with its own keys, at shared times.
// Curve k owns entries [offsets[k], offsets[k + 1]) of times and values (and
// of the per-key option arrays); every curve needs at least one key. Each
// curve's segments are turned into power-basis cubics once, so sampling is a
// Horner evaluation per sample. Writes samples (c x m) and optionally
// derivatives (c x m).
struct InterpolateCurvesJob {
  InterpolateCurvesJob(Eigen::Ref<const Eigen::VectorXi> offsets_in, ConstVectorView times_in,
                       ConstVectorView values_in, const InterpolationOptions& options_in,
                       ConstVectorView eval_times_in, Eigen::Ref<RowMatrixXd> samples_out)
      : offsets(offsets_in),
        times(times_in),
        values(values_in),
        options(options_in),
        eval_times(eval_times_in),
        samples(samples_out) {}

  Eigen::Ref<const Eigen::VectorXi> offsets;  // c + 1, from 0 to the number of keys
  ConstVectorView times;                      // total keys
  ConstVectorView values;                     // total keys
  InterpolationOptions options;
  ConstVectorView eval_times;                 // m
  Eigen::Ref<RowMatrixXd> samples;            // c x m, output
  std::optional<Eigen::Ref<RowMatrixXd>> derivatives;  // c x m, output when given
  InterpolationScratch* scratch = nullptr;

  Status Validate() const;
  void Run();
};

}  // namespace motionkit
