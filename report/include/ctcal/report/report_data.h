// The data contract between `ctcal calibrate` and the report: what a finished calibration folder
// OUT keeps so that `ctcal report --out OUT` can redraw every plot without the calibrator.
//
//   OUT/result.yaml                            SPEC section 7 (sensors/rig_yaml.h)
//   OUT/crosscheck.yaml                        optional (--method both)
//   OUT/report_data/<cam>_corners.csv.gz       t_ns,frame,corner_id,u,v,du,dv,whitened,outlier
//   OUT/report_data/<sensor>_gyro.csv.gz       t_ns,meas_x,meas_y,meas_z,pred_x,pred_y,pred_z
//   OUT/report_data/<sensor>_accel.csv.gz      same columns, m/s^2 (imu sensors only)
//   OUT/report_data/<sensor>_bias.csv.gz       t_ns,b_x,b_y,b_z,sigma_x,sigma_y,sigma_z,part
//                                              (part = gyro | accel; one row per sample and part)
//   OUT/report_data/trajectory.csv.gz          t_ns,p_x,p_y,p_z,q_w,q_x,q_y,q_z   (T_W_B)
//   OUT/report_data/correlation.csv            name,<name_1>,...,<name_n>; then one row per name
//   OUT/report_data/run_info.csv               key,value (configuration and versions, in order)
//
// The per-sample tables are gzip-compressed CSV (`zcat` reads them; written as gzip members of
// 4 MiB of text each, which zcat, zlib and Python read as one file); readers also accept the
// plain `.csv` of folders written before.
//
// Conventions: t_ns on the base clock (SPEC section 2) in integer nanoseconds; corner residuals
// du, dv = measured - predicted in px, `whitened` = |(du, dv)| / sigma_px (the norm of the
// whitened 2-vector), `outlier` 0/1 (1: removed from the final solve); inertial `meas` is the raw
// sample, `pred` the model's prediction of it including biases, in the sensor's own units
// (rad/s, m/s^2); bias sigma is the random walk's 1-sigma spread since the track's first row,
// sigma_rw sqrt(t - t_first) (Kalibr's bias envelope; the report draws +-3 sigma around the
// bias at t_first; calibrator/report_data_builder.h says why not the estimate's marginal
// sigma). Every file starts with one `#` header line naming its columns.
//
// Precision: what the plots and the statistics need. Corners u, v to 1e-3 px, du, dv and
// whitened to 7 significant digits (a whitened RMS recomputed from the file is within 5e-7
// relative of the solver's); bias rows to 7 digits; inertial samples, trajectory, correlation
// exactly (the shortest decimal that reads back to the same double, sensors/number_format.h: a
// sample minus its prediction is ~1e-3 of the sample). Non-finite values as .nan / .inf / -.inf.
//
// Readers are strict: a wrong column count, a number that does not parse or an unknown `part`
// throws std::runtime_error "<file>:<line>: <what>". A missing optional file reads as empty.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace ctcal::report {

struct CornerResidual {
  std::int64_t t_ns = 0;
  int frame = 0;  // image index within the camera's stream
  int corner_id = 0;
  double u = 0.0, v = 0.0;    // measured corner, px
  double du = 0.0, dv = 0.0;  // measured - predicted, px
  double whitened = 0.0;      // |(du, dv)| / sigma
  bool outlier = false;
};

struct InertialSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d meas = Eigen::Vector3d::Zero();
  Eigen::Vector3d pred = Eigen::Vector3d::Zero();
};

struct BiasSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();
};

struct BiasTrack {
  std::vector<BiasSample> gyro;
  std::vector<BiasSample> accel;  // empty for a gyroscope
};

struct PoseSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();
};

struct Correlation {
  std::vector<std::string> names;  // SPEC section 7 parameter names
  Eigen::MatrixXd values;          // names.size() square
};

using RunInfo = std::vector<std::pair<std::string, std::string>>;

// ---- paths
std::string ReportDataDir(const std::string& out_dir);
std::string CornersPath(const std::string& out_dir, const std::string& camera);
std::string GyroPath(const std::string& out_dir, const std::string& sensor);
std::string AccelPath(const std::string& out_dir, const std::string& sensor);
std::string BiasPath(const std::string& out_dir, const std::string& sensor);
std::string TrajectoryPath(const std::string& out_dir);
std::string CorrelationPath(const std::string& out_dir);
std::string RunInfoPath(const std::string& out_dir);

// ---- writers (create OUT/report_data/ when needed; throw std::runtime_error on I/O errors)
void WriteCornerResiduals(const std::string& out_dir, const std::string& camera,
                          const std::vector<CornerResidual>& rows);
void WriteGyroSamples(const std::string& out_dir, const std::string& sensor,
                      const std::vector<InertialSample>& rows);
void WriteAccelSamples(const std::string& out_dir, const std::string& sensor,
                       const std::vector<InertialSample>& rows);
void WriteBiasTrack(const std::string& out_dir, const std::string& sensor, const BiasTrack& track);
void WriteTrajectory(const std::string& out_dir, const std::vector<PoseSample>& rows);
void WriteCorrelation(const std::string& out_dir, const Correlation& c);
void WriteRunInfo(const std::string& out_dir, const RunInfo& info);

// ---- readers (by path; a missing file gives an empty result)
std::vector<CornerResidual> ReadCornerResiduals(const std::string& path);
std::vector<InertialSample> ReadInertialSamples(const std::string& path);
BiasTrack ReadBiasTrack(const std::string& path);
std::vector<PoseSample> ReadTrajectory(const std::string& path);
Correlation ReadCorrelation(const std::string& path);
RunInfo ReadRunInfo(const std::string& path);

// Everything of a folder, per sensor name.
struct ReportData {
  std::map<std::string, std::vector<CornerResidual>> corners;
  std::map<std::string, std::vector<InertialSample>> gyro;
  std::map<std::string, std::vector<InertialSample>> accel;
  std::map<std::string, BiasTrack> bias;
  std::vector<PoseSample> trajectory;
  Correlation correlation;
  RunInfo run_info;
};

// Reads the files of every sensor name given (the rig's sensors), one file per job on `threads`
// threads (<= 0: the hardware's).
ReportData LoadReportData(const std::string& out_dir, const std::vector<std::string>& sensors,
                          int threads = 0);

// Writes every file of `data` (the inverse of LoadReportData; empty tables write no file, except
// run_info.csv, which is always written), one file per job on `threads` threads (<= 0: the
// hardware's). Returns `data` as the files hold it, the corner and bias columns rounded to their
// written digits: what LoadReportData reads back, to the bit, so that a report rendered from the
// return equals one rendered from the folder.
ReportData WriteReportData(const std::string& out_dir, ReportData data, int threads = 0);

}  // namespace ctcal::report
