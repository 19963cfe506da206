#include "ctcal/report/verdict.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ctcal::report {

Check PixelRmsCheck(const SensorConfig& camera, const std::optional<double>& rms_px,
                    const PixelRmsThresholds& th) {
  Check c;
  c.name = "pixel RMS";
  c.sensor = camera.name;
  const double pass = std::max(th.sigmas * camera.pixel_sigma, th.floor_px);
  char text[160];
  std::snprintf(text, sizeof text,
                "geometry: pass <= %.2f px (max of %g x the stated pixel_sigma, %g px), warn <= "
                "%.2f px",
                pass, th.sigmas, th.floor_px, 2.0 * pass);
  c.criterion = text;
  if (!rms_px) {
    c.value = "not in result.yaml";
    return c;
  }
  std::snprintf(text, sizeof text, "%.3g px", *rms_px);
  c.value = text;
  c.status = !std::isfinite(*rms_px) ? Status::kFail
             : *rms_px <= pass       ? Status::kPass
             : *rms_px <= 2.0 * pass ? Status::kWarn
                                     : Status::kFail;
  return c;
}

std::vector<std::string> FailedCheckLines(const std::vector<Check>& checks) {
  std::vector<std::string> lines;
  for (const Check& c : checks) {
    if (c.status != Status::kFail)
      continue;
    const std::string what = c.sensor.empty() ? c.name + ":" : c.sensor + " " + c.name;
    lines.push_back("check failed: " + what + " " + c.value + " (" + c.criterion + ")");
  }
  return lines;
}

bool AnyFailed(const std::vector<Check>& checks) {
  return std::any_of(checks.begin(), checks.end(),
                     [](const Check& c) { return c.status == Status::kFail; });
}

}  // namespace ctcal::report
