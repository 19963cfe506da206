#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <opencv2/calib3d.hpp>

#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/spline/so3.h"
#include "intrinsics_refinement.h"

namespace ctcal {

namespace {

double Median(std::vector<double> v) {
  if (v.empty())
    return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Corners grouped by frame, in time order.
std::vector<std::vector<CornerObservation>> SplitFrames(
    const std::vector<CornerObservation>& corners) {
  std::map<std::int64_t, std::vector<CornerObservation>> by_stamp;
  for (const CornerObservation& c : corners)
    by_stamp[c.t_ns].push_back(c);
  std::vector<std::vector<CornerObservation>> frames;
  for (auto& [stamp, frame] : by_stamp)
    frames.push_back(std::move(frame));
  return frames;
}

// Zhang's two constraints per view on the guess's normalised plane, where the board maps by
// H ~ diag(k, k, 1) [r1 r2 t] with k = f_true / f_guess (see camera_init.h). With
// B = diag(1/k^2, 1/k^2, 1): h1^T B h2 = 0 and h1^T B h1 = h2^T B h2, each a * x + b = 0 in
// x = 1/k^2. Returns k, or 1 when the views do not determine it (fronto-parallel only).
double ClosedFormFocalScale(const CameraModel& guess, const Board& board,
                            const std::vector<std::vector<CornerObservation>>& frames,
                            int* used_views) {
  double saa = 0.0, sab = 0.0;
  *used_views = 0;
  for (const auto& frame : frames) {
    std::vector<cv::Point2d> object, image;
    for (const CornerObservation& c : frame) {
      Eigen::Vector3d ray;
      if (!guess.Unproject(Eigen::Vector2d(c.u, c.v), &ray) || ray.z() < 0.2)
        continue;
      const Eigen::Vector3d& p = board.Corner(c.corner_id);
      object.emplace_back(p.x(), p.y());
      image.emplace_back(ray.x() / ray.z(), ray.y() / ray.z());
    }
    if (object.size() < 8)
      continue;
    const cv::Mat H_cv = cv::findHomography(object, image, cv::RANSAC, 0.01);
    if (H_cv.empty())
      continue;
    Eigen::Matrix3d H;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        H(r, c) = H_cv.at<double>(r, c);
    H /= H.norm();
    const double a1 = H(0, 0) * H(0, 1) + H(1, 0) * H(1, 1);
    const double b1 = H(2, 0) * H(2, 1);
    const double a2 = H(0, 0) * H(0, 0) + H(1, 0) * H(1, 0) - H(0, 1) * H(0, 1) - H(1, 1) * H(1, 1);
    const double b2 = H(2, 0) * H(2, 0) - H(2, 1) * H(2, 1);
    saa += a1 * a1 + a2 * a2;
    sab += a1 * b1 + a2 * b2;
    ++*used_views;
  }
  if (saa <= 0.0)
    return 1.0;
  const double x = -sab / saa;
  if (!(x > 0.0))
    return 1.0;
  const double k = 1.0 / std::sqrt(x);
  return (k > 0.5 && k < 2.0) ? k : 1.0;
}

// Projection residual norms of all corners with the given parameters and poses; NaN where the
// model cannot project.
std::vector<double> ReprojectionErrors(const CameraModel& camera,
                                       const std::vector<ViewState>& views,
                                       const std::vector<CornerRef>& refs) {
  std::vector<double> errors;
  errors.reserve(refs.size());
  for (const CornerRef& c : refs) {
    const ViewState& v = views[static_cast<std::size_t>(c.view)];
    Eigen::Vector2d uv;
    if (!camera.Project(v.q_C_W * c.p_W + v.t_C_W, &uv))
      errors.push_back(std::numeric_limits<double>::quiet_NaN());
    else
      errors.push_back((uv - c.uv).norm());
  }
  return errors;
}

double Rms(const std::vector<double>& errors, const std::vector<char>* keep = nullptr) {
  double sq = 0.0;
  int n = 0;
  for (std::size_t k = 0; k < errors.size(); ++k) {
    if ((keep && !(*keep)[k]) || !std::isfinite(errors[k]))
      continue;
    sq += errors[k] * errors[k];
    ++n;
  }
  return n > 0 ? std::sqrt(sq / n) : std::numeric_limits<double>::infinity();
}

// Board poses by robust PnP with `camera` and the RMS reprojection error of the corners of the
// posed frames (infinity when none is posed).
double PnpRms(const CameraModel& camera, const Board& board,
              const std::vector<CornerObservation>& corners, int min_corners,
              std::vector<BoardView>* views) {
  *views = EstimateBoardViews(camera, board, corners, min_corners);
  std::map<std::int64_t, const BoardView*> by_stamp;
  for (const BoardView& v : *views)
    by_stamp[v.t_ns] = &v;
  double sq = 0.0;
  int n = 0;
  for (const CornerObservation& c : corners) {
    const auto it = by_stamp.find(c.t_ns);
    Eigen::Vector2d uv;
    if (it != by_stamp.end() &&
        camera.Project(it->second->T_C_W * board.Corner(c.corner_id), &uv)) {
      sq += (uv - Eigen::Vector2d(c.u, c.v)).squaredNorm();
      ++n;
    }
  }
  return n > 0 ? std::sqrt(sq / n) : std::numeric_limits<double>::infinity();
}

// One refinement: intrinsics (distortion held when !free_distortion) and all poses, corners with
// keep[k] only, Cauchy loss (intrinsics_refinement.h). A corner that the start values cannot
// project (a guess whose distortion folds the outer field, a PnP pose that puts a corner of a
// grazing view behind the camera) is left out of this refinement and counted in
// `*unprojectable`: a step that makes a corner unprojectable is rejected, so none may be at the
// start; it is back in the next refinement if it projects there.
bool Refine(CameraModel* camera, std::vector<ViewState>* views, const std::vector<CornerRef>& refs,
            const std::vector<char>& keep, bool free_distortion,
            const IntrinsicsInitOptions& options, int* unprojectable) {
  Eigen::VectorXd params = camera->params();
  const std::vector<double> start_errors = ReprojectionErrors(*camera, *views, refs);
  std::vector<CornerRef> corners;
  corners.reserve(refs.size());
  *unprojectable = 0;
  for (std::size_t k = 0; k < refs.size(); ++k) {
    if (!keep[k])
      continue;
    if (!std::isfinite(start_errors[k])) {
      ++*unprojectable;
      continue;
    }
    corners.push_back(refs[k]);
  }
  IntrinsicsRefinementOptions refinement;
  refinement.cauchy_px = options.cauchy_px;
  refinement.max_iterations = options.max_iterations;
  if (!free_distortion && camera->NumDistortionCoeffs() > 0)
    refinement.first_held_param = camera->NumIntrinsics();
  Eigen::VectorXd lower, upper;
  camera->ParamBounds(&lower, &upper);
  // One thread: a run gives the same bits for the same data and --threads
  // (docs/calibrator.md, Reproducibility), and the solve is a few milliseconds an iteration.
  const IntrinsicsRefinementSummary summary =
      RefineIntrinsicsAndPoses(camera->type(), &params, lower, upper, views, corners, refinement);
  if (!summary.usable)
    return false;
  try {
    camera->SetParams(params);
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

// The first of fu, fv that `camera` moved beyond `max_ratio` of `guess` (its index), or -1.
int FocalBeyondRatio(const CameraModel& camera, const CameraModel& guess, double max_ratio) {
  const std::vector<std::string> names = guess.ParamNames();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] != "fu" && names[i] != "fv")
      continue;
    const double ratio =
        camera.params()[static_cast<long>(i)] / guess.params()[static_cast<long>(i)];
    if (!(ratio > 1.0 / max_ratio && ratio < max_ratio))
      return static_cast<int>(i);
  }
  return -1;
}

}  // namespace

IntrinsicsInitResult InitCameraIntrinsics(const std::string& camera_name, const CameraModel& guess,
                                          const Board& board,
                                          const std::vector<CornerObservation>& corners,
                                          const IntrinsicsInitOptions& options,
                                          const InitLog& log) {
  constexpr const char* kStage = "camera intrinsics";
  // Frames with enough corners, thinned evenly to max_views.
  std::vector<std::vector<CornerObservation>> frames;
  for (auto& frame : SplitFrames(corners))
    if (static_cast<int>(frame.size()) >= options.min_corners)
      frames.push_back(std::move(frame));
  if (static_cast<int>(frames.size()) < options.min_views)
    throw InitError(
        kStage, camera_name,
        FormatInitLine("%d frames with >= %d corners (need %d board views)",
                       static_cast<int>(frames.size()), options.min_corners, options.min_views));
  if (static_cast<int>(frames.size()) > options.max_views) {
    std::vector<std::vector<CornerObservation>> thinned;
    for (int i = 0; i < options.max_views; ++i)
      thinned.push_back(frames[static_cast<std::size_t>(
          (static_cast<long>(i) * static_cast<long>(frames.size())) / options.max_views)]);
    frames = std::move(thinned);
  }
  std::vector<CornerObservation> selected;
  for (const auto& frame : frames)
    selected.insert(selected.end(), frame.begin(), frame.end());

  IntrinsicsInitResult result(guess);
  // The guess's own fit: the log's reference, and the test of the closed-form factor.
  std::vector<BoardView> pnp;
  result.rms_px_guess = PnpRms(guess, board, selected, options.min_corners, &pnp);

  // a. Closed-form focal factor, kept only when it stays within max_focal_ratio of the guess (the
  // bound the refinement is held to) and fits the corners better than the guess: the factor
  // assumes the guess's distortion and aspect ratio are right, and a zero-distortion guess of a
  // strongly distorted lens bends the normalised points (x1.29 for the default rig's radtan
  // camera whose truth is x1.05; x1.90 for an equidistant lens guessed with fu 5 % short and fv
  // 5 % long).
  int zhang_views = 0;
  const double zhang = ClosedFormFocalScale(guess, board, frames, &zhang_views);
  Eigen::VectorXd params = guess.params();
  const std::vector<std::string> names = guess.ParamNames();
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == "fu" || names[i] == "fv")
      params[static_cast<long>(i)] *= zhang;
  CameraModel camera = guess;
  std::string factor_note;
  if (zhang != 1.0 && !(zhang < options.max_focal_ratio && zhang > 1.0 / options.max_focal_ratio)) {
    factor_note = FormatInitLine(", x%.4f rejected: beyond the guess's x%.2f", zhang,
                                 options.max_focal_ratio);
  } else if (zhang != 1.0) {
    CameraModel scaled = guess;
    scaled.SetParams(params);
    std::vector<BoardView> scaled_pnp;
    const double scaled_rms = PnpRms(scaled, board, selected, options.min_corners, &scaled_pnp);
    if (scaled_pnp.size() >= pnp.size() && scaled_rms < result.rms_px_guess) {
      camera = scaled;
      pnp = std::move(scaled_pnp);
      result.focal_scale = zhang;
    } else {
      factor_note = FormatInitLine(", x%.4f rejected: PnP RMS %.2f px vs the guess's %.2f px",
                                   zhang, scaled_rms, result.rms_px_guess);
    }
  }

  // b. Poses by robust PnP with the (rescaled) model.
  if (static_cast<int>(pnp.size()) < options.min_views)
    throw InitError(kStage, camera_name,
                    FormatInitLine("PnP found the board in %d of %d frames (need %d)",
                                   static_cast<int>(pnp.size()), static_cast<int>(frames.size()),
                                   options.min_views));
  std::map<std::int64_t, int> view_of_stamp;
  std::vector<ViewState> views;
  for (const BoardView& v : pnp) {
    view_of_stamp[v.t_ns] = static_cast<int>(views.size());
    views.push_back({Eigen::Quaterniond(v.T_C_W.linear()).normalized(), v.T_C_W.translation()});
  }
  std::vector<CornerRef> refs;
  for (const CornerObservation& c : selected) {
    const auto it = view_of_stamp.find(c.t_ns);
    if (it != view_of_stamp.end())
      refs.push_back({it->second, board.Corner(c.corner_id), Eigen::Vector2d(c.u, c.v)});
  }

  // c. Projection parameters first (distortion held at the guess), then everything, then
  // everything without the outliers. A lens far from the guess's distortion (a zero guess of
  // radtan k1 -0.28) can have no plausible distortion-free fit: the held stage then walks towards
  // an orthographic camera (fu 392 -> 5 px on scripts/spec_sim.py --images --target aprilgrid
  // --seed 7, whose views determine fu to 0.03 px) and the full refinement starts from the
  // guess instead.
  std::vector<char> keep(refs.size(), 1);
  int unprojectable = 0;
  const auto refine = [&](CameraModel* model, std::vector<ViewState>* poses, bool free_distortion) {
    const bool ok = Refine(model, poses, refs, keep, free_distortion, options, &unprojectable);
    result.unprojectable = std::max(result.unprojectable, unprojectable);
    return ok;
  };
  const auto failed = [&] {
    return InitError(kStage, camera_name,
                     FormatInitLine("the refinement of the intrinsics failed (%d of %d corners not "
                                    "projectable at its start)",
                                    unprojectable, static_cast<int>(refs.size())));
  };
  CameraModel held = camera;
  std::vector<ViewState> held_views = views;
  if (!refine(&held, &held_views, false))
    throw failed();
  if (!options.estimate_distortion || FocalBeyondRatio(held, guess, options.max_focal_ratio) < 0) {
    camera = held;
    views = std::move(held_views);
  } else {
    factor_note +=
        FormatInitLine(", the distortion-free fit left x%.2f of the focal guess: not used",
                       options.max_focal_ratio);
  }
  if (options.estimate_distortion && !refine(&camera, &views, true))
    throw failed();
  const std::vector<double> errors = ReprojectionErrors(camera, views, refs);
  std::vector<double> finite;
  for (const double e : errors)
    if (std::isfinite(e))
      finite.push_back(e);
  // The norm of a 2-D Gaussian error has median 1.1774 sigma.
  const double sigma = Median(finite) / 1.1774;
  const double gate = std::max(options.outlier_px, 5.0 * sigma);
  for (std::size_t k = 0; k < refs.size(); ++k)
    if (!(errors[k] <= gate)) {
      keep[k] = 0;
      ++result.outliers;
    }
  if (result.outliers > 0 && !refine(&camera, &views, options.estimate_distortion))
    throw InitError(kStage, camera_name, "the refinement without outliers failed");
  // Views that are all nearly fronto-parallel (or alike) leave focal length and board depth
  // trading freely: the refinement then walks far from any plausible focal length (towards an
  // orthographic camera), which the guess (within ~20 %) rules out.
  if (const int i = FocalBeyondRatio(camera, guess, options.max_focal_ratio); i >= 0)
    throw InitError(
        kStage, camera_name,
        FormatInitLine("the board views do not determine the focal length: the refinement "
                       "moved %s from %.1f to %.4g px (views nearly fronto-parallel or "
                       "alike: tilt the board relative to the camera)",
                       names[static_cast<std::size_t>(i)].c_str(), guess.params()[i],
                       camera.params()[i]));
  result.rms_px = Rms(ReprojectionErrors(camera, views, refs), &keep);
  result.corners = static_cast<int>(std::count(keep.begin(), keep.end(), 1)) - unprojectable;
  result.views = static_cast<int>(views.size());
  result.camera = camera;
  std::string values;
  for (int i = 0; i < camera.NumParams(); ++i)
    values += (i ? " " : "") + FormatInitLine("%s=%.4g", names[static_cast<std::size_t>(i)].c_str(),
                                              camera.params()[i]);
  result.summary =
      camera_name +
      FormatInitLine(
          ": focal x%.4f (Zhang, %d views%s), then refined on %d views / %d "
          "corners (%d outliers, %d not projectable at a start): RMS %.3f px (guess "
          "%.2f px); ",
          result.focal_scale, zhang_views, factor_note.c_str(), result.views, result.corners,
          result.outliers, result.unprojectable, result.rms_px, result.rms_px_guess) +
      values;
  if (log)
    log(result.summary);
  return result;
}

BoardPosesResult InitBoardPoses(const std::string& camera_name, const CameraModel& camera,
                                const Board& board, const std::vector<CornerObservation>& corners,
                                int min_corners, int min_views, const InitLog& log, int threads) {
  constexpr const char* kStage = "board poses";
  BoardPosesResult result;
  result.views = EstimateBoardViews(camera, board, corners, min_corners, threads);
  std::vector<std::int64_t> stamps;
  for (const CornerObservation& c : corners)
    if (stamps.empty() || stamps.back() != c.t_ns)
      stamps.push_back(c.t_ns);
  result.frames = static_cast<int>(stamps.size());
  if (static_cast<int>(result.views.size()) < min_views)
    throw InitError(
        kStage, camera_name,
        FormatInitLine("board pose found in %d of %d frames with corners (need %d; frames "
                       "need >= %d corners the camera model can unproject)",
                       static_cast<int>(result.views.size()), result.frames, min_views,
                       min_corners));
  std::vector<double> rms;
  for (const BoardView& v : result.views)
    rms.push_back(v.rms_ray_error);
  result.median_rms_ray = Median(rms);
  result.summary =
      camera_name + FormatInitLine(": board pose in %d of %d frames, median ray RMS %.2e",
                                   static_cast<int>(result.views.size()), result.frames,
                                   result.median_rms_ray);
  if (log)
    log(result.summary);
  return result;
}

RelativePoseResult InitCameraRelativePose(const std::string& camera_i,
                                          const std::vector<BoardView>& views_i,
                                          double time_offset_i, const std::string& camera_j,
                                          const std::vector<BoardView>& views_j,
                                          double time_offset_j, const InitLog& log) {
  constexpr const char* kStage = "camera relative pose";
  const std::string pair_name = camera_i + "-" + camera_j;
  std::vector<double> gaps;
  for (std::size_t k = 1; k < views_j.size(); ++k)
    gaps.push_back(InitSeconds(views_j[k].t_ns) - InitSeconds(views_j[k - 1].t_ns));
  const double max_gap = 1.5 * Median(gaps);
  // Samples T_Ci_Cj = T_Ci_W (T_Cj_W at the same base time)^-1.
  std::vector<Eigen::Quaterniond> q;
  std::vector<Eigen::Vector3d> t;
  for (const BoardView& vi : views_i) {
    // Cj's own clock at the base time of this Ci view.
    const double t_j = InitSeconds(vi.t_ns) + time_offset_i - time_offset_j;
    const auto it = std::upper_bound(
        views_j.begin(), views_j.end(), t_j,
        [](double value, const BoardView& v) { return value < InitSeconds(v.t_ns); });
    if (it == views_j.begin() || it == views_j.end())
      continue;
    const BoardView& b = *it;
    const BoardView& a = *(it - 1);
    const double ta = InitSeconds(a.t_ns), tb = InitSeconds(b.t_ns);
    if (tb - ta > max_gap)
      continue;
    const double s = (t_j - ta) / (tb - ta);
    const Eigen::Quaterniond q_Cj_W =
        Eigen::Quaterniond(a.T_C_W.linear()).slerp(s, Eigen::Quaterniond(b.T_C_W.linear()));
    const Eigen::Vector3d t_Cj_W = (1.0 - s) * a.T_C_W.translation() + s * b.T_C_W.translation();
    const Eigen::Quaterniond q_Ci_W(vi.T_C_W.linear());
    const Eigen::Quaterniond q_Ci_Cj = (q_Ci_W * q_Cj_W.conjugate()).normalized();
    q.push_back(q_Ci_Cj);
    t.push_back(vi.T_C_W.translation() - q_Ci_Cj * t_Cj_W);
  }
  const int n = static_cast<int>(q.size());
  if (n < 3)
    throw InitError(
        kStage, pair_name,
        FormatInitLine("%d views of '%s' have a view of '%s' within %.1f ms on each side "
                       "(need 3)",
                       n, camera_i.c_str(), camera_j.c_str(), max_gap * 1e3));
  // Robust start: the sample with the smallest median angle to (up to 50 of) the others.
  const int stride = std::max(1, n / 50);
  int best = 0;
  double best_median = std::numeric_limits<double>::infinity();
  for (int a = 0; a < n; a += stride) {
    std::vector<double> d;
    for (int b = 0; b < n; b += stride)
      d.push_back(q[static_cast<std::size_t>(a)].angularDistance(q[static_cast<std::size_t>(b)]));
    const double m = Median(d);
    if (m < best_median) {
      best_median = m;
      best = a;
    }
  }
  Eigen::Quaterniond q_mean = q[static_cast<std::size_t>(best)];
  std::vector<char> inlier(static_cast<std::size_t>(n), 1);
  for (int iteration = 0; iteration < 5; ++iteration) {
    std::vector<double> d(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k)
      d[static_cast<std::size_t>(k)] = q_mean.angularDistance(q[static_cast<std::size_t>(k)]);
    const double gate = std::max(3.0 * 1.4826 * Median(d), 1e-4);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int m = 0;
    for (int k = 0; k < n; ++k) {
      inlier[static_cast<std::size_t>(k)] = d[static_cast<std::size_t>(k)] <= gate;
      if (inlier[static_cast<std::size_t>(k)]) {
        // Geodesic (Karcher) mean step: average of the left tangent vectors.
        sum += LogSO3<double>((q[static_cast<std::size_t>(k)] * q_mean.conjugate()).normalized());
        ++m;
      }
    }
    q_mean = (ExpSO3<double>(Eigen::Vector3d(sum / m)) * q_mean).normalized();
  }
  Eigen::Vector3d t_med;
  for (int i = 0; i < 3; ++i) {
    std::vector<double> c;
    for (const auto& v : t)
      c.push_back(v[i]);
    t_med[i] = Median(c);
  }
  std::vector<double> dist;
  for (const auto& v : t)
    dist.push_back((v - t_med).norm());
  const double t_gate = std::max(3.0 * 1.4826 * Median(dist), 1e-4);
  Eigen::Vector3d t_sum = Eigen::Vector3d::Zero();
  int inliers = 0;
  std::vector<double> rot_dev, trans_dev;
  for (int k = 0; k < n; ++k) {
    if (!inlier[static_cast<std::size_t>(k)] || dist[static_cast<std::size_t>(k)] > t_gate)
      continue;
    t_sum += t[static_cast<std::size_t>(k)];
    ++inliers;
  }
  RelativePoseResult result;
  result.pairs = n;
  result.inliers = inliers;
  result.T_Ci_Cj.linear() = q_mean.toRotationMatrix();
  result.T_Ci_Cj.translation() = inliers > 0 ? Eigen::Vector3d(t_sum / inliers) : t_med;
  for (int k = 0; k < n; ++k) {
    rot_dev.push_back(q_mean.angularDistance(q[static_cast<std::size_t>(k)]));
    trans_dev.push_back((t[static_cast<std::size_t>(k)] - result.T_Ci_Cj.translation()).norm());
  }
  result.rotation_spread_deg = Median(rot_dev) * 180.0 / M_PI;
  result.translation_spread_m = Median(trans_dev);
  const Eigen::Vector3d& p = result.T_Ci_Cj.translation();
  result.summary =
      pair_name + FormatInitLine(
                      ": T_Ci_Cj rotation %.3f deg, translation [%.4f %.4f %.4f] m from %d "
                      "of %d view pairs (median spread %.3f deg, %.2f mm)",
                      Eigen::AngleAxisd(q_mean).angle() * 180.0 / M_PI, p.x(), p.y(), p.z(),
                      inliers, n, result.rotation_spread_deg, result.translation_spread_m * 1e3);
  if (log)
    log(result.summary);
  return result;
}

}  // namespace ctcal
