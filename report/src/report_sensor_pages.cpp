// The report's per-sensor pages: the trajectory, each inertial sensor, each camera.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "ctcal/report/distortion_field.h"
#include "ctcal/report/lens_fit.h"

#include "report_builder.h"

namespace ctcal::report::detail {

Section Builder::TrajectorySection() {
  Section sec("sec-trajectory", "Estimated poses in 3-D");
  if (data_.trajectory.empty()) {
    sec.omitted = rig_.IsCameraOnly()
                      ? "a camera-only rig has one board pose per frame, no trajectory"
                      : "no trajectory (report_data/trajectory.csv absent)";
    return sec;
  }
  auto f = NewFigure("fig-trajectory", "Base IMU trajectory T_W_B", 1, 2);
  for (const bool oblique : {true, false}) {
    auto& v = f->Add<Trajectory3D>();
    // Top-down: azimuth -90 deg puts world x to the right and y up on the page.
    v.azimuth_deg = oblique ? -60.0 : -90.0;
    v.elevation_deg = oblique ? 25.0 : 90.0;
    v.title = oblique ? "oblique view" : "top-down view (x right, y up)";
    for (const auto& p : data_.trajectory) {
      v.p_W.push_back(p.p_W_B);
      v.R_W.push_back(p.q_W_B.normalized().toRotationMatrix());
      v.t.push_back(Sec(p.t_ns));
    }
    v.triad_every = std::max<int>(1, static_cast<int>(data_.trajectory.size() / 40));
  }
  sec.figures.push_back(f);
  return sec;
}

// Predicted vs measured, their error with the +-3 sigma white-noise bound, per axis.
void Builder::InertialFigures(Section* sec, const SensorConfig& s,
                              const std::vector<InertialSample>& d, const std::string& part,
                              const std::string& unit, double sigma) {
  const char* axes = "xyz";
  auto f = NewFigure("fig-" + s.name + "-" + part,
                     s.name + ": " + part + " predicted vs measured [" + unit + "]", 3, 1);
  auto e =
      NewFigure("fig-" + s.name + "-" + part + "-error",
                s.name + ": " + part + " error (measured - predicted) with +-3 sigma noise", 3, 1);
  std::vector<double> t;
  for (const auto& r : d)
    t.push_back(Sec(r.t_ns));
  for (int a = 0; a < 3; ++a) {
    std::vector<double> m, p, err;
    for (const auto& r : d) {
      m.push_back(r.meas[a]);
      p.push_back(r.pred[a]);
      err.push_back(r.meas[a] - r.pred[a]);
    }
    auto& pl = f->Add<XYPlot>();
    pl.title = std::string(1, axes[a]) + " axis";
    pl.y_label = unit;
    if (a == 2)
      pl.x_label = "time [s]";
    pl.Line(t, m, "measured", PaletteColor(0), 1.0);
    pl.Line(t, p, "predicted", PaletteColor(1), 1.0);
    auto& pe = e->Add<XYPlot>();
    pe.title = std::string(1, axes[a]) + " axis";
    pe.y_label = unit;
    if (a == 2)
      pe.x_label = "time [s]";
    if (std::isfinite(sigma) && sigma > 0 && !t.empty()) {
      pe.Band({t.front(), t.back()}, {-3 * sigma, -3 * sigma}, {3 * sigma, 3 * sigma},
              "+-3 sigma noise", PaletteColor(2));
    }
    pe.Line(t, err, "error", PaletteColor(3), 0.8);
  }
  sec->figures.push_back(f);
  sec->figures.push_back(e);
}

Section Builder::InertialSection(const SensorConfig& s) {
  Section sec("sec-imu-" + s.name, "Inertial sensor " + s.name + " (" + ToString(s.type) + ")");
  const auto g = data_.gyro.find(s.name);
  const auto a = data_.accel.find(s.name);
  const auto b = data_.bias.find(s.name);
  if (g == data_.gyro.end() && a == data_.accel.end() && b == data_.bias.end()) {
    sec.omitted = "no inertial data for " + s.name + " in report_data/";
    return sec;
  }
  // Sample intervals: a dropped sample or a jittery clock is visible at once.
  const auto& stamps = g != data_.gyro.end() ? g->second : a->second;
  if (g != data_.gyro.end() || a != data_.accel.end()) {
    auto f = NewFigure("fig-" + s.name + "-intervals", s.name + ": sample intervals", 1, 2);
    std::vector<double> t, dt;
    for (size_t i = 1; i < stamps.size(); ++i) {
      t.push_back(Sec(stamps[i].t_ns));
      dt.push_back(1e3 * 1e-9 * static_cast<double>(stamps[i].t_ns - stamps[i - 1].t_ns));
    }
    auto& p = f->Add<XYPlot>();
    p.title = "interval over time";
    p.x_label = "time [s]";
    p.y_label = "dt [ms]";
    p.Scatter(t, dt, "", PaletteColor(0), 1.2);
    if (s.noise.update_rate > 0)
      p.HLine(1e3 / s.noise.update_rate, "1 / update_rate", PaletteColor(3));
    auto& h = f->Add<XYPlot>();
    h.title = "interval histogram";
    h.x_label = "dt [ms]";
    h.y_label = "density";
    double lo = INFINITY, hi = -INFINITY;
    for (const double x : dt) {
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    if (hi > lo)
      h.Histogram(dt, 40, lo, hi, "", PaletteColor(0));
    else if (!dt.empty())
      h.Histogram(dt, 1, lo - 0.5, lo + 0.5, "", PaletteColor(0));
    sec.figures.push_back(f);
  }
  // Whitened by the noise the solve used: the estimate where the calibrator made one.
  const InertialNoise& noise = s.noise_estimated ? *s.noise_estimated : s.noise;
  if (g != data_.gyro.end())
    InertialFigures(&sec, s, g->second, "gyro", "rad/s", noise.GyroSampleSigma());
  if (a != data_.accel.end())
    InertialFigures(&sec, s, a->second, "accel", "m/s^2", noise.AccelSampleSigma());
  if (b != data_.bias.end()) {
    const bool both = !b->second.gyro.empty() && !b->second.accel.empty();
    auto f =
        NewFigure("fig-" + s.name + "-bias",
                  s.name + ": bias estimates with +-3 sigma random-walk envelopes from the start",
                  both ? 2 : 1, 3);
    for (const auto* part : {&b->second.gyro, &b->second.accel}) {
      if (part->empty())
        continue;
      const bool gyro = part == &b->second.gyro;
      for (int ax = 0; ax < 3; ++ax) {
        // The random-walk envelope opens from the bias at the track's start
        // (report_data.h): where the stated random walk lets the true bias wander.
        std::vector<double> t, v, lo, hi;
        const double b0 = part->front().b[ax];
        for (const auto& r : *part) {
          t.push_back(Sec(r.t_ns));
          v.push_back(r.b[ax]);
          lo.push_back(b0 - 3 * r.sigma[ax]);
          hi.push_back(b0 + 3 * r.sigma[ax]);
        }
        auto& p = f->Add<XYPlot>();
        p.title = std::string(gyro ? "gyro " : "accel ") + "xyz"[ax];
        p.x_label = "time [s]";
        p.y_label = gyro ? "rad/s" : "m/s^2";
        p.legend = ax == 0;
        p.Band(t, lo, hi, "+-3 sigma random walk", PaletteColor(gyro ? 0 : 1));
        p.Line(t, v, "bias", PaletteColor(gyro ? 0 : 1), 1.5);
      }
    }
    sec.figures.push_back(f);
  }
  return sec;
}

// Distortion field (distortion_field.h): arrows from the reference lens's pixel to the model's
// pixel of the same ray, and the displacement's magnitude over the image.
void Builder::DistortionFigure(Section* sec, const SensorConfig& s) const {
  DistortionField d;
  try {
    d = ComputeDistortionField(s);
  } catch (const std::exception& e) {
    sec->html += "<p class=\"note\">distortion field not drawn: " + Escape(e.what()) + "</p>\n";
    return;
  }
  if (d.model_uv.empty()) {
    sec->html += "<p class=\"note\">no distortion field: " + s.camera_model + " with " +
                 s.distortion_model + " distortion is the ideal pinhole.</p>\n";
    return;
  }
  const double W = s.width, H = s.height;
  // Arrows scaled so that the longest spans a grid cell; the scale is in the title.
  const double scale = d.max_magnitude > 0 ? (W / 16.0) / d.max_magnitude : 1.0;
  std::vector<double> x0, y0, dx, dy;
  for (std::size_t i = 0; i < d.model_uv.size(); ++i) {
    x0.push_back(d.reference_uv[i].x());
    y0.push_back(d.reference_uv[i].y());
    dx.push_back(scale * (d.model_uv[i].x() - d.reference_uv[i].x()));
    dy.push_back(scale * (d.model_uv[i].y() - d.reference_uv[i].y()));
  }
  auto f = NewFigure("fig-" + s.name + "-distortion",
                     s.name + ": distortion field vs " + d.reference + ", max " +
                         FormatNumber(d.max_magnitude, 3) + " px",
                     1, 2);
  auto& p = f->Add<XYPlot>();
  p.title = "reference -> model pixel, arrows x" + FormatNumber(scale, 3);
  ImageAxes(W, H, &p);
  p.Arrows(x0, y0, dx, dy, PaletteColor(0));
  auto& hm = f->Add<HeatMap>();
  hm.title = "|displacement| (grey: outside the model's field of view)";
  hm.values = d.magnitude;
  ImageAxes(W, H, &hm);
  hm.value_label = "px";
  sec->html += "<p class=\"note\">Distortion field: the reference is " + Escape(d.reference) +
               ", focal " + FormatNumber(d.focal.x(), 5) + " / " + FormatNumber(d.focal.y(), 5) +
               " px, principal point " + FormatNumber(d.principal_point.x(), 5) + ", " +
               FormatNumber(d.principal_point.y(), 5) + " px.</p>\n";
  if (p.HasData())
    sec->figures.push_back(f);
}

// The per-image whitened RMS (each corner by the sigma the solve weighed it with) over time and
// against the base's angular speed at the image (from the trajectory): ~1 and flat when the noise
// model holds; rising with speed when blur or timing errors grow that the weights miss.
void Builder::WhitenedFrameFigure(
    Section* sec, const std::string& camera,
    const std::map<int, std::pair<double, std::pair<double, int>>>& per_frame,
    const std::map<int, double>& whitened) const {
  std::vector<double> ft, fw, speed, sw;
  const auto& traj = data_.trajectory;
  for (const auto& [k, pf] : per_frame) {
    const double rms = std::sqrt(whitened.at(k) / (2.0 * std::max(pf.second.second, 1)));
    ft.push_back(pf.first);
    fw.push_back(rms);
    // The angular speed between the trajectory samples around the image.
    const std::int64_t t_ns = t0_ + static_cast<std::int64_t>(std::llround(pf.first * 1e9));
    const auto it =
        std::lower_bound(traj.begin(), traj.end(), t_ns,
                         [](const PoseSample& p, std::int64_t t) { return p.t_ns < t; });
    if (it == traj.begin() || it == traj.end())
      continue;
    const PoseSample& a = *(it - 1);
    const double dt = 1e-9 * static_cast<double>(it->t_ns - a.t_ns);
    if (dt > 0.0) {
      speed.push_back(Eigen::AngleAxisd(a.q_W_B.conjugate() * it->q_W_B).angle() / dt);
      sw.push_back(rms);
    }
  }
  if (ft.empty())
    return;
  auto f = NewFigure("fig-" + camera + "-whitened", camera + ": per-image whitened RMS", 1, 2);
  const auto panel = [&](const std::string& title, const std::string& x_label,
                         const std::vector<double>& x, const std::vector<double>& y) {
    auto& p = f->Add<XYPlot>();
    p.title = title;
    p.x_label = x_label;
    p.y_label = "whitened RMS";
    p.Scatter(x, y, "", PaletteColor(0), 1.8);
    p.HLine(1.0, "1", PaletteColor(3));
  };
  panel("per-image whitened RMS over time", "time [s]", ft, fw);
  panel("against the angular speed", "angular speed [rad/s]", speed, sw);
  sec->figures.push_back(f);
}

void Builder::LensFitFigure(Section* sec, const SensorConfig& s,
                            const std::vector<CornerResidual>& corners) const {
  LensFitDiagnosis d;
  try {
    d = DiagnoseLensFit(s, corners);
  } catch (const std::exception& e) {
    sec->html += "<p class=\"note\">lens fit not diagnosed: " + Escape(e.what()) + "</p>\n";
    return;
  }
  if (d.cells.empty())
    return;
  const double W = s.width, H = s.height;
  // Arrows scaled so that the largest cell mean spans a cell; the scale is in the title.
  const double scale = d.max_mean_px > 0 ? (W / d.cells_x) / d.max_mean_px : 1.0;
  std::vector<double> x0, y0, dx, dy;
  for (const LensFitCell& c : d.cells) {
    x0.push_back(-0.5 + W * (c.col + 0.5) / d.cells_x);
    y0.push_back(-0.5 + H * (c.row + 0.5) / d.cells_y);
    dx.push_back(scale * c.mean.x());
    dy.push_back(scale * c.mean.y());
  }
  auto f = NewFigure(
      "fig-" + s.name + "-lens-fit",
      s.name + ": lens fit, mean residual per cell (max " + FormatNumber(d.max_mean_px, 3) + " px)",
      1, 1);
  auto& p = f->Add<XYPlot>();
  p.title = "mean (measured - predicted) per cell, arrows x" + FormatNumber(scale, 3);
  ImageAxes(W, H, &p);
  p.Arrows(x0, y0, dx, dy, d.significant ? kFail : PaletteColor(0));
  sec->figures.push_back(f);
  std::ostringstream h;
  h << "<p class=\"note\">Lens fit: chi-square " << FormatNumber(d.chi2, 4) << " on " << d.dof
    << " degrees of freedom (" << d.cells.size() << " cells of " << d.corners
    << " corners, within-cell noise " << FormatNumber(d.noise_px, 3)
    << " px), p = " << FormatNumber(d.p_value, 2) << "; mean |cell mean| "
    << FormatNumber(d.border_mean_px, 3) << " px at the border, "
    << FormatNumber(d.inner_mean_px, 3) << " px inside. ";
  if (d.significant)
    h << "<b>The residuals keep a systematic pattern: the model does not fit this lens.</b> Try "
      << Escape(d.suggestion) << ".";
  else
    h << "No significant systematic pattern.";
  h << "</p>\n";
  sec->html += h.str();
}

Section Builder::CameraSection(const SensorConfig& s) {
  Section sec("sec-camera-" + s.name,
              "Camera " + s.name + " (" + s.camera_model + ", " + s.distortion_model + ")");
  const auto it = data_.corners.find(s.name);
  if (it == data_.corners.end()) {
    sec.omitted = "no corner residuals for " + s.name + " in report_data/";
    return sec;
  }
  const auto& c = it->second;
  std::vector<double> du, dv, frame, u, v, ou, ov;
  std::map<int, std::pair<double, std::pair<double, int>>> per_frame;  // t, (sum sq, n)
  std::map<int, double> per_frame_whitened;                            // sum of whitened^2
  for (const auto& r : c) {
    if (r.outlier) {
      ou.push_back(r.u);
      ov.push_back(r.v);
      continue;
    }
    du.push_back(r.du);
    dv.push_back(r.dv);
    frame.push_back(r.frame);
    u.push_back(r.u);
    v.push_back(r.v);
    auto& pf = per_frame[r.frame];
    pf.first = Sec(r.t_ns);
    pf.second.first += r.du * r.du + r.dv * r.dv;
    pf.second.second += 1;
    per_frame_whitened[r.frame] += r.whitened * r.whitened;
  }
  const double W = s.width > 0 ? s.width : 1, H = s.height > 0 ? s.height : 1;
  {
    auto f = NewFigure("fig-" + s.name + "-residuals", s.name + ": reprojection errors", 1, 2);
    auto& p = f->Add<XYPlot>();
    p.title = "errors coloured by image index (inliers)";
    p.x_label = "du [px]";
    p.y_label = "dv [px]";
    p.value_label = "image index";
    p.equal_aspect = true;
    p.ScatterByValue(du, dv, frame, 1.6);
    auto& t = f->Add<XYPlot>();
    t.title = "per-image RMS over time (per coordinate)";
    t.x_label = "time [s]";
    t.y_label = "RMS [px]";
    std::vector<double> ft, fr;
    for (const auto& [k, pf] : per_frame) {
      ft.push_back(pf.first);
      fr.push_back(std::sqrt(pf.second.first / (2.0 * std::max(pf.second.second, 1))));
    }
    t.Line(ft, fr, "", PaletteColor(0), 1.0);
    t.Scatter(ft, fr, "", PaletteColor(0), 1.8);
    // What a frame's RMS scatters about when the stated noise holds.
    if (s.pixel_sigma > 0)
      t.HLine(s.pixel_sigma, "pixel_sigma", PaletteColor(3));
    if (s.pixel_sigma_estimated)
      t.HLine(*s.pixel_sigma_estimated, "estimated", PaletteColor(2));
    sec.figures.push_back(f);
  }
  WhitenedFrameFigure(&sec, s.name, per_frame, per_frame_whitened);
  {
    auto f = NewFigure("fig-" + s.name + "-image", s.name + ": over the image", 1, 2);
    auto& cov = f->Add<XYPlot>();
    cov.title = "coverage (" + std::to_string(ou.size()) + " outliers removed, red)";
    ImageAxes(W, H, &cov);
    cov.value_label = "image index";
    cov.ScatterByValue(u, v, frame, 1.2);
    if (!ou.empty())
      cov.Scatter(ou, ov, "outliers", kFail, 2.5);
    // Mean error magnitude per cell.
    const int nx = 16, ny = std::max(1, static_cast<int>(std::round(16 * H / W)));
    Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(ny, nx), n = sum;
    for (size_t i = 0; i < u.size(); ++i) {
      const int cx = std::clamp(static_cast<int>((u[i] + 0.5) / W * nx), 0, nx - 1);
      const int cy = std::clamp(static_cast<int>((v[i] + 0.5) / H * ny), 0, ny - 1);
      sum(cy, cx) += std::hypot(du[i], dv[i]);
      n(cy, cx) += 1;
    }
    auto& hm = f->Add<HeatMap>();
    hm.title = "mean |error| per cell (grey: no corners)";
    hm.values = (n.array() > 0).select(sum.array() / n.array(), kNaN);
    ImageAxes(W, H, &hm);
    hm.value_label = "px";
    sec.figures.push_back(f);
  }
  LensFitFigure(&sec, s, c);
  DistortionFigure(&sec, s);
  std::ostringstream h;
  h << "<p>" << c.size() << " corners in " << per_frame.size() << " images, " << ou.size()
    << " outliers; inlier RMS " << FormatNumber(Rms(du), 3) << " / " << FormatNumber(Rms(dv), 3)
    << " px (u / v).</p>\n";
  sec.html = h.str() + sec.html;
  return sec;
}

}  // namespace ctcal::report::detail
