// The dataset files of SPEC sections 6 and 7 (ASL / EuRoC folder layout): readers and writers.
//
//   DATA/<imu>/data.csv        #timestamp [ns],w_x,w_y,w_z [rad/s],a_x,a_y,a_z [m/s^2]
//   DATA/<gyro>/data.csv       #timestamp [ns],w_x,w_y,w_z [rad/s]
//   DATA/<cam>/data.csv        #timestamp [ns],filename          (images in DATA/<cam>/data/)
//   DATA/<cam>/corners.csv     #timestamp [ns],corner_id,u,v[,sigma]
//   DATA/groundtruth/data.csv  EuRoC state_groundtruth_estimate0 columns (simulator truth)
//   DATA/<inertial>/biases.csv #timestamp [ns],bw_x,bw_y,bw_z[,ba_x,ba_y,ba_z]
//
// Readers are strict and never skip a line: a bad header, column count, number, NaN/Inf,
// a timestamp that does not increase, a
// corner id outside the target, a missing image file, a corner frame absent from data.csv: each
// throws std::runtime_error "<file>:<line>: <what>". Gaps (intervals longer than 1.5x the median)
// are warnings with their count. A first line starting with '#' is the header; without one, the
// first line is data. Writers produce what the readers read back exactly: int64 nanoseconds,
// shortest exact doubles.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ctcal/sensors/rig.h"
#include "ctcal/targets/target_config.h"

namespace ctcal {

struct ImuSample {
  std::int64_t t_ns = 0;                          // the sensor's own clock
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();  // raw gyroscope, rad/s
  Eigen::Vector3d a_m = Eigen::Vector3d::Zero();  // raw accelerometer, m/s^2
};

struct GyroSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d w_m = Eigen::Vector3d::Zero();
};

struct ImageEntry {
  std::int64_t t_ns = 0;
  std::string filename;  // relative to DATA/<cam>/data/
};

struct CornerObservation {
  std::int64_t t_ns = 0;  // the image's stamp
  int corner_id = 0;      // SPEC section 5 numbering
  double u = 0.0;         // px, (0,0) at the centre of the top-left pixel
  double v = 0.0;
  std::optional<double> sigma;  // px per coordinate; none: the camera's noise.pixel_sigma
};

// A row of DATA/groundtruth/data.csv: the base IMU's state at its own rate.
struct GroundTruthState {
  std::int64_t t_ns = 0;
  Eigen::Vector3d p_W_B = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_W_B = Eigen::Quaterniond::Identity();  // Hamilton, written w,x,y,z
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
};

// A row of DATA/<sensor>/biases.csv on the sensor's own clock; b_a only for an imu.
struct BiasSample {
  std::int64_t t_ns = 0;
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  std::optional<Eigen::Vector3d> b_a;
};

// Warnings (gaps) go to *warnings, or to stderr when it is null.
using Warnings = std::vector<std::string>;

// What a real IMU can read: they saturate at a few thousand deg/s and a few hundred g, so a
// reading ten times beyond on an axis is a corrupt sample or other units, and would pull the solve
// away (one 1e6 m/s^2 sample made it diverge, blaming a camera). LoadDataset checks every reading
// against it; the readers alone, given none, read any finite number (exact round trips).
struct InertialRange {
  double max_rate = 1e3;            // rad/s
  double max_specific_force = 1e4;  // m/s^2
};

std::vector<ImuSample> ReadImuCsv(const std::string& path, Warnings* warnings = nullptr,
                                  const InertialRange* range = nullptr);
std::vector<GyroSample> ReadGyroCsv(const std::string& path, Warnings* warnings = nullptr,
                                    const InertialRange* range = nullptr);
// With `check_images`, every DATA/<cam>/data/<filename> must exist (the folder of `path` + data/).
std::vector<ImageEntry> ReadImageCsv(const std::string& path, bool check_images,
                                     Warnings* warnings = nullptr);
// The image a camera's corners are measured in (ReadCornersCsv): a detector reports no corner off
// the pixel grid [-0.5, width - 0.5] x [-0.5, height - 0.5], and noise moves one a few sigma at
// most, so a corner more than 5 sigma (its row's, else `pixel_sigma`) beyond it is not a
// measurement of this camera (another resolution, another camera's file, u and v swapped).
struct CornerImage {
  int width = 0;
  int height = 0;
  double pixel_sigma = 1.0;
};

// `num_corners`: the target's corner count (ids are 0 .. num_corners-1). `frame_stamps`: when
// given (the camera has a data.csv), every corner's stamp must be one of them. `image`: when
// given, every corner must lie in it (CornerImage). Rows of a frame are contiguous, frames in
// increasing time, a corner id at most once per frame.
std::vector<CornerObservation> ReadCornersCsv(const std::string& path, int num_corners,
                                              const std::set<std::int64_t>* frame_stamps = nullptr,
                                              const CornerImage* image = nullptr);
std::vector<GroundTruthState> ReadGroundTruthCsv(const std::string& path);
// `with_accel`: the file has the 3 accelerometer-bias columns (an imu's; a gyro's has not).
std::vector<BiasSample> ReadBiasesCsv(const std::string& path, bool with_accel);

// Writers create the parent folder if needed; they throw std::runtime_error on a non-finite value
// or a stamp that does not increase (what the reader would reject) and on I/O failure.
void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& samples);
void WriteGyroCsv(const std::string& path, const std::vector<GyroSample>& samples);
void WriteImageCsv(const std::string& path, const std::vector<ImageEntry>& images);
// The sigma column is written when the corners carry one (all of them or none).
void WriteCornersCsv(const std::string& path, const std::vector<CornerObservation>& corners);
void WriteGroundTruthCsv(const std::string& path, const std::vector<GroundTruthState>& states);
void WriteBiasesCsv(const std::string& path, const std::vector<BiasSample>& biases);

// Corner count of a target: 2*tagRows x 2*tagCols (aprilgrid), targetRows x targetCols
// (checkerboard, inner corners).
int TargetCornerCount(const TargetConfig& target);

// The data of one sensor of a rig.
struct SensorData {
  std::vector<ImuSample> imu;      // type imu
  std::vector<GyroSample> gyro;    // type gyro
  std::vector<ImageEntry> images;  // camera: data.csv (may be empty when corners exist)
  std::vector<CornerObservation> corners;
  bool has_corners = false;  // corners.csv exists (else the images must be detected first)
};

// Reads DATA/<name>/ for every sensor of the rig (SPEC section 6): inertial data.csv required; a
// camera with corners.csv needs no images (its data.csv is optional, and when present the corner
// frames must be in it); a camera without corners.csv needs data.csv and every image file.
std::map<std::string, SensorData> LoadDataset(const std::string& data_dir, const RigConfig& rig,
                                              Warnings* warnings = nullptr);

}  // namespace ctcal
