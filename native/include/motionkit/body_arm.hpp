// An arm's least turn out of its body (core/body_clearance): per frame, the turn of the upper arm about the
// shoulder and of the forearm about the elbow (two rotation vectors, the armature's space) that brings the
// arm's skin points to a clearance from the body (body_sample.hpp's read) and, where asked, the hand onto
// it, by Gauss-Newton; the hand keeps its orientation, carried by the wrist (docs/body.md).
//
// A point p on the forearm moves to qs qe (p - elbow) + elbow', on the hand to p - wrist + wrist', where
// qs and qe are the shoulder's and the elbow's turns, elbow' = qs (elbow - shoulder) + shoulder and wrist' =
// qs qe (wrist - elbow) + elbow'. Each step solves (J^T J + w^2 I) step = J^T r over the points nearer the
// body than wanted (r: how much nearer; J: a point's distance moves by the shoulder's turn's cross product
// with its lever from the shoulder, and by the elbow's, in the shoulder-turned space, with its lever from
// the elbow where the arm is now) and, on a frame to touch a goal, the three rows of the hand's point
// nearest it; each joint's step at most max_step, taken on by each turn (qs <- exp(step) qs, qe the same).
#pragma once

#include <Eigen/Core>
#include <array>
#include <utility>
#include <vector>

#include "motionkit/body_sample.hpp"
#include "motionkit/error.hpp"
#include "motionkit/types.hpp"

namespace motionkit {

// Caller-owned buffers; Run() allocates only the per-point scratch of each block of frames, before it starts.
//   field:           the body (BodyFieldView)
//   orientations:    F x 4B, heads F x 3B: the armature pose, the field read in it and the arm posed by it
//   arm:             the upper arm's, the forearm's and the hand's bones: the shoulder, elbow and wrist are
//                    their heads
//   point_bones:     S, the bone each skin point rides on; point_local (S x 3) its offset in that bone's rest
//                    frame (posed at orientation * offset + head)
//   on_hand:         S: nonzero for a point on the hand
//   frames:          the frames to solve (indices into F, any order, each once)
//   wanted:          F: the distance every point is to keep from the body
//   touch:           F: nonzero where the hand's point nearest the body is brought to touch_distance (from
//                    either side) rather than kept out, or where goals has a finite row, the hand's point
//                    nearest that goal onto it (the rest of the arm kept out)
//   goals:           F x 3 (or 0 rows for none): where a touching hand goes (a place on the body)
//   contacts:        F x 3 (or 0 rows: the hand's point nearest the goal): the point of the hand, posed, that
//                    goes onto the goal (it rides on the hand, carried by the wrist)
//   turns:           F x 6 in and out: on the frames solved, where the solve starts and what it found (the
//                    shoulder's then the elbow's rotation vector); iterations 0 reads only
//   least, hand:     one per frame solved, out: after the turns, the nearest of the points' distances and of
//                    the hand's (+inf where none is read); gap: the hand's nearest point's distance to the
//                    frame's goal (0 where it has none)
struct BodyArmJob {
  BodyArmJob(BodyFieldView field_in, ConstMatrixView orientations_in, ConstMatrixView heads_in,
             std::array<int, 3> arm_in, std::vector<int> point_bones_in, ConstMatrixView point_local_in,
             std::vector<int> on_hand_in, std::vector<int> frames_in, ConstVectorView wanted_in,
             std::vector<int> touch_in, ConstMatrixView goals_in, ConstMatrixView contacts_in,
             Eigen::Ref<RowMatrixXd> turns_io,
             Eigen::Ref<Eigen::VectorXd> least_out, Eigen::Ref<Eigen::VectorXd> hand_out,
             Eigen::Ref<Eigen::VectorXd> gap_out)
      : field(std::move(field_in)),
        orientations(orientations_in),
        heads(heads_in),
        arm(arm_in),
        point_bones(std::move(point_bones_in)),
        point_local(point_local_in),
        on_hand(std::move(on_hand_in)),
        frames(std::move(frames_in)),
        wanted(wanted_in),
        touch(std::move(touch_in)),
        goals(goals_in),
        contacts(contacts_in),
        turns(turns_io),
        least(least_out),
        hand(hand_out),
        gap(gap_out) {}

  BodyFieldView field;
  ConstMatrixView orientations;
  ConstMatrixView heads;
  std::array<int, 3> arm;
  std::vector<int> point_bones;
  ConstMatrixView point_local;
  std::vector<int> on_hand;
  std::vector<int> frames;
  ConstVectorView wanted;
  std::vector<int> touch;
  ConstMatrixView goals;
  ConstMatrixView contacts;
  Eigen::Ref<RowMatrixXd> turns;
  Eigen::Ref<Eigen::VectorXd> least;
  Eigen::Ref<Eigen::VectorXd> hand;
  Eigen::Ref<Eigen::VectorXd> gap;
  double touch_distance = 0.0;
  int iterations = 6;        // Gauss-Newton steps a frame at most
  double turn_weight = 0.05;  // w: the least turn, shared between the joints
  double max_step = 0.25;     // radians a joint turns in one step at most
  int threads = 0;            // frames on this many threads (0: one per hardware thread); the same result on any
  // c: where > 0, each run of consecutive frames is solved as one, c (t_f - t_{f-1}) among its rows (radians
  // weighed as the points' distances are): neighbouring frames take alike turns, never each its own way
  // round the body (frames then each once, runs on the threads). 0: each frame alone.
  double smoothness = 0.0;

  // Shapes agree, bones in range, the field's (BodyFieldView::Validate), finite inputs (naming the frame),
  // options in range.
  Status Validate() const;
  void Run();

 private:
  void RunCoupled();
};

}  // namespace motionkit
