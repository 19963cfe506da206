// `ctcal simulate --images`: every frame of every camera rendered as the camera sees the board
// (targets/renderer.h: supersampled ink, optics blur, sensor noise, 8 bits), written to
// DATA/<cam>/data/<stamp ns>.png, the names DATA/<cam>/data.csv lists.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "ctcal/sim/simulator.h"
#include "ctcal/sim/trajectory.h"

namespace ctcal::sim {

// `traj` must be the trajectory `data` was simulated along. The poses are those of the corners'
// simulation: base time t_S + time_offset (+ row * line_delay for a rolling shutter, row by row).
// Each image's noise comes from its own stream of `seed`, so the files do not depend on the
// order they are rendered in. `progress(done, total)` is called after each image. Throws
// std::runtime_error naming a file that cannot be written.
void RenderImages(const SimulatedDataset& data, const Trajectory& traj, const std::string& dir,
                  std::uint64_t seed,
                  const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace ctcal::sim
