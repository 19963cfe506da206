// The spline and discrete calibrators' report data: the prepared data of the final solve (the
// corners with their outlier flags, the inertial samples inside the trajectory) through the
// measurement models of report_data_builder.h, and the correlation of the marginal covariance.
#include "../problem/spline_problem_impl.h"

namespace ctcal::spline_internal {

report::ReportData SplineReportData(const Prepared& prep, const TrajectoryEvaluator& trajectory,
                                    const SplineCalibrationResult& result,
                                    std::map<std::string, BiasEvaluator> bias) {
  ReportInputs in;
  in.bias = std::move(bias);
  in.t0_ns = prep.t0_ns;
  in.t1_ns = prep.t1_ns;
  for (const PreparedCamera& cam : prep.cameras) {
    auto& rows = in.corners[cam.state->name()];
    rows.reserve(cam.corners.size());
    for (std::size_t i = 0; i < cam.corners.size(); ++i) {
      ReportCorner c;
      c.t_ns = cam.Stamp(i);
      c.corner_id = cam.corners[i].corner_id;
      c.p_W = cam.board_W[static_cast<std::size_t>(c.corner_id)];
      c.uv = cam.corners[i].uv;
      c.sigma_px = cam.corners[i].sigma_px;
      c.outlier = cam.removed[i];
      rows.push_back(c);
    }
  }
  for (const PreparedInertial& s : prep.inertial) {
    if (!s.imu.empty())
      in.imu[s.state->name()] = s.imu;
    if (!s.gyro.empty())
      in.gyro[s.state->name()] = s.gyro;
  }
  report::ReportData data = BuildReportData(*prep.state, in, trajectory);
  if (result.covariance.size() > 0) {
    // Undetermined by the data (sigma .inf): no correlation to show, whatever a prior did.
    std::vector<bool> undetermined(result.covariance_names.size(), false);
    for (Eigen::Index i = 0; i < result.data_sigma.size(); ++i)
      undetermined[static_cast<std::size_t>(i)] = !std::isfinite(result.data_sigma(i));
    data.correlation =
        CorrelationFromCovariance(result.covariance, result.covariance_names, undetermined);
  }
  return data;
}

}  // namespace ctcal::spline_internal
