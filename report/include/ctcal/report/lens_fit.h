// Lens-fit diagnosis (issue 21): does the camera model fit the lens, or do the corner residuals
// keep a systematic pattern over the image that a richer model would remove?
//
// The image is cut into cells_x x cells_y cells. For cell c with n_c inlier corners, residuals
// r_i = measured - predicted (px):
//   m_c = (1 / n_c) sum r_i                  the cell's mean residual vector
//   T_c = n_c |m_c|^2 / s^2                  ~ chi^2(2) if the cell has no systematic error,
// where s^2 is the pooled within-cell variance per coordinate,
//   s^2 = sum_c sum_i |r_i - m_c|^2 / (2 (N - K)),
// i.e. the noise as the data show it, free of the pattern being tested (a stated pixel_sigma is
// often not the detector's real noise). Under "no pattern" T = sum_c T_c ~ chi^2(2K); the pattern
// is significant when its p-value is below 1e-3 and the largest cell mean is at least 0.1 px (with
// tens of thousands of corners a hundredth of a pixel is "significant" and harmless). Corners of
// one image share a board pose, so they are not independent: the test is a screen, and its
// numbers are shown with the pattern itself (the arrows of m_c).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ctcal/report/report_data.h"
#include "ctcal/sensors/rig.h"

namespace ctcal::report {

struct LensFitCell {
  int row = 0, col = 0;  // row 0 at the top
  int n = 0;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();  // px
  double chi2 = 0.0;
};

struct LensFitDiagnosis {
  int cells_x = 0, cells_y = 0;
  std::vector<LensFitCell> cells;  // cells with at least min_corners inliers
  int corners = 0;                 // inliers in those cells
  double noise_px = 0.0;           // s, per coordinate
  double chi2 = 0.0;
  int dof = 0;
  double p_value = 1.0;
  double max_mean_px = 0.0;  // largest |m_c|
  // Mean |m_c| over the cells of the outer ring of the grid, and over the inner ones.
  double border_mean_px = 0.0, inner_mean_px = 0.0;
  bool significant = false;
  // When significant: the richer model to try (a rig-file snippet), else empty.
  std::string suggestion;
};

// Throws std::invalid_argument when the camera's model cannot be built (the message names it).
LensFitDiagnosis DiagnoseLensFit(const SensorConfig& camera,
                                 const std::vector<CornerResidual>& corners, int cells_x = 16,
                                 int min_corners = 5);

// The richer mrcal model for a camera: a splined stereographic lens whose knots cover the
// camera's field of view ("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=.._Ny=.._fov_x_deg=..").
std::string SuggestedSplinedModel(const SensorConfig& camera);

}  // namespace ctcal::report
