// Initial guesses for a simulated rig: the truth disturbed the way a user's guess would be.
//
//  table4  the MVIS report's prior sigmas (its Table 4), drawn as Gaussian errors, and the same
//          sigmas written as `prior_sigma` so the calibrator can use them as priors:
//            D_w, D_a entries 0.003; R_I_a / R_I_w 0.003 rad; T_g entries 0.001;
//            camera focal lengths and principal point 1 px, every other camera parameter
//            (distortion, xi, alpha, beta) 0.002; camera R_B_S 0.004 rad, t_B_S 0.008 m,
//            time_offset 0.008 s; inertial R_B_S 0.003 rad, t_B_S 0.005 m, time_offset 0.003 s.
//  coarse  what a user types from a drawing: identity inertial intrinsics (D identity, T_g zero,
//          rotation identity), extrinsic rotations off by a uniform 0-5 deg about a random axis,
//          positions by a uniform 0-2 cm in a random direction, time offsets 0, focal lengths off
//          by +-5 %, principal point at the image centre, distortion 0 (other camera parameters
//          keep their true values); no prior.
// Rotations are disturbed on the left, R = Exp(dtheta) R_true (SPEC section 7's convention).
// Only what a sensor estimates is disturbed; everything else stays exact. gravity_W and results
// are removed: the output is an input rig file.
#pragma once

#include <cstdint>
#include <string>

#include "ctcal/sensors/rig.h"
#include "ctcal/sim/random.h"

namespace ctcal::sim {

enum class Perturbation { kTable4, kCoarse };

// The perturbation of seed N draws from Random(N).Fork(kPerturbationStream), independent of the
// measurements' stream (`ctcal simulate`, `ctcal montecarlo`: the same seed, the same guesses).
inline constexpr std::uint64_t kPerturbationStream = 0x9e7;

// "table4" or "coarse"; throws std::invalid_argument naming the word.
Perturbation ParsePerturbation(const std::string& name);
std::string ToString(Perturbation p);

RigConfig PerturbRig(const RigConfig& truth, Perturbation perturbation, Random& rng);

}  // namespace ctcal::sim
