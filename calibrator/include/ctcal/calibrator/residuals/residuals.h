// Every residual of the continuous-time calibrator (docs/residuals.md), one include for the
// pipeline.
#pragma once

#include "ctcal/calibrator/residuals/aux_gyro_residual.h"
#include "ctcal/calibrator/residuals/aux_imu_residual.h"
#include "ctcal/calibrator/residuals/base_imu_residual.h"
#include "ctcal/calibrator/residuals/bias_random_walk_residual.h"
#include "ctcal/calibrator/residuals/corner_residual.h"
#include "ctcal/calibrator/residuals/prior_residuals.h"
