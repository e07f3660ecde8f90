#include "bvh_fk.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "parallel.hpp"
#include "so3.hpp"

// How it is fast (about 8 ns per joint and frame on a 31-joint skeleton in
// cache, AVX2): frames are solved several at a time in vector lanes, the
// half-angle sines and cosines come from a vectorised polynomial instead of
// libm, quaternions are composed rather than matrices, and nothing is
// allocated. A block's results stay lane by lane in a buffer on the stack,
// where children read their parents with whole-vector loads; rows go in and
// out through in-register transposes of square tiles, a joint's tile as soon
// as it is done; and what each joint's channels are is worked out once per
// run, so that the usual joint (three rotations about distinct axes) runs
// straight-line code.
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
// Joint-frames below which another thread is not worth starting (about 0.1 ms
// of work); tests lower it to split short clips.
Eigen::Index fk_min_joint_frames_per_thread = 16384;
}  // namespace internal

namespace {

using internal::kPi;

// Adding and subtracting 1.5 * 2^52 rounds a double of magnitude below 2^51 to
// the nearest integer in the default rounding mode, without a library call,
// so the loops below vectorise. (The build never uses -ffast-math.) In between,
// the sum's low mantissa bits are that integer in two's complement.
constexpr double kRoundMagic = 6755399441055744.0;
// Beyond this many degrees the rounding above would overflow; such angles
// are first reduced with fmod.
constexpr double kLargeDegrees = 1e14;

MOTIONKIT_FK_INLINE double RoundToInteger(double x) { return (x + kRoundMagic) - kRoundMagic; }

// sin and cos on |r| <= pi/4 as r + r^3 P(r^2) and 1 - r^2/2 + r^4 Q(r^2), P and
// Q of degree 5: near-minimax fits (Chebyshev, mpmath.chebyfit at 50 digits
// on [0, (pi/4)^2]) whose own error is below 2e-17, so each result is within
// about one unit in the last place. T is a double or a vector of them.
template <typename T>
MOTIONKIT_FK_INLINE void SinCosSmall(const T& r, T* s, T* c) {
  const T r2 = r * r;
  T p = r2 * 1.5918129294866608e-10 - 2.5051131845003624e-08;
  p = p * r2 + 2.755731610255244e-06;
  p = p * r2 - 0.00019841269836758574;
  p = p * r2 + 0.008333333333330948;
  p = p * r2 - 0.16666666666666666;
  *s = r + r * r2 * p;
  T q = r2 * -1.1382632425521717e-11 + 2.08761462684032e-09;
  q = q * r2 - 2.7557317271729793e-07;
  q = q * r2 + 2.480158729876569e-05;
  q = q * r2 - 0.0013888888888887398;
  q = q * r2 + 0.041666666666666664;
  *c = r2 * (q * r2 - 0.5) + 1.0;
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

// Frames solved together. Frames are independent, so a joint is computed for
// a block of them side by side: each step is one vector operation (one lane a
// frame), and the parent-to-child dependency chain of one frame no longer
// stalls the others. The block is as wide as a vector register: 2 frames on
// the baseline ISA (SSE2, or NEON), 4 with AVX2.
constexpr int kMaxBlock = 4;
// Columns whose half-angle cosines and sines are computed at once (for each
// frame of a block); a joint has at most kMaxChannelsPerJoint, so any joint
// fits in one batch.
constexpr int kBatch = 64;
static_assert(kBatch >= kMaxChannelsPerJoint, "a joint's channels must fit in one batch");
// Joints whose results a block keeps lane by lane before writing them out as
// rows (7 KB a lane): any real skeleton's parents are then read from there.
// A parent in an earlier chunk is read back from the output rows.
constexpr int kChunk = 128;
// How far ahead (in blocks) to prefetch; 2 to 3 measured best on a 10,000-frame clip.
constexpr int kPrefetchBlocks = 3;

// Vec<L>::type holds L doubles, one per frame of a block. GCC and Clang vector
// extensions give plain arithmetic on whole registers; other compilers get a
// loop per operation (define MOTIONKIT_FK_NO_VECTOR_EXT to try that path with
// GCC). No function takes or returns one by value, which would make GCC and
// Clang warn that the calling convention for 32-byte vectors depends on AVX
// (-Wpsabi).
#if defined(__GNUC__) && !defined(MOTIONKIT_FK_NO_VECTOR_EXT)
#define MOTIONKIT_FK_VECTOR_EXT 1
template <int L>
struct Vec {
  typedef double type __attribute__((vector_size(L * sizeof(double))));
  typedef std::uint64_t bits __attribute__((vector_size(L * sizeof(double))));
  typedef std::int64_t ints __attribute__((vector_size(L * sizeof(double))));
};
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
#endif

// L consecutive doubles, from and to memory of any alignment.
template <typename V>
MOTIONKIT_FK_INLINE void LoadTo(V& out, const double* p) {
  std::memcpy(&out, p, sizeof(out));
}
template <typename V>
MOTIONKIT_FK_INLINE void StoreFrom(double* p, const V& v) {
  std::memcpy(p, &v, sizeof(v));
}

#if MOTIONKIT_FK_VECTOR_EXT
// An L x L tile transposed in registers (unpacks, then swaps of 128-bit
// halves): from[i] is read at from_base + i * from_step, row b of the result
// written at to_base + b * to_step. Named variables rather than arrays, which
// GCC would keep on the stack.
template <int L>
MOTIONKIT_FK_INLINE void TransposeTile(const double* const* from, std::size_t from_offset,
                                       double* const* to, std::size_t to_offset) {
  using V = typename Vec<L>::type;
  if constexpr (L == 2) {
    V a, b;
    LoadTo(a, from[0] + from_offset);
    LoadTo(b, from[1] + from_offset);
    const V c0 = __builtin_shufflevector(a, b, 0, 2);
    const V c1 = __builtin_shufflevector(a, b, 1, 3);
    StoreFrom(to[0] + to_offset, c0);
    StoreFrom(to[1] + to_offset, c1);
  } else {
    static_assert(L == 4, "tiles of 2 or 4");
    V a, b, c, d;
    LoadTo(a, from[0] + from_offset);
    LoadTo(b, from[1] + from_offset);
    LoadTo(c, from[2] + from_offset);
    LoadTo(d, from[3] + from_offset);
    const V t0 = __builtin_shufflevector(a, b, 0, 4, 2, 6);
    const V t1 = __builtin_shufflevector(a, b, 1, 5, 3, 7);
    const V t2 = __builtin_shufflevector(c, d, 0, 4, 2, 6);
    const V t3 = __builtin_shufflevector(c, d, 1, 5, 3, 7);
    const V c0 = __builtin_shufflevector(t0, t2, 0, 1, 4, 5);
    const V c1 = __builtin_shufflevector(t1, t3, 0, 1, 4, 5);
    const V c2 = __builtin_shufflevector(t0, t2, 2, 3, 6, 7);
    const V c3 = __builtin_shufflevector(t1, t3, 2, 3, 6, 7);
    StoreFrom(to[0] + to_offset, c0);
    StoreFrom(to[1] + to_offset, c1);
    StoreFrom(to[2] + to_offset, c2);
    StoreFrom(to[3] + to_offset, c3);
  }
}
#endif

// Rows to lanes: lanes[k * L + b] = rows[b][offset + k] for k < n.
template <int L>
MOTIONKIT_FK_INLINE void RowsToLanes(const double* const* rows, std::size_t offset, int n,
                                     double* lanes) {
  int k = 0;
#if MOTIONKIT_FK_VECTOR_EXT
  for (; k + L <= n; k += L) {
    double* to[L];
    for (int i = 0; i < L; ++i) to[i] = lanes + (k + i) * L;
    TransposeTile<L>(rows, offset + static_cast<std::size_t>(k), to, 0);
  }
#endif
  for (; k < n; ++k) {
    for (int b = 0; b < L; ++b) lanes[k * L + b] = rows[b][offset + static_cast<std::size_t>(k)];
  }
}

// The other way: rows[b][offset + k] = lanes[k * L + b] for k < n.
template <int L>
MOTIONKIT_FK_INLINE void LanesToRows(const double* lanes, int n, double* const* rows,
                                     std::size_t offset) {
  int k = 0;
#if MOTIONKIT_FK_VECTOR_EXT
  for (; k + L <= n; k += L) {
    const double* from[L];
    for (int i = 0; i < L; ++i) from[i] = lanes + (k + i) * L;
    TransposeTile<L>(from, 0, rows, offset + static_cast<std::size_t>(k));
  }
#endif
  for (; k < n; ++k) {
    for (int b = 0; b < L; ++b) rows[b][offset + static_cast<std::size_t>(k)] = lanes[k * L + b];
  }
}

// Lane b of v is rows[b][offset]: a parent beyond the current chunk.
template <int L>
MOTIONKIT_FK_INLINE void LoadColumn(typename Vec<L>::type& out, double* const* rows,
                                    std::size_t offset) {
  alignas(64) double lanes[L];
  for (int b = 0; b < L; ++b) lanes[b] = rows[b][offset];
  LoadTo(out, lanes);
}

// A vector with every lane x.
template <int L>
MOTIONKIT_FK_INLINE void Splat(typename Vec<L>::type& out, double x) {
#if MOTIONKIT_FK_VECTOR_EXT
  if constexpr (L == 2) {
    out = typename Vec<L>::type{x, x};
  } else {
    static_assert(L == 4, "one initialiser per lane");
    out = typename Vec<L>::type{x, x, x, x};
  }
#else
  for (int b = 0; b < L; ++b) out.v[b] = x;
#endif
}

// cos and sin of half of each of count * L angles in degrees (lane-major, as
// RowsToLanes leaves them). The output may be the input.
template <int L>
MOTIONKIT_FK_INLINE void HalfAngleCosSin(const double* degrees, int count, double* cos_out,
                                         double* sin_out) {
#if MOTIONKIT_FK_VECTOR_EXT
  using V = typename Vec<L>::type;
  using Bits = typename Vec<L>::bits;
  V minus_zero;
  Splat<L>(minus_zero, -0.0);
  const Bits sign_bit = (Bits)minus_zero;
  for (int i = 0; i < count; ++i) {
    V x;
    LoadTo(x, degrees + i * L);
    // As HalfAngleCosSinOne, with the quarter turns n taken from the bits of
    // the rounding sum: when n is odd, (sin, cos) becomes (cos, -sin); then
    // both change sign when bit 1 of n is set.
    const V shifted = x * (1.0 / 180.0) + kRoundMagic;
    const V n = shifted - kRoundMagic;
    const V r = (x - n * 180.0) * (kPi / 360.0);
    V s, c;
    SinCosSmall(r, &s, &c);
    const Bits bits = (Bits)shifted;
    const Bits odd = bits << 63;  // only the sign bit: what a blend looks at
    const V minus_s = (V)((Bits)s ^ odd);
    const V s1 = (typename Vec<L>::ints)odd < 0 ? c : minus_s;
    const V c1 = (typename Vec<L>::ints)odd < 0 ? minus_s : c;
    const Bits half_turn = (bits << 62) & sign_bit;
    StoreFrom(cos_out + i * L, (V)((Bits)c1 ^ half_turn));
    StoreFrom(sin_out + i * L, (V)((Bits)s1 ^ half_turn));
  }
#else
  for (int i = 0; i < count * L; ++i) HalfAngleCosSinOne(degrees[i], cos_out + i, sin_out + i);
#endif
}

// (w, x, y, z) times (hc, hs e_axis), the rotation about one axis.
template <int kAxis, typename V>
MOTIONKIT_FK_INLINE void Turn(V& w, V& x, V& y, V& z, const V& hc, const V& hs) {
  V nw, nx, ny, nz;
  if constexpr (kAxis == 0) {
    nw = w * hc - x * hs;
    nx = x * hc + w * hs;
    ny = y * hc + z * hs;
    nz = z * hc - y * hs;
  } else if constexpr (kAxis == 1) {
    nw = w * hc - y * hs;
    nx = x * hc - z * hs;
    ny = y * hc + w * hs;
    nz = z * hc + x * hs;
  } else {
    nw = w * hc - z * hs;
    nx = x * hc + y * hs;
    ny = y * hc - x * hs;
    nz = z * hc + w * hs;
  }
  w = nw;
  x = nx;
  y = ny;
  z = nz;
}

// Three turns about distinct axes, the usual Euler angles; k is the column
// (times L) of the first one's half angle.
template <int kA, int kB, int kC, int L>
MOTIONKIT_FK_INLINE void TurnEuler(typename Vec<L>::type (&q)[4], const double* half_cos,
                                   const double* half_sin, int k) {
  typename Vec<L>::type hc, hs;
  LoadTo(hc, half_cos + k);
  LoadTo(hs, half_sin + k);
  Turn<kA>(q[0], q[1], q[2], q[3], hc, hs);
  LoadTo(hc, half_cos + k + L);
  LoadTo(hs, half_sin + k + L);
  Turn<kB>(q[0], q[1], q[2], q[3], hc, hs);
  LoadTo(hc, half_cos + k + 2 * L);
  LoadTo(hs, half_sin + k + 2 * L);
  Turn<kC>(q[0], q[1], q[2], q[3], hc, hs);
}

// Angles beyond kLargeDegrees, which a real clip never has, reduced by whole
// periods of the half angle (fmod is exact); the others are copied unchanged,
// so that an angle's result never depends on its neighbours.
void ReduceLargeAngles(const double* degrees, int n, double* out) {
  for (int i = 0; i < n; ++i) {
    out[i] = std::abs(degrees[i]) < kLargeDegrees ? degrees[i] : std::fmod(degrees[i], 720.0);
  }
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
    // |v| < large fails for NaN too; two accumulators halve the dependency chain.
    using V = typename Vec<L>::type;
    using Ints = typename Vec<L>::ints;
    V large, minus_zero;
    Splat<L>(large, kLargeDegrees);
    Splat<L>(minus_zero, -0.0);
    const Ints magnitude_bits = ~(Ints)minus_zero;  // all but the sign bit
    Ints ok0 = ~Ints{}, ok1 = ~Ints{};
    for (; i + 2 * L <= n; i += 2 * L) {
      V v0, v1;
      LoadTo(v0, row + i);
      LoadTo(v1, row + i + L);
      ok0 &= (V)((Ints)v0 & magnitude_bits) < large;
      ok1 &= (V)((Ints)v1 & magnitude_bits) < large;
    }
    ok0 &= ok1;
    for (int b = 0; b < L; ++b) unusual |= ok0[b] == 0;
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

// What a joint needs from the skeleton, gathered once per chunk of joints
// rather than once per block of frames.
struct JointPlan {
  double offset[3];
  double twice_offset[3];
  int parent;       // -1 for a root
  int parent_slot;  // the parent's place in the chunk, -1 if outside it
  int first;        // column of the first channel
  int count;        // channels
  // For the usual layout, three rotations about distinct axes after no
  // positions or after X Y Z positions: 9 a + 3 b + c for the axes a, b, c
  // in file order; else -1.
  int euler;
  bool xyz_positions;
};

void PlanJoint(const Skeleton& skeleton, int j, int chunk, JointPlan* plan) {
  const Joint& joint = skeleton.joints[static_cast<std::size_t>(j)];
  for (int i = 0; i < 3; ++i) {
    plan->offset[i] = joint.offset[i];
    plan->twice_offset[i] = 2.0 * joint.offset[i];
  }
  plan->parent = joint.parent;
  plan->parent_slot = joint.parent >= chunk ? joint.parent - chunk : -1;
  plan->first = joint.first_channel;
  plan->count = joint.channel_count;
  plan->euler = -1;
  plan->xyz_positions = false;
  const auto channel = [&](int c) { return joint.channels[static_cast<std::size_t>(c)]; };
  int r = 0;  // the first rotation
  if (joint.channel_count == 6 && channel(0) == ChannelType::kXposition &&
      channel(1) == ChannelType::kYposition && channel(2) == ChannelType::kZposition) {
    r = 3;
  } else if (joint.channel_count != 3) {
    return;
  }
  if (!IsRotation(channel(r)) || !IsRotation(channel(r + 1)) || !IsRotation(channel(r + 2))) {
    return;
  }
  const int a = ChannelAxis(channel(r)), b = ChannelAxis(channel(r + 1)),
            c = ChannelAxis(channel(r + 2));
  if (a == b || b == c || a == c) return;
  plan->euler = 9 * a + 3 * b + c;
  plan->xyz_positions = r == 3;
}

// Joints [chunk, chunk_end) of the whole clip, on finite values. any_size
// admits angles beyond kLargeDegrees.
template <int L>
MOTIONKIT_FK_INLINE void SolveChunk(const Skeleton& skeleton, int chunk, int chunk_end,
                                    const ConstMatrixView& values,
                                    Eigen::Ref<RowMatrixXd>& positions,
                                    Eigen::Ref<RowMatrixXd>& orientations, bool any_size) {
  static_assert(L <= kMaxBlock, "blocks of at most kMaxBlock frames");
  using V = typename Vec<L>::type;
  const Eigen::Index frames = values.rows();
  const int channels = skeleton.channel_count;
  const int joints = chunk_end - chunk;
  JointPlan plans[kChunk];
  for (int j = chunk; j < chunk_end; ++j) PlanJoint(skeleton, j, chunk, &plans[j - chunk]);
  // Scratch on the stack, lane-minor ([column][frame of the block]): Run
  // allocates nothing.
  alignas(64) double raw[kBatch * L];
  alignas(64) double half_cos[kBatch * L];
  alignas(64) double half_sin[kBatch * L];
  alignas(64) double world_q[4 * kChunk * L];  // w x y z of the chunk's joints
  alignas(64) double world_p[3 * kChunk * L];  // x y z

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
    int positions_done = 3 * chunk;  // position columns written out so far

    for (int slot = 0; slot < joints; ++slot) {
      const JointPlan& plan = plans[slot];
      const int first = plan.first;
      if (first + plan.count > batch_end) {
        batch_begin = first;
        batch_end = std::min(first + kBatch, channels);
        const int n = batch_end - batch_begin;
        RowsToLanes<L>(in, static_cast<std::size_t>(batch_begin), n, raw);
        if (any_size) {
          ReduceLargeAngles(raw, n * L, half_cos);
          HalfAngleCosSin<L>(half_cos, n, half_cos, half_sin);
        } else {
          HalfAngleCosSin<L>(raw, n, half_cos, half_sin);
        }
      }

      // The parent's world orientation (pw, px, py, pz) and position.
      V pw, px, py, pz, p0, p1, p2;
      if (plan.parent_slot >= 0) {
        const double* q = world_q + 4 * plan.parent_slot * L;
        const double* p = world_p + 3 * plan.parent_slot * L;
        LoadTo(pw, q);
        LoadTo(px, q + L);
        LoadTo(py, q + 2 * L);
        LoadTo(pz, q + 3 * L);
        LoadTo(p0, p);
        LoadTo(p1, p + L);
        LoadTo(p2, p + 2 * L);
      } else if (plan.parent >= 0) {
        const std::size_t oq = 4 * static_cast<std::size_t>(plan.parent);
        const std::size_t op = 3 * static_cast<std::size_t>(plan.parent);
        LoadColumn<L>(pw, ori, oq);
        LoadColumn<L>(px, ori, oq + 1);
        LoadColumn<L>(py, ori, oq + 2);
        LoadColumn<L>(pz, ori, oq + 3);
        LoadColumn<L>(p0, pos, op);
        LoadColumn<L>(p1, pos, op + 1);
        LoadColumn<L>(p2, pos, op + 2);
      } else {
        Splat<L>(pw, 1.0);
        px = py = pz = p0 = p1 = p2 = V{};
      }

      // Q_i = Q_p R_i, with R_i's axis rotations multiplied into Q_p one by
      // one (each has a single non-zero vector component), and the
      // translation t_i: the offset, position channels replacing components.
      // The rotation of t_i below wants it doubled.
      V q[4] = {pw, px, py, pz};
      V t0, t1, t2;
      const int k = (first - batch_begin) * L;
      if (plan.euler >= 0) {
        if (plan.xyz_positions) {
          LoadTo(t0, raw + k);
          LoadTo(t1, raw + k + L);
          LoadTo(t2, raw + k + 2 * L);
        } else {
          Splat<L>(t0, plan.offset[0]);
          Splat<L>(t1, plan.offset[1]);
          Splat<L>(t2, plan.offset[2]);
        }
        const int r = k + (plan.xyz_positions ? 3 * L : 0);
        switch (plan.euler) {
          case 9 * 0 + 3 * 1 + 2:
            TurnEuler<0, 1, 2, L>(q, half_cos, half_sin, r);
            break;
          case 9 * 0 + 3 * 2 + 1:
            TurnEuler<0, 2, 1, L>(q, half_cos, half_sin, r);
            break;
          case 9 * 1 + 3 * 0 + 2:
            TurnEuler<1, 0, 2, L>(q, half_cos, half_sin, r);
            break;
          case 9 * 1 + 3 * 2 + 0:
            TurnEuler<1, 2, 0, L>(q, half_cos, half_sin, r);
            break;
          case 9 * 2 + 3 * 0 + 1:
            TurnEuler<2, 0, 1, L>(q, half_cos, half_sin, r);
            break;
          default:  // 9 * 2 + 3 * 1 + 0, the only order left
            TurnEuler<2, 1, 0, L>(q, half_cos, half_sin, r);
            break;
        }
      } else {
        Splat<L>(t0, plan.offset[0]);
        Splat<L>(t1, plan.offset[1]);
        Splat<L>(t2, plan.offset[2]);
        const Joint& joint = skeleton.joints[static_cast<std::size_t>(chunk + slot)];
        for (int c = 0; c < plan.count; ++c) {
          V hc, hs;
          LoadTo(hc, half_cos + k + c * L);
          LoadTo(hs, half_sin + k + c * L);
          switch (joint.channels[static_cast<std::size_t>(c)]) {
            case ChannelType::kXrotation:
              Turn<0>(q[0], q[1], q[2], q[3], hc, hs);
              break;
            case ChannelType::kYrotation:
              Turn<1>(q[0], q[1], q[2], q[3], hc, hs);
              break;
            case ChannelType::kZrotation:
              Turn<2>(q[0], q[1], q[2], q[3], hc, hs);
              break;
            case ChannelType::kXposition:
              LoadTo(t0, raw + k + c * L);
              break;
            case ChannelType::kYposition:
              LoadTo(t1, raw + k + c * L);
              break;
            case ChannelType::kZposition:
              LoadTo(t2, raw + k + c * L);
              break;
          }
        }
      }

      double* q_out = world_q + 4 * slot * L;
      double* p_out = world_p + 3 * slot * L;
      StoreFrom(q_out, q[0]);
      StoreFrom(q_out + L, q[1]);
      StoreFrom(q_out + 2 * L, q[2]);
      StoreFrom(q_out + 3 * L, q[3]);
      if (plan.parent < 0) {
        StoreFrom(p_out, t0);
        StoreFrom(p_out + L, t1);
        StoreFrom(p_out + 2 * L, t2);
      } else {
        // p_i = p_p + Q_p t_i, rotating with t + w u + v x u where u = 2 v x t.
        V d0, d1, d2;  // 2 t, exactly
        if (plan.euler >= 0 && !plan.xyz_positions) {
          Splat<L>(d0, plan.twice_offset[0]);
          Splat<L>(d1, plan.twice_offset[1]);
          Splat<L>(d2, plan.twice_offset[2]);
        } else {
          d0 = t0 + t0;
          d1 = t1 + t1;
          d2 = t2 + t2;
        }
        const V ux = py * d2 - pz * d1;
        const V uy = pz * d0 - px * d2;
        const V uz = px * d1 - py * d0;
        StoreFrom(p_out, p0 + t0 + pw * ux + (py * uz - pz * uy));
        StoreFrom(p_out + L, p1 + t1 + pw * uy + (pz * ux - px * uz));
        StoreFrom(p_out + 2 * L, p2 + t2 + pw * uz + (px * uy - py * ux));
      }
      // Out to the rows at once, not at the end of the block: the writes'
      // cache misses then overlap the arithmetic instead of queueing up.
      const int j = chunk + slot;
      LanesToRows<L>(q_out, 4, ori, 4 * static_cast<std::size_t>(j));
      const int whole = (3 * (j + 1) - positions_done) / L * L;
      LanesToRows<L>(world_p + (positions_done - 3 * chunk) * L, whole, pos,
                     static_cast<std::size_t>(positions_done));
      positions_done += whole;
      // Ask for the same joint's lines of a later block now, so that a clip
      // larger than the caches streams instead of stalling on every line.
      // Every other joint is enough: two joints span at most 64 bytes of a row.
      if (slot % 2 == 0) {
        const int j2 = chunk + slot;
        for (int b = 0; b < L; ++b) {
          MOTIONKIT_FK_PREFETCH(ahead_in[b] + first, 0);
          MOTIONKIT_FK_PREFETCH(ahead_pos[b] + 3 * j2, 1);
          MOTIONKIT_FK_PREFETCH(ahead_ori[b] + 4 * j2, 1);
        }
      }
    }
    LanesToRows<L>(world_p + (positions_done - 3 * chunk) * L, 3 * chunk_end - positions_done,
                   pos, static_cast<std::size_t>(positions_done));
  }
}

// The whole clip, a chunk of joints at a time.
template <int L>
MOTIONKIT_FK_INLINE void SolveClip(const Skeleton& skeleton, const ConstMatrixView& values,
                                   Eigen::Ref<RowMatrixXd>& positions,
                                   Eigen::Ref<RowMatrixXd>& orientations, bool any_size) {
  const int joint_count = static_cast<int>(skeleton.joints.size());
  for (int chunk = 0; chunk < joint_count; chunk += kChunk) {
    SolveChunk<L>(skeleton, chunk, std::min(chunk + kChunk, joint_count), values, positions,
                  orientations, any_size);
  }
}

// The solver for one ISA: a scan of the values (true when all are ordinary)
// and the solve proper.
struct Kernels {
  bool (*scan)(const ConstMatrixView& values);
  void (*solve)(const Skeleton& skeleton, const ConstMatrixView& values,
                Eigen::Ref<RowMatrixXd>& positions, Eigen::Ref<RowMatrixXd>& orientations,
                bool any_size);
};

bool ScanBaseline(const ConstMatrixView& values) { return AllOrdinary<2>(values); }
void SolveBaseline(const Skeleton& skeleton, const ConstMatrixView& values,
                   Eigen::Ref<RowMatrixXd>& positions, Eigen::Ref<RowMatrixXd>& orientations,
                   bool any_size) {
  SolveClip<2>(skeleton, values, positions, orientations, any_size);
}

#if MOTIONKIT_FK_X86_DISPATCH
// The same code with four lanes, inlined into functions compiled for AVX2
// and FMA. (With FMA the last bit of a result may differ from the baseline.)
__attribute__((target("avx2,fma"))) bool ScanAvx2(const ConstMatrixView& values) {
  return AllOrdinary<4>(values);
}
__attribute__((target("avx2,fma"))) void SolveAvx2(const Skeleton& skeleton,
                                                   const ConstMatrixView& values,
                                                   Eigen::Ref<RowMatrixXd>& positions,
                                                   Eigen::Ref<RowMatrixXd>& orientations,
                                                   bool any_size) {
  SolveClip<4>(skeleton, values, positions, orientations, any_size);
}

bool HasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return has;
}
#endif

Kernels PickKernels() {
#if MOTIONKIT_FK_X86_DISPATCH
  if (internal::fk_allow_avx2 && HasAvx2()) return {ScanAvx2, SolveAvx2};
#endif
  return {ScanBaseline, SolveBaseline};
}

// Contiguous runs of rows, one a thread: `count` runs of `size` rows (a whole
// number of blocks), the last one shorter.
struct Parts {
  int count = 1;
  Eigen::Index size = 0;

  Eigen::Index Begin(int i) const { return i * size; }
  Eigen::Index Rows(int i, Eigen::Index frames) const {
    return std::min(size, frames - Begin(i));
  }
};

Parts SplitFrames(const ForwardKinematicsJob& job) {
  const Eigen::Index frames = job.values.rows();
  Parts parts;
  parts.size = frames;
  Eigen::Index threads = job.threads;
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  const auto joints = std::max<Eigen::Index>(1, static_cast<Eigen::Index>(job.skeleton.joints.size()));
  const Eigen::Index blocks = (frames + kMaxBlock - 1) / kMaxBlock;
  const Eigen::Index by_work =
      std::max<Eigen::Index>(1, frames * joints / internal::fk_min_joint_frames_per_thread);
  const Eigen::Index wanted = std::min({threads, blocks, by_work});
  if (wanted <= 1) return parts;
  const Eigen::Index per_part = (frames + wanted - 1) / wanted;
  parts.size = (per_part + kMaxBlock - 1) / kMaxBlock * kMaxBlock;
  parts.count = static_cast<int>((frames + parts.size - 1) / parts.size);
  return parts;
}

// Several threads. Every part is scanned before any is solved, so that a
// value that is not finite still leaves the outputs untouched. Large angles
// are reduced value by value, so a part solved with any_size gives the other
// values the same numbers as a part without.
void RunInParts(ForwardKinematicsJob& job, const Kernels& kernels, const Parts& parts) {
  const Eigen::Index frames = job.values.rows();
  std::vector<char> ordinary(static_cast<std::size_t>(parts.count));
  internal::ParallelFor(parts.count, parts.count, [&](int i) {
    ordinary[static_cast<std::size_t>(i)] =
        kernels.scan(job.values.middleRows(parts.Begin(i), parts.Rows(i, frames)));
  });
  if (std::find(ordinary.begin(), ordinary.end(), 0) != ordinary.end()) {
    CheckValues(job).ThrowIfFailed();
  }
  internal::ParallelFor(parts.count, parts.count, [&](int i) {
    const Eigen::Index begin = parts.Begin(i), rows = parts.Rows(i, frames);
    Eigen::Ref<RowMatrixXd> positions = job.positions.middleRows(begin, rows);
    Eigen::Ref<RowMatrixXd> orientations = job.orientations.middleRows(begin, rows);
    kernels.solve(job.skeleton, job.values.middleRows(begin, rows), positions, orientations,
                  !ordinary[static_cast<std::size_t>(i)]);
  });
}

// The shapes and the thread count.
Status CheckJob(const ForwardKinematicsJob& job) {
  if (job.threads < 0) {
    return Status::Fail("fk: threads must be 0 (all) or more, got " + std::to_string(job.threads));
  }
  return CheckShapes(job);
}

}  // namespace

Status ForwardKinematicsJob::Validate() const {
  if (Status s = CheckJob(*this); !s) return s;
  if (AllOrdinary<2>(values)) return Status::Ok();
  return CheckValues(*this);
}

void ForwardKinematicsJob::Run() {
  CheckJob(*this).ThrowIfFailed();
  const Kernels kernels = PickKernels();
  const Parts parts = SplitFrames(*this);
  if (parts.count > 1) {
    RunInParts(*this, kernels, parts);
    return;
  }
  bool any_size = false;
  if (!kernels.scan(values)) {
    CheckValues(*this).ThrowIfFailed();
    any_size = true;
  }
  kernels.solve(skeleton, values, positions, orientations, any_size);
}

}  // namespace motionkit
