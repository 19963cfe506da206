// The verdict of a finished calibration from the report's own checks (EvaluateChecks, report.h):
// the geometric check of a camera's raw pixel RMS, the stderr lines of the failed checks, and
// whether any failed (`ctcal calibrate` then exits 3, SPEC section 8). The report's first page
// and the exit code read the same checks, so they cannot disagree.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ctcal/report/report.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::report {

// The camera's raw pixel RMS (result.yaml `residuals: rms_px`) against what a corner detector
// can be: the whitened RMS compares the residuals with the noise the fit used, which is
// meaningless once that noise is estimated from the same residuals (an 86 px misfit then whitens
// to ~1). A board's corners are measured to a fraction of a pixel, so an RMS many times the
// camera's stated pixel_sigma, and above a pixel, is a geometric failure (wrong board, wrong
// corner order, a lens the model does not fit), whatever the estimated noise. Pass <=
// max(sigmas * pixel_sigma, floor_px), warn <= twice that, fail beyond.
struct PixelRmsThresholds {
  double sigmas = 5.0;
  double floor_px = 1.0;
};
Check PixelRmsCheck(const SensorConfig& camera, const std::optional<double>& rms_px,
                    const PixelRmsThresholds& thresholds = {});

// "check failed: cam1 whitened RMS 86.7 (~1: pass in [0.77, 1.30], ...)", or for a rig-wide
// check "check failed: observability: 29 unobservable (...)": one line per failed check, in
// the report's order.
std::vector<std::string> FailedCheckLines(const std::vector<Check>& checks);

bool AnyFailed(const std::vector<Check>& checks);

}  // namespace ctcal::report
