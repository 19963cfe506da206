// Writes a simulated dataset in the layout of SPEC sections 6 and 7:
//   DATA/<imu>/data.csv       #timestamp [ns],w_x,w_y,w_z [rad/s],a_x,a_y,a_z [m/s^2]
//   DATA/<gyro>/data.csv      #timestamp [ns],w_x,w_y,w_z [rad/s]
//   DATA/<sensor>/biases.csv  #timestamp [ns],bw_x,bw_y,bw_z[,ba_x,ba_y,ba_z]   (own clock)
//   DATA/<cam>/data.csv       #timestamp [ns],filename   (every frame; <ns>.png)
//   DATA/<cam>/corners.csv    #timestamp [ns],corner_id,u,v,sigma
//   DATA/groundtruth/data.csv EuRoC's state_groundtruth_estimate0 columns
//   DATA/truth.yaml, DATA/rig.yaml, DATA/target.yaml
// The CSV files go through sensors/dataset.h's writers (the readers' exact counterparts); numbers
// are the shortest decimals that read back to the same doubles, so equal datasets give
// byte-identical files.
#pragma once

#include <map>
#include <string>

#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/rig.h"
#include "ctcal/sim/simulator.h"

namespace ctcal::sim {

struct WriteOptions {
  // With rendered images the calibrator must detect: the noise-free corners go to
  // corners_true.csv (no sigma column) instead of corners.csv.
  bool corners_true_only = false;
};

// Creates `dir` (and parents) and writes everything. `guess` is the rig.yaml (initial guesses).
// Throws std::runtime_error naming the path that could not be created or written.
void WriteDataset(const SimulatedDataset& data, const RigConfig& guess, const std::string& dir,
                  const WriteOptions& options = {});

// What LoadDataset reads back from WriteDataset's files (noisy corners with their sigma), without
// the files: for in-process simulate + calibrate loops (`ctcal montecarlo`, tests).
std::map<std::string, SensorData> ToSensorData(const SimulatedDataset& data);

}  // namespace ctcal::sim
