#include "motionkit/fk.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>

// How it is fast (about 10 ns per joint and frame on a 31-joint skeleton):
// frames are solved several at a time in vector lanes, the half-angle sines and
// cosines come from a vectorised polynomial instead of libm, quaternions are
// composed rather than matrices, the next rows are prefetched, and nothing is
// allocated.
//
// On x86-64 with GCC or Clang the solver is compiled twice, for the baseline
// ISA and for AVX2 with FMA, and picks one at run time: the build has no
// -march flag, and the wider vectors more than halve the time.
#if defined(__GNUC__)
#define MOTIONKIT_FK_PREFETCH(address, for_write) __builtin_prefetch((address), (for_write))
#else
#define MOTIONKIT_FK_PREFETCH(address, for_write) ((void)0)
#endif

#if defined(__GNUC__) && defined(__x86_64__)
#define MOTIONKIT_FK_X86_DISPATCH 1
#define MOTIONKIT_FK_INLINE inline __attribute__((always_inline))
#else
#define MOTIONKIT_FK_X86_DISPATCH 0
#define MOTIONKIT_FK_INLINE inline
#endif

namespace motionkit {
namespace internal {
// Tests turn the AVX2 path off to exercise the baseline one too.
bool fk_allow_avx2 = true;
}  // namespace internal

namespace {

constexpr double kPi = 3.14159265358979323846;

// Adding and subtracting 1.5 * 2^52 rounds a double of magnitude below 2^51 to
// the nearest integer in the default rounding mode, without a library call,
// so the loop below vectorises. (The build never uses -ffast-math.)
constexpr double kRoundMagic = 6755399441055744.0;
// Beyond this many degrees the rounding above would overflow; such angles
// take a slower exact path.
constexpr double kLargeDegrees = 1e14;

MOTIONKIT_FK_INLINE double RoundToInteger(double x) { return (x + kRoundMagic) - kRoundMagic; }

// sin and cos on |r| <= pi/4 as r + r^3 P(r^2) and 1 - r^2/2 + r^4 Q(r^2), P and
// Q of degree 5: near-minimax fits (Chebyshev, mpmath.chebyfit at 50 digits
// on [0, (pi/4)^2]) whose own error is below 2e-17, so each result is within
// about one unit in the last place.
MOTIONKIT_FK_INLINE void SinCosSmall(double r, double* s, double* c) {
  const double r2 = r * r;
  double p = 1.5918129294866608e-10;
  p = p * r2 - 2.5051131845003624e-08;
  p = p * r2 + 2.755731610255244e-06;
  p = p * r2 - 0.00019841269836758574;
  p = p * r2 + 0.008333333333330948;
  p = p * r2 - 0.16666666666666666;
  *s = r + r * r2 * p;
  double q = -1.1382632425521717e-11;
  q = q * r2 + 2.08761462684032e-09;
  q = q * r2 - 2.7557317271729793e-07;
  q = q * r2 + 2.480158729876569e-05;
  q = q * r2 - 0.0013888888888887398;
  q = q * r2 + 0.041666666666666664;
  *c = 1.0 + r2 * (q * r2 - 0.5);
}

// cos and sin of half an angle given in degrees, for |degrees| < 2^51 * 180.
// The reduction is done in degrees, where it is exact: x = 180 n + r with
// |r| <= 90 (x - 180 n is exact by Sterbenz's lemma), so x/2 = n pi/2 + r pi/360
// and only the final scaling of r rounds.
MOTIONKIT_FK_INLINE void HalfAngleCosSinOne(double x, double* cos_out, double* sin_out) {
  const double n = RoundToInteger(x * (1.0 / 180.0));
  const double r = (x - 180.0 * n) * (kPi / 360.0);
  double s, c;
  SinCosSmall(r, &s, &c);
  // n = 2 m + e with e in {-1, 0, 1}: turn by e quarter turns, then by m half
  // turns; arithmetic rather than branches, so that loops over it vectorise.
  const double m = RoundToInteger(0.5 * n);
  const double e = n - 2.0 * m;
  const double keep = 1.0 - std::abs(e);
  const double se = keep * s + e * c;
  const double ce = keep * c - e * s;
  const double m_odd = std::abs(m - 2.0 * RoundToInteger(0.5 * m));
  const double sign = 1.0 - 2.0 * m_odd;
  *sin_out = sign * se;
  *cos_out = sign * ce;
}

// cos and sin of half of each angle given in degrees: the scalar and vector
// parts of the joints' axis quaternions.
MOTIONKIT_FK_INLINE void HalfAngleCosSin(const double* __restrict degrees, int count,
                                         double* __restrict cos_out, double* __restrict sin_out) {
  for (int i = 0; i < count; ++i) HalfAngleCosSinOne(degrees[i], cos_out + i, sin_out + i);
}

// The same for angles of any size, one at a time.
void HalfAngleCosSinAnySize(double degrees, double* cos_out, double* sin_out) {
  // fmod is exact, and 720 degrees is a whole period of the half angle.
  if (!(std::abs(degrees) < kLargeDegrees)) degrees = std::fmod(degrees, 720.0);
  HalfAngleCosSinOne(degrees, cos_out, sin_out);
}

// Frames solved together. Frames are independent, so a joint is computed for
// a block of them side by side: each step is one vector operation (one lane a
// frame), and the parent-to-child dependency chain of one frame no longer
// stalls the others. The block is as wide as a vector register: 2 frames on
// the baseline ISA (SSE2, or NEON), 4 with AVX2.
constexpr int kMaxBlock = 4;
// How far ahead (in blocks) to prefetch; 2 to 3 measured best on a 10,000-frame clip.
constexpr int kPrefetchBlocks = 3;
// Columns whose half-angle cosines and sines are computed at once (for each
// frame of a block); a joint has at most kMaxChannelsPerJoint, so any joint
// fits in one batch.
constexpr int kBatch = 64;
static_assert(kBatch >= kMaxChannelsPerJoint, "a joint's channels must fit in one batch");

// Vec<L>::type holds L doubles, one per frame of a block. GCC and Clang vector
// extensions give plain arithmetic on whole registers; other compilers get a
// loop per operation (define MOTIONKIT_FK_NO_VECTOR_EXT to try that path with
// GCC). No function takes or returns one by value, which would make GCC and
// Clang warn that the calling convention for 32-byte vectors depends on AVX
// (-Wpsabi).
#if defined(__GNUC__) && !defined(MOTIONKIT_FK_NO_VECTOR_EXT)
#define MOTIONKIT_FK_VECTOR_EXT 1
template <int L>
struct Vec;
template <>
struct Vec<2> {
  typedef double type __attribute__((vector_size(2 * sizeof(double))));
};
template <>
struct Vec<4> {
  typedef double type __attribute__((vector_size(4 * sizeof(double))));
};
#define MOTIONKIT_FK_LANE(lanes, b) (lanes)[b]
#else
#define MOTIONKIT_FK_VECTOR_EXT 0
template <int L>
struct LaneArray {
  double v[L];
};
#define MOTIONKIT_FK_LANE_OP(op)                                               \
  template <int L>                                                             \
  LaneArray<L> operator op(const LaneArray<L>& a, const LaneArray<L>& b) {     \
    LaneArray<L> r;                                                            \
    for (int i = 0; i < L; ++i) r.v[i] = a.v[i] op b.v[i];                     \
    return r;                                                                  \
  }                                                                            \
  template <int L>                                                             \
  LaneArray<L> operator op(const LaneArray<L>& a, double b) {                  \
    LaneArray<L> r;                                                            \
    for (int i = 0; i < L; ++i) r.v[i] = a.v[i] op b;                          \
    return r;                                                                  \
  }
MOTIONKIT_FK_LANE_OP(+)
MOTIONKIT_FK_LANE_OP(-)
MOTIONKIT_FK_LANE_OP(*)
#undef MOTIONKIT_FK_LANE_OP
template <int L>
struct Vec {
  typedef LaneArray<L> type;
};
#define MOTIONKIT_FK_LANE(lanes, b) (lanes).v[b]
#endif

// L consecutive doubles.
template <typename V>
MOTIONKIT_FK_INLINE void LoadTo(V& out, const double* p) {
  std::memcpy(&out, p, sizeof(out));
}

// Between lanes (one per frame) and rows (one per frame): rows[b][offset + i]
// is lane b of v[i]. Element by element: in measurements this beat 4 x 4
// shuffle transposes with whole-vector loads and stores.
template <int L, int n>
MOTIONKIT_FK_INLINE void StoreRows(const typename Vec<L>::type (&v)[n], double* const* rows,
                                   std::size_t offset) {
  for (int b = 0; b < L; ++b) {
    for (int i = 0; i < n; ++i) rows[b][offset + i] = MOTIONKIT_FK_LANE(v[i], b);
  }
}

template <int L>
MOTIONKIT_FK_INLINE void LoadColumn(typename Vec<L>::type& out, double* const* rows,
                                    std::size_t offset) {
#if MOTIONKIT_FK_VECTOR_EXT
  // Initialisers rather than element stores, which GCC takes for partly
  // uninitialised vectors (-Wmaybe-uninitialized).
  if constexpr (L == 2) {
    out = typename Vec<L>::type{rows[0][offset], rows[1][offset]};
  } else {
    static_assert(L == 4, "one initialiser per lane");
    out = typename Vec<L>::type{rows[0][offset], rows[1][offset], rows[2][offset],
                                rows[3][offset]};
  }
#else
  for (int b = 0; b < L; ++b) out.v[b] = rows[b][offset];
#endif
}

const char* NonFiniteName(double v) {
  if (std::isnan(v)) return "nan";
  return v > 0 ? "inf" : "-inf";
}

std::string Shape(Eigen::Index rows, Eigen::Index cols) {
  return std::to_string(rows) + " x " + std::to_string(cols);
}

// The skeleton and the shapes (cheap).
Status CheckShapes(const ForwardKinematicsJob& job) {
  const Skeleton& skeleton = job.skeleton;
  if (Status s = skeleton.Validate(); !s) return s;
  const Eigen::Index frames = job.values.rows();
  const auto joints = static_cast<Eigen::Index>(skeleton.joints.size());
  if (job.values.cols() != skeleton.channel_count) {
    return Status::Fail("fk: values has " + std::to_string(job.values.cols()) +
                        " columns but the skeleton has " + std::to_string(skeleton.channel_count) +
                        " channels");
  }
  if (job.positions.rows() != frames || job.positions.cols() != 3 * joints) {
    return Status::Fail("fk: output positions must be " + Shape(frames, 3 * joints) + ", got " +
                        Shape(job.positions.rows(), job.positions.cols()));
  }
  if (job.orientations.rows() != frames || job.orientations.cols() != 4 * joints) {
    return Status::Fail("fk: output orientations must be " + Shape(frames, 4 * joints) +
                        ", got " + Shape(job.orientations.rows(), job.orientations.cols()));
  }
  return Status::Ok();
}

// True when every value is finite and below kLargeDegrees in magnitude: one
// vectorised pass that only compares.
template <int L>
MOTIONKIT_FK_INLINE bool AllOrdinary(const ConstMatrixView& values) {
  const Eigen::Index n = values.cols();
  for (Eigen::Index f = 0; f < values.rows(); ++f) {
    const double* row = values.row(f).data();
    bool unusual = false;
    Eigen::Index i = 0;
#if MOTIONKIT_FK_VECTOR_EXT
    using V = typename Vec<L>::type;
    const V large = V{} + kLargeDegrees;
    V v{};
    auto seen = (v != v);  // all false, of the comparison's mask type
    for (; i + L <= n; i += L) {
      LoadTo(v, row + i);
      seen |= (v != v) | (v >= large) | (v <= -large);  // NaN, or large or infinite
    }
    for (int b = 0; b < L; ++b) unusual |= seen[b] != 0;
#endif
    for (; i < n; ++i) unusual |= !(std::abs(row[i]) < kLargeDegrees);
    if (unusual) return false;
  }
  return true;
}

// After AllOrdinary() said no: names the first value that is not finite, if
// any (else some are merely large).
Status CheckValues(const ForwardKinematicsJob& job) {
  for (Eigen::Index f = 0; f < job.values.rows(); ++f) {
    for (const Joint& joint : job.skeleton.joints) {
      for (int c = 0; c < joint.channel_count; ++c) {
        const double v = job.values(f, joint.first_channel + c);
        if (!std::isfinite(v)) {
          return Status::Fail("fk: frame " + std::to_string(f) + ", joint '" + joint.name +
                              "' channel " +
                              ChannelName(joint.channels[static_cast<std::size_t>(c)]) + " is " +
                              NonFiniteName(v));
        }
      }
    }
  }
  return Status::Ok();
}

// The whole clip. kAnySize handles angles beyond kLargeDegrees, which a real
// clip never has, at the cost of vectorisation.
template <int L, bool kAnySize>
MOTIONKIT_FK_INLINE void SolveClip(const Skeleton& skeleton, const ConstMatrixView& values,
                                   Eigen::Ref<RowMatrixXd>& positions,
                                   Eigen::Ref<RowMatrixXd>& orientations) {
  static_assert(L <= kMaxBlock, "scratch is sized for kMaxBlock lanes");
  using V = typename Vec<L>::type;
  const Eigen::Index frames = values.rows();
  const int channels = skeleton.channel_count;
  const std::size_t joint_count = skeleton.joints.size();
  // Scratch on the stack, lane-minor ([column][frame of the block]): Run
  // allocates nothing.
  alignas(64) double raw[kBatch * kMaxBlock];
  alignas(64) double half_cos[kBatch * kMaxBlock];
  alignas(64) double half_sin[kBatch * kMaxBlock];

  for (Eigen::Index f0 = 0; f0 < frames; f0 += L) {
    const double* in[L];
    double* pos[L];
    double* ori[L];
    const double* ahead_in[L];  // the rows kPrefetchBlocks blocks on
    const double* ahead_pos[L];
    const double* ahead_ori[L];
    for (int b = 0; b < L; ++b) {
      // A short last block repeats its last frame, which writes the same
      // numbers to the same place twice.
      const Eigen::Index f = std::min<Eigen::Index>(f0 + b, frames - 1);
      in[b] = values.row(f).data();
      pos[b] = positions.row(f).data();
      ori[b] = orientations.row(f).data();
      const Eigen::Index ahead =
          std::min<Eigen::Index>(f0 + kPrefetchBlocks * L + b, frames - 1);
      ahead_in[b] = values.row(ahead).data();
      ahead_pos[b] = positions.row(ahead).data();
      ahead_ori[b] = orientations.row(ahead).data();
    }
    int batch_begin = 0;
    int batch_end = 0;  // nothing computed yet for this block

    for (std::size_t j = 0; j < joint_count; ++j) {
      const Joint& joint = skeleton.joints[j];
      const int first = joint.first_channel;
      if (first + joint.channel_count > batch_end) {
        batch_begin = first;
        batch_end = std::min(first + kBatch, channels);
        const int n = batch_end - batch_begin;
        for (int k = 0; k < n; ++k) {
          for (int b = 0; b < L; ++b) raw[k * L + b] = in[b][batch_begin + k];
        }
        if constexpr (kAnySize) {
          for (int i = 0; i < n * L; ++i) {
            HalfAngleCosSinAnySize(raw[i], half_cos + i, half_sin + i);
          }
        } else {
          HalfAngleCosSin(raw, n * L, half_cos, half_sin);
        }
      }

      // Local rotation R_i (w, x, y, z), composed channel by channel, and t_i.
      const V zero{};
      V w = zero + 1.0, x = zero, y = zero, z = zero;
      // Separate variables, not an array, so that they stay in registers.
      V t0 = zero + joint.offset[0], t1 = zero + joint.offset[1], t2 = zero + joint.offset[2];
      for (int c = 0; c < joint.channel_count; ++c) {
        const ChannelType type = joint.channels[static_cast<std::size_t>(c)];
        const int k = (first + c - batch_begin) * L;
        V hc, hs;
        LoadTo(hc, half_cos + k);
        LoadTo(hs, half_sin + k);
        V nw, nx, ny, nz;
        switch (type) {
          case ChannelType::kXrotation:  // q * (hc, hs, 0, 0)
            nw = w * hc - x * hs;
            nx = x * hc + w * hs;
            ny = y * hc + z * hs;
            nz = z * hc - y * hs;
            break;
          case ChannelType::kYrotation:  // q * (hc, 0, hs, 0)
            nw = w * hc - y * hs;
            nx = x * hc - z * hs;
            ny = y * hc + w * hs;
            nz = z * hc + x * hs;
            break;
          case ChannelType::kZrotation:  // q * (hc, 0, 0, hs)
            nw = w * hc - z * hs;
            nx = x * hc + y * hs;
            ny = y * hc - x * hs;
            nz = z * hc + w * hs;
            break;
          // A position channel replaces one component of the offset.
          case ChannelType::kXposition:
            LoadTo(t0, raw + k);
            continue;
          case ChannelType::kYposition:
            LoadTo(t1, raw + k);
            continue;
          case ChannelType::kZposition:
            LoadTo(t2, raw + k);
            continue;
          default:  // no other types pass Skeleton::Validate()
            continue;
        }
        w = nw;
        x = nx;
        y = ny;
        z = nz;
      }

      V q[4] = {w, x, y, z};
      if (joint.parent >= 0) {
        const std::size_t oq = 4 * static_cast<std::size_t>(joint.parent);
        const std::size_t op = 3 * static_cast<std::size_t>(joint.parent);
        V pw, px, py, pz, p0, p1, p2;
        LoadColumn<L>(pw, ori, oq);
        LoadColumn<L>(px, ori, oq + 1);
        LoadColumn<L>(py, ori, oq + 2);
        LoadColumn<L>(pz, ori, oq + 3);
        LoadColumn<L>(p0, pos, op);
        LoadColumn<L>(p1, pos, op + 1);
        LoadColumn<L>(p2, pos, op + 2);
        // Q_i = Q_p R_i
        q[0] = pw * w - px * x - py * y - pz * z;
        q[1] = pw * x + px * w + py * z - pz * y;
        q[2] = pw * y - px * z + py * w + pz * x;
        q[3] = pw * z + px * y - py * x + pz * w;
        // p_i = p_p + Q_p t_i, rotating with t + w u + v x u where u = 2 v x t.
        const V ux = (py * t2 - pz * t1) * 2.0;
        const V uy = (pz * t0 - px * t2) * 2.0;
        const V uz = (px * t1 - py * t0) * 2.0;
        t0 = p0 + t0 + pw * ux + (py * uz - pz * uy);
        t1 = p1 + t1 + pw * uy + (pz * ux - px * uz);
        t2 = p2 + t2 + pw * uz + (px * uy - py * ux);
      }
      // Ask for the same joint's lines of a later block now, so that a clip
      // larger than the caches streams instead of stalling on every line.
      // Every other joint is enough: two joints span at most 64 bytes of a row.
      if (j % 2 == 0) {
        for (int b = 0; b < L; ++b) {
          MOTIONKIT_FK_PREFETCH(ahead_in[b] + first, 0);
          MOTIONKIT_FK_PREFETCH(ahead_pos[b] + 3 * j, 1);
          MOTIONKIT_FK_PREFETCH(ahead_ori[b] + 4 * j, 1);
        }
      }
      const V t[3] = {t0, t1, t2};
      StoreRows<L>(q, ori, 4 * j);
      StoreRows<L>(t, pos, 3 * j);
    }
  }
}

// Angles beyond kLargeDegrees: never in a real clip, so not worth a copy per ISA.
void SolveAnySize(const Skeleton& skeleton, const ConstMatrixView& values,
                  Eigen::Ref<RowMatrixXd>& positions, Eigen::Ref<RowMatrixXd>& orientations) {
  SolveClip<2, true>(skeleton, values, positions, orientations);
}

// Run() after the shapes are known to be right: scan the values, then solve.
template <int L>
MOTIONKIT_FK_INLINE void ScanAndSolve(ForwardKinematicsJob& job) {
  if (AllOrdinary<L>(job.values)) {
    SolveClip<L, false>(job.skeleton, job.values, job.positions, job.orientations);
    return;
  }
  CheckValues(job).ThrowIfFailed();
  SolveAnySize(job.skeleton, job.values, job.positions, job.orientations);
}

void RunBaseline(ForwardKinematicsJob& job) { ScanAndSolve<2>(job); }

#if MOTIONKIT_FK_X86_DISPATCH
// The same code with four lanes, inlined into a function compiled for AVX2
// and FMA. (With FMA the last bit of a result may differ from the baseline.)
__attribute__((target("avx2,fma"))) void RunAvx2(ForwardKinematicsJob& job) {
  ScanAndSolve<4>(job);
}

bool HasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

}  // namespace

Status ForwardKinematicsJob::Validate() const {
  if (Status s = CheckShapes(*this); !s) return s;
  if (AllOrdinary<2>(values)) return Status::Ok();
  return CheckValues(*this);
}

void ForwardKinematicsJob::Run() {
  CheckShapes(*this).ThrowIfFailed();
#if MOTIONKIT_FK_X86_DISPATCH
  if (internal::fk_allow_avx2 && HasAvx2()) {
    RunAvx2(*this);
    return;
  }
#endif
  RunBaseline(*this);
}

}  // namespace motionkit
