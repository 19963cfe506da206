// Coarse-guess initialisation, stage 3: a sensor's time offset to the base clock by
// cross-correlating angular-rate magnitudes (frame-independent, so no extrinsic is needed).
#pragma once

#include <string>
#include <vector>

#include "ctcal/calibrator/init/angular_rates.h"
#include "ctcal/calibrator/init/init_log.h"

namespace ctcal {

struct TimeOffsetOptions {
  double max_offset = 0.1;            // s, searched lags are [-max_offset, max_offset]
  double coarse_step = 1e-3;          // s, lag grid of the search
  double fine_step = 5e-5;            // s, lag grid around the coarse peak
  double min_rate_std = 0.05;         // rad/s, below: "no rotation"
  double min_peak_correlation = 0.6;  // normalised correlation the peak must reach
  double max_secondary_ratio = 0.9;   // a second peak this close to the first: ambiguous
  // A second local maximum counts as a peak only when the correlation dips by this much between
  // it and the first (a ripple on the main lobe is not an alternative offset).
  double min_secondary_prominence = 0.05;
  int min_samples = 20;
  // Subtract each gyro's per-axis median before taking magnitudes. Off by default: a median is a
  // poor bias estimate for an asymmetric motion and shifted the peak by up to 6 ms in tests,
  // while real gyro biases (mrad/s) hardly change rates of ~1 rad/s.
  bool remove_median_bias = false;
  // Refinement by the hand-eye residual (see InitTimeOffset) over +-refine_half_width around the
  // correlation peak; 0 disables it.
  double refine_half_width = 3e-3;  // s
  double refine_step = 2e-4;        // s
  // Lags are evaluated on this many threads (the result does not depend on it).
  int threads = 1;
};

struct TimeOffsetResult {
  double time_offset = 0.0;            // s: t_B = t_S + time_offset (SPEC section 2)
  double correlation_offset = 0.0;     // s, the magnitude correlation peak before refinement
  double peak_correlation = 0.0;       // normalised cross-correlation at the peak
  double secondary_correlation = 0.0;  // highest local maximum outside the main lobe (0: none)
  double secondary_offset = 0.0;       // its lag, s
  double rate_std = 0.0;               // rad/s, std of the sensor's rate magnitude
  int samples = 0;                     // sensor samples in the correlation at the peak
  std::string summary;
};

// s(t) = |w_S(t)| and r(t) = |w_B(t)| (optionally minus MedianRate), and for each lag L
// the normalised correlation of s(t_k) with r(t_k + L) over the sensor samples t_k whose shifted
// time lies in the base's span; base rates are integrated over a camera sample's span so both
// sides are the same quantity. The peak of the 1 ms grid is refined on a fine grid and a parabola
// through its neighbours (sub-sample precision). Then the offset is refined on the vector model
// of stage 4: the hand-eye residual min_{R,c} sum |w_B(t + L) - R w_S(t) - c|^2 on a 0.2 ms grid
// of +-3 ms, with a parabola through its minimum. Throws InitError (stage "time offset") for too
// little rotation, a peak below min_peak_correlation, a peak on the search boundary, or a
// second peak within max_secondary_ratio of the first (ambiguous, e.g. periodic motion).
TimeOffsetResult InitTimeOffset(const std::string& sensor_name,
                                const std::vector<RateSample>& base_rates,
                                const std::vector<RateSample>& sensor_rates,
                                const TimeOffsetOptions& options = {},
                                const InitLog& log = LogInitToStderr);

}  // namespace ctcal
