// `ctcal compare --projection --a A --b B [--a-camera NAME] [--b-camera NAME] [--observed CSV]
// [--map OUT.png|OUT.svg] [--json OUT.json]`: the projection difference of two lens fits of one
// camera, of any models (sensors/projection_diff.h, docs/camera_models.md "Projection
// difference"). A and B are mrcal .cameramodel files or rig/result files (then the camera named,
// or the first camera).
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/report/plot.h"
#include "ctcal/sensors/dataset.h"
#include "ctcal/sensors/mrcal_model.h"
#include "ctcal/sensors/number_format.h"
#include "ctcal/sensors/projection_diff.h"
#include "ctcal/sensors/rig_yaml.h"

namespace ctcal::app {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() &&
         s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// A camera of a .cameramodel, or of a rig file (the named camera, else the first one).
CameraModel LoadCamera(const std::string& path, const std::string& name) {
  if (EndsWith(path, ".cameramodel"))
    return LoadMrcalCameraModel(path).camera;
  std::vector<std::string> ignored;
  const RigConfig rig = LoadRig(path, &ignored);
  for (const SensorConfig& s : rig.sensors) {
    if (s.type != SensorType::kCamera || (!name.empty() && s.name != name))
      continue;
    try {
      return CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                 s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(path + ": sensors." + s.name + ": " + e.what());
    }
  }
  throw std::invalid_argument(path + ": no camera" + (name.empty() ? "" : " named '" + name + "'"));
}

std::string Num(double x, int digits) {
  std::ostringstream s;
  s.precision(digits);
  s << x;
  return s.str();
}

std::string Describe(const CameraModel& c) {
  return c.camera_model() + " " + c.distortion_model();
}

}  // namespace

int RunCompareProjection(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("compare",
                  "--projection --a A --b B [--a-camera NAME] [--b-camera NAME] [--observed CSV] "
                  "[--cells N] [--map OUT.png|OUT.svg] [--json OUT.json]",
                  "Projection difference of two lens fits of one camera, of any models (mrcal's "
                  "method): the rotation between the two camera frames is fitted over the observed "
                  "part of the image, then each grid point's ray as A sees it is projected by B; "
                  "mean, RMS and max of the pixel difference there.");
  std::string a_path, b_path, a_name, b_name, observed_path, map_path, json_path;
  int cells = 60;
  cli.options().add_options()("projection", "compare two lens fits (this mode)")(
      "a", po::value(&a_path)->required(), "first fit: a .cameramodel or a rig/result file")(
      "b", po::value(&b_path)->required(), "second fit, the same camera (same resolution)")(
      "a-camera", po::value(&a_name), "camera of A when A is a rig file (default: its first)")(
      "b-camera", po::value(&b_name), "camera of B when B is a rig file (default: its first)")(
      "observed", po::value(&observed_path),
      "corners.csv of the camera: its cells are the observed part (default: the whole image)")(
      "cells", po::value(&cells), "grid cells across the image (default 60)")(
      "map", po::value(&map_path), "write the difference map (.png or .svg)")(
      "json", po::value(&json_path), "also write the numbers as JSON");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  if (cells < 2 || cells > 1000)
    return cli.InputError("--cells must be in 2..1000, got " + std::to_string(cells));

  ProjectionDiff diff;
  std::string a_text, b_text;
  try {
    const CameraModel a = LoadCamera(a_path, a_name);
    const CameraModel b = LoadCamera(b_path, b_name);
    a_text = Describe(a);
    b_text = Describe(b);
    ProjectionDiffOptions options;
    options.cells_x = cells;
    if (!observed_path.empty()) {
      for (const CornerObservation& c :
           ReadCornersCsv(observed_path, std::numeric_limits<int>::max()))
        options.observed.emplace_back(c.u, c.v);
    }
    diff = DiffProjections(a, b, options);
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  const int total = static_cast<int>(diff.diff_px.size());
  std::ostringstream text;
  text << "projection difference, A: " << a_path << " (" << a_text << "), B: " << b_path << " ("
       << b_text << ")\n"
       << "observed part: " << diff.points << " of " << total << " grid points ("
       << (observed_path.empty() ? "whole image" : observed_path) << ")\n"
       << "mean " << Num(diff.mean_px, 4) << " px, RMS " << Num(diff.rms_px, 4) << " px, max "
       << Num(diff.max_px, 4) << " px; fitted rotation B from A " << Num(diff.rotation_deg, 4)
       << " deg\n";
  std::cout << text.str();

  try {
    if (!map_path.empty()) {
      report::Figure figure(1, 1, 640, 480);
      figure.title = "projection difference A vs B";
      figure.id = "projection-difference";
      auto& hm = figure.Add<report::HeatMap>();
      hm.title = "|B(R A^-1(q)) - q|, mean " + Num(diff.mean_px, 3) + " px, max " +
                 Num(diff.max_px, 3) + " px over the observed part (grey: no ray)";
      hm.values = diff.diff_px;
      hm.x_lo = -0.5;
      hm.y_lo = -0.5;
      hm.x_hi = hm.x_lo + diff.width;
      hm.y_hi = hm.y_lo + diff.height;
      hm.x_label = "u (px)";
      hm.y_label = "v (px)";
      hm.value_label = "px";
      if (EndsWith(map_path, ".svg")) {
        std::ofstream f(map_path);
        f << report::RenderSvg(figure);
        if (!f)
          throw std::runtime_error(map_path + ": cannot write");
      } else {
        report::SavePng(figure, map_path);
      }
    }
    if (!json_path.empty()) {
      std::ofstream f(json_path);
      f << "{\"mean_px\": " << FormatDouble(diff.mean_px)
        << ", \"rms_px\": " << FormatDouble(diff.rms_px)
        << ", \"max_px\": " << FormatDouble(diff.max_px)
        << ", \"rotation_deg\": " << FormatDouble(diff.rotation_deg)
        << ", \"points\": " << diff.points << ", \"grid_points\": " << total << "}\n";
      if (!f)
        throw std::runtime_error(json_path + ": cannot write");
    }
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  return kExitOk;
}

}  // namespace ctcal::app
