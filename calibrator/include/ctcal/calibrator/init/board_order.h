// The corner order of the views of a board whose print looks the same turned (a checkerboard with
// rows + cols even, targets/board_symmetry.h): the detector's order of each view is the board's
// only up to such a turn, which a camera alone does not mind (each view has its own board pose)
// but a rig does: two cameras of one instant whose orders differ by a half turn see the board
// 180 deg apart, and the stereo pose from them is wrong (a right camera rotated 72 deg, 86 px
// RMS, on 11 real pairs of a 5x7-square board before this stage). Each view's turn is resolved
// by consistency, before any calibrator reads the corners:
//  - across the cameras of one instant: per camera pair, the relative pose T_Cb_Ca of every
//    shared instant for each turn, P_b T_turn P_a^-1 (P: the view's PnP pose); the true turn
//    gives one and the same rotation at every instant, the others differ from it by a turn
//    conjugated (90 or 180 deg): the rotation most instants agree with picks each instant's turn;
//  - along time (rigs with an IMU, whose board is one fixed world): consecutive views of a camera
//    rotate by the angle the base gyroscope integrates between them (the angle of a rotation is
//    the same in every frame, so no extrinsic is needed); a wrong turn adds 90 or 180 deg.
// The relations join views into groups of one common order (union-find with the turn as the
// offset); each view's corners are renamed into its group's order. A view that no relation
// settles where one is needed (an instant shared with another camera, or outside the IMU rig's
// main group) is dropped and counted in a warning.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ctcal/calibrator/init/init_log.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"

namespace ctcal {

struct BoardOrderOptions {
  int min_corners = 12;         // a view with fewer corners keeps its order (no PnP)
  double reinit_rms_px = 1.0;   // guessed intrinsics worse than this: initialised from the views
  double max_angle_deg = 20.0;  // agreement of two rotations (the turns are >= 90 deg apart)
  double max_gap_s = 5.0;       // consecutive views further apart give no time relation
  int threads = 1;
};

struct BoardOrderResult {
  int symmetries = 0;  // turns the board's print is unchanged by (0: nothing to resolve)
  std::map<std::string, int> views, turned, dropped;  // per camera
  int conflicts = 0;  // relations that contradicted the ones already joined (not used)
  std::vector<std::string> warnings;
};

// Renames (and drops) the corners of `data`'s cameras in place; does nothing for a board without
// symmetries. A camera whose views give no PnP pose keeps its corners as they are (the
// calibrator's own stages then say why).
BoardOrderResult ResolveBoardOrder(const RigConfig& rig, std::map<std::string, SensorData>* data,
                                   const BoardOrderOptions& options = {},
                                   const InitLog& log = LogInitToStderr);

}  // namespace ctcal
