// The whole continuous-time calibration problem (spline_problem.h) with its member definitions,
// for the translation units that instantiate or run it (spline_problem_split.cpp / _joint.cpp,
// the discrete calibrator, the report data). Private to the calibrator library.
#pragma once

#include "spline_problem.h"
#include "spline_problem_build.h"
#include "spline_problem_noise.h"
#include "spline_problem_solve.h"
