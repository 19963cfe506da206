// The camera-only calibration (camera_only_calibrator.h): initialisation from the coarse-guess
// stages (init/camera_init.h), one bundle adjustment over board poses, extrinsics and intrinsics,
// outlier removal, and the marginal covariance of the calibration.
#include "ctcal/calibrator/camera_only/camera_only_calibrator.h"

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "ctcal/calibrator/camera_only/board_frame_corners.h"
#include "ctcal/calibrator/camera_only/mrcal_board_corner.h"
#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/calibrator/marginal_covariance.h"
#include "ctcal/calibrator/report_data_builder.h"
#include "ctcal/calibrator/residuals/mrcal_regularization.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/sensors/mrcal_lens.h"
#include "ctcal/sensors/parameter_names.h"
#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/spline/so3_manifold.h"
#include "ctcal/targets/board.h"

namespace ctcal {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Corner reprojection of camera C in a frame with board pose T_W_B:
//   p_B = R_W_B^T (p_W - p_W_B),  p_C = R_B_C^T (p_B - p_B_C),  r = (pi(theta, p_C) - uv) / sigma.
// The corner's stated sigma whitens it, so r ~ N(0, I) for a consistent model. The reference
// camera gets a constant identity T_B_C (B is its frame). Quaternions are Eigen's x, y, z, w on
// So3LeftManifold, whose tangent is the SPEC's rotation perturbation: the marginal covariance is
// then directly the `sigma: R_B_S` of the result.
template <class Model>
struct BoardCornerResidual {
  BoardCornerResidual(const Eigen::Vector3d& p_W, const Eigen::Vector2d& uv, double sigma)
      : p_W_(p_W), uv_(uv), inv_sigma_(1.0 / sigma) {}

  template <typename T>
  bool operator()(const T* q_W_B, const T* p_W_B, const T* q_B_C, const T* p_B_C, const T* theta,
                  T* residual) const {
    const Eigen::Matrix<T, 3, 1> p_C = BoardPointInCamera(p_W_, q_W_B, p_W_B, q_B_C, p_B_C);
    Eigen::Matrix<T, 2, 1> uv;
    if (!Model::Project(theta, p_C, &uv))
      return false;
    residual[0] = (uv(0) - uv_(0)) * inv_sigma_;
    residual[1] = (uv(1) - uv_(1)) * inv_sigma_;
    return true;
  }

  Eigen::Vector3d p_W_;
  Eigen::Vector2d uv_;
  double inv_sigma_;
};

// A pose [q (x, y, z, w), p]: a board pose is one 7-double block on BoardPoseManifold (frame
// blocks) or the two blocks q, p (per-corner blocks); T_B_C is always the two blocks.
struct PoseBlock {
  double x[7] = {0, 0, 0, 1, 0, 0, 0};
  double* q() { return x; }
  double* p() { return x + 4; }
  const double* q() const { return x; }
  const double* p() const { return x + 4; }
};

void SetPose(const Eigen::Isometry3d& T, PoseBlock* block) {
  const Eigen::Quaterniond q(T.linear());
  block->x[0] = q.x();
  block->x[1] = q.y();
  block->x[2] = q.z();
  block->x[3] = q.w();
  for (int i = 0; i < 3; ++i)
    block->p()[i] = T.translation()(i);
}

Eigen::Isometry3d GetPose(const PoseBlock& block) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(block.x[3], block.x[0], block.x[1], block.x[2])
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(block.x[4], block.x[5], block.x[6]);
  return T;
}

// One corner in the problem: camera, pose block, measurement.
struct CornerTerm {
  int camera = 0;
  int pose = 0;
  std::int64_t t_ns = 0;  // image stamp and corner id: the report's rows
  int corner_id = 0;
  Eigen::Vector3d p_W;
  Eigen::Vector2d uv;
  double sigma = 1.0;
  bool inlier = true;
};

struct CameraState {
  const SensorConfig* config = nullptr;
  CameraModel model;
  PoseBlock T_B_C;
  CameraOnlyCameraReport report;
  std::vector<BoardView> views;
  explicit CameraState(CameraModel m) : model(std::move(m)) {}
};

double Median(std::vector<double> v) {
  if (v.empty())
    return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Median angle of the board normals (z_W in the camera) to their mean: how different the views
// are. Zhang's method needs distinct board orientations; nearly parallel ones trade focal length
// against distance.
double ViewSpreadDeg(const std::vector<BoardView>& views) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const BoardView& v : views)
    mean += v.T_C_W.linear().col(2);
  if (mean.norm() == 0.0)
    return 0.0;
  mean.normalize();
  std::vector<double> angles;
  for (const BoardView& v : views)
    angles.push_back(std::acos(std::clamp(v.T_C_W.linear().col(2).dot(mean), -1.0, 1.0)) / kDeg);
  return Median(angles);
}

bool IsPixelParameter(const std::string& symbol) {
  return symbol == "fu" || symbol == "fv" || symbol == "pu" || symbol == "pv" || symbol == "fx" ||
         symbol == "fy" || symbol == "cx" || symbol == "cy";
}

// Index of the horizontal focal length: the first of the last four intrinsics in SPEC section 4
// (fu fv pu pv), the first of mrcal's core (fx fy cx cy).
int FocalIndex(const CameraModel& model) {
  return model.mrcal_lens() ? 0 : model.NumIntrinsics() - 4;
}

}  // namespace

CameraOnlyResult CalibrateCameraOnly(const RigConfig& rig,
                                     const std::map<std::string, SensorData>& data,
                                     const CameraOnlyOptions& options, std::ostream& log) {
  const auto wall_start = std::chrono::steady_clock::now();
  report::StageClock clock;  // the log's `time:` line of the stages
  const int threads = options.num_threads > 0
                          ? options.num_threads
                          : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  if (!rig.IsCameraOnly())
    throw std::runtime_error("camera-only calibration: the rig has an inertial sensor");
  ValidateRig(rig, "camera-only calibration");
  const SensorConfig& base = rig.Base();
  if (base.type != SensorType::kCamera)
    throw std::runtime_error("camera-only calibration: base_imu '" + rig.base_imu +
                             "' is not a camera");
  const Board board(rig.target);
  CameraOnlyResult result;
  result.rig = rig;
  auto warn = [&](const std::string& line) {
    result.warnings.push_back(line);
    log << "[camera-only] WARNING: " << line << "\n";
  };
  const InitLog init_log = [&log](const std::string& line) { log << "[init] " << line << "\n"; };

  // Cameras, the reference first.
  std::vector<std::unique_ptr<CameraState>> cams;
  std::vector<const SensorConfig*> configs{&base};
  for (const SensorConfig& s : rig.sensors)
    if (s.name != base.name)
      configs.push_back(&s);
  for (const SensorConfig* s : configs) {
    const auto it = data.find(s->name);
    if (it == data.end() || !it->second.has_corners)
      throw std::runtime_error("camera-only calibration: camera '" + s->name +
                               "' has no corners.csv (run `ctcal detect` on its images first)");
    CameraModel model =
        CameraModel::Create(s->camera_model, s->intrinsics, s->distortion_model,
                            s->distortion_coeffs, Eigen::Vector2i(s->width, s->height));
    auto state = std::make_unique<CameraState>(std::move(model));
    state->config = s;
    if (s->name != base.name)
      SetPose(Eigen::Isometry3d(s->T_B_S), &state->T_B_C);
    cams.push_back(std::move(state));
  }

  // Intrinsics and board poses per camera. The guess is kept unless its PnP reprojection says it
  // is poor; then the intrinsics come from the board views (stage 1).
  for (auto& cam : cams) {
    const std::string& name = cam->config->name;
    const std::vector<CornerObservation>& corners = data.at(name).corners;
    std::set<std::int64_t> frames;
    for (const CornerObservation& c : corners)
      frames.insert(c.t_ns);
    cam->report.frames = static_cast<int>(frames.size());
    const int focal_index = FocalIndex(cam->model);
    bool reinit = false;
    if (cam->config->Estimates(EstimateItem::kIntrinsics)) {
      try {
        const BoardPosesResult guess = InitBoardPoses(
            name, cam->model, board, corners, options.min_corners, options.min_views, {}, threads);
        const double rms_px = guess.median_rms_ray * cam->model.params()(focal_index);
        reinit = rms_px > options.reinit_rms_px;
        log << "[camera-only] " << name << ": the guessed intrinsics reproject at " << rms_px
            << " px (median over " << guess.views.size() << " views)"
            << (!reinit ? ""
                : cam->model.mrcal_lens()
                    ? ": kept (an mrcal lens starts from its guess; the solve refines it)"
                    : ": re-initialising them from the board views")
            << "\n";
      } catch (const InitError&) {
        reinit = true;  // no pose with the guess: try the intrinsics stage, which says why
      }
    }
    bool guess_posed = true;
    if (reinit && cam->model.mrcal_lens()) {
      // The intrinsics stage fits SPEC section 4's models only: an mrcal lens starts from its
      // guess, which the robust bundle adjustment refines when the board poses could be found.
      try {
        InitBoardPoses(name, cam->model, board, corners, options.min_corners, options.min_views, {},
                       threads);
      } catch (const InitError&) {
        guess_posed = false;
      }
      if (!guess_posed)
        throw std::runtime_error(
            "camera-only calibration: " + name + " (mrcal " + cam->model.distortion_model() +
            "): the guessed intrinsics give no board poses; start from a fit of a simpler model "
            "(OPENCV4/5/8 take a pinhole-radtan fit's numbers, zeros for the rest; a splined "
            "model the focal length and centre with zero control points)");
      reinit = false;
    }
    if (reinit) {
      IntrinsicsInitOptions init_options;
      init_options.min_corners = options.min_corners;
      init_options.min_views = options.min_views;
      cam->model =
          InitCameraIntrinsics(name, cam->model, board, corners, init_options, init_log).camera;
      cam->report.intrinsics_reinitialised = true;
    }
    cam->views = InitBoardPoses(name, cam->model, board, corners, options.min_corners,
                                options.min_views, init_log, threads)
                     .views;
    cam->report.view_spread_deg = ViewSpreadDeg(cam->views);
  }

  // Extrinsics from the shared views (stage 2b): T_B_C = T_Cref_C.
  for (std::size_t c = 1; c < cams.size(); ++c) {
    if (!cams[c]->config->Estimates(EstimateItem::kExtrinsics))
      continue;
    const RelativePoseResult rel =
        InitCameraRelativePose(base.name, cams[0]->views, 0.0, cams[c]->config->name,
                               cams[c]->views, cams[c]->config->time_offset, init_log);
    SetPose(rel.T_Ci_Cj, &cams[c]->T_B_C);
  }

  // Reference frames and the pairing rule of SPEC section 7.
  std::set<std::int64_t> ref_stamps;
  for (const CornerObservation& c : data.at(base.name).corners)
    ref_stamps.insert(c.t_ns);
  for (const ImageEntry& e : data.at(base.name).images)
    ref_stamps.insert(e.t_ns);
  std::vector<double> periods;
  for (auto it = ref_stamps.begin(); std::next(it) != ref_stamps.end(); ++it)
    periods.push_back(static_cast<double>(*std::next(it) - *it));
  const double half_period = 0.5 * Median(periods);
  // A frame's base time: its stamp plus the camera's given (not estimated) time offset, 0 for
  // hardware-synchronised cameras.
  std::map<int, double> max_pair_gap_ns;  // per camera, over its paired frames
  auto pose_key = [&](int camera, std::int64_t stamp_ns) -> std::pair<int, std::int64_t> {
    if (camera == 0)
      return {0, stamp_ns};
    const std::int64_t t_ns =
        stamp_ns + std::llround(cams[static_cast<std::size_t>(camera)]->config->time_offset * 1e9);
    auto it = ref_stamps.lower_bound(t_ns);
    std::int64_t best = 0;
    double best_dt = std::numeric_limits<double>::infinity();
    if (it != ref_stamps.end()) {
      best = *it;
      best_dt = static_cast<double>(*it - t_ns);
    }
    if (it != ref_stamps.begin() && static_cast<double>(t_ns - *std::prev(it)) < best_dt) {
      best = *std::prev(it);
      best_dt = static_cast<double>(t_ns - best);
    }
    if (best_dt <= half_period) {
      max_pair_gap_ns[camera] = std::max(max_pair_gap_ns[camera], best_dt);
      return {0, best};
    }
    return {camera, stamp_ns};  // seen without the reference camera: a pose of its own
  };

  // Board poses T_W_B: the reference camera's PnP, then the other cameras' for frames the
  // reference has no pose for.
  std::map<std::pair<int, std::int64_t>, int> pose_index;
  std::vector<PoseBlock> poses;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    const Eigen::Isometry3d T_B_C = GetPose(cams[c]->T_B_C);
    for (const BoardView& v : cams[c]->views) {
      const auto key = pose_key(static_cast<int>(c), v.t_ns);
      if (pose_index.count(key))
        continue;
      pose_index[key] = static_cast<int>(poses.size());
      PoseBlock block;
      SetPose(v.T_C_W.inverse() * T_B_C.inverse(), &block);
      poses.push_back(block);
    }
  }
  result.poses = static_cast<int>(poses.size());
  for (const auto& [c, gap_ns] : max_pair_gap_ns) {
    if (gap_ns * 1e-9 > options.max_pair_gap_s) {
      std::ostringstream why;
      why << cams[static_cast<std::size_t>(c)]->config->name << ": frames paired with " << base.name
          << "'s up to " << gap_ns * 1e-6
          << " ms apart (stamp + time_offset): the cameras must expose at once for a shared board "
             "pose; on a moving rig give their time_offset or synchronise them";
      warn(why.str());
    }
  }

  std::vector<CornerTerm> terms;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    std::set<std::int64_t> used, dropped;
    for (const CornerObservation& o : data.at(cams[c]->config->name).corners) {
      const auto it = pose_index.find(pose_key(static_cast<int>(c), o.t_ns));
      if (it == pose_index.end()) {
        dropped.insert(o.t_ns);
        continue;
      }
      used.insert(o.t_ns);
      CornerTerm term;
      term.camera = static_cast<int>(c);
      term.pose = it->second;
      term.t_ns = o.t_ns;
      term.corner_id = o.corner_id;
      term.p_W = board.Corner(o.corner_id);
      term.uv = Eigen::Vector2d(o.u, o.v);
      term.sigma = o.sigma.value_or(cams[c]->config->pixel_sigma);
      terms.push_back(term);
    }
    cams[c]->report.frames_used = static_cast<int>(used.size());
    cams[c]->report.frames_dropped = static_cast<int>(dropped.size());
    if (!dropped.empty())
      log << "[camera-only] " << cams[c]->config->name << ": " << dropped.size()
          << " frames dropped (fewer than " << options.min_corners
          << " corners and no reference pose)\n";
  }

  // The corner's whitened residual r = (pi - uv) / sigma at the current values (false: it does not
  // project): the outlier gate, the residual statistics and the report's rows.
  const PoseBlock identity_pose;
  PoseBlock ref_T_B_C = identity_pose;  // constant: B is the reference camera's frame
  auto whitened = [&](const CornerTerm& t, double r[2]) {
    CameraState& cam = *cams[static_cast<std::size_t>(t.camera)];
    const PoseBlock& T_B_C = t.camera == 0 ? ref_T_B_C : cam.T_B_C;
    const PoseBlock& T_W_B = poses[static_cast<std::size_t>(t.pose)];
    if (cam.model.mrcal_lens()) {
      const double* blocks[5] = {T_W_B.q(), T_W_B.p(), T_B_C.q(), T_B_C.p(),
                                 cam.model.params().data()};
      return MrcalBoardCornerCost(cam.model.shared_mrcal_lens(), t.p_W, t.uv, t.sigma)
          .Evaluate(blocks, r, nullptr);
    }
    return VisitCameraModel(cam.model.type(), [&](auto model) {
      return BoardCornerResidual<decltype(model)>(t.p_W, t.uv, t.sigma)(
          T_W_B.q(), T_W_B.p(), T_B_C.q(), T_B_C.p(), cam.model.params().data(), r);
    });
  };

  // The problem, built twice: robust (Huber) on every corner, then L2 on the inliers. By default
  // one compressed block per camera frame (board_frame_corners.h) over the frame's 7-double board
  // pose, which Ceres' Schur complement eliminates; options.per_corner_blocks: one autodiff block
  // per corner over the pose's q and p (the reference the frame blocks are tested against).
  So3LeftManifold so3;
  BoardPoseManifold board_pose_manifold;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::HuberLoss huber(options.huber_whitened);
  auto add_corner_blocks = [&](ceres::Problem& problem, ceres::LossFunction* loss) {
    for (const CornerTerm& t : terms) {
      if (!t.inlier)
        continue;
      CameraState& cam = *cams[static_cast<std::size_t>(t.camera)];
      PoseBlock& T_B_C = t.camera == 0 ? ref_T_B_C : cam.T_B_C;
      PoseBlock& T_W_B = poses[static_cast<std::size_t>(t.pose)];
      ceres::CostFunction* cost =
          cam.model.mrcal_lens()
              ? new MrcalBoardCornerCost(cam.model.shared_mrcal_lens(), t.p_W, t.uv, t.sigma)
              : VisitCameraModel(cam.model.type(), [&](auto model) {
                  using Model = decltype(model);
                  return static_cast<ceres::CostFunction*>(
                      new ceres::AutoDiffCostFunction<BoardCornerResidual<Model>, 2, 4, 3, 4, 3,
                                                      Model::kNumParams>(
                          new BoardCornerResidual<Model>(t.p_W, t.uv, t.sigma)));
                });
      problem.AddResidualBlock(cost, loss, T_W_B.q(), T_W_B.p(), T_B_C.q(), T_B_C.p(),
                               cam.model.mutable_params());
    }
    for (PoseBlock& pose : poses)
      if (problem.HasParameterBlock(pose.q()))
        problem.SetManifold(pose.q(), &so3);
  };
  // measurements: the inlier corners, frame by frame (a frame = a run of one camera's terms on
  // one stamp); the blocks point into it, so it outlives the problem.
  auto add_frame_blocks = [&](ceres::Problem& problem, double huber_threshold,
                              std::vector<CornerMeasurement>* measurements) {
    measurements->clear();
    std::vector<std::pair<std::size_t, std::size_t>> frames;  // [first, end) in measurements
    std::vector<std::size_t> frame_term;                      // a term of each frame
    for (std::size_t i = 0; i < terms.size(); ++i) {
      const CornerTerm& t = terms[i];
      if (!t.inlier)
        continue;
      const bool same = !frame_term.empty() && terms[frame_term.back()].camera == t.camera &&
                        terms[frame_term.back()].t_ns == t.t_ns;
      if (!same) {
        frames.emplace_back(measurements->size(), measurements->size());
        frame_term.push_back(i);
      }
      CornerMeasurement m;
      m.p_W = t.p_W;
      m.uv = t.uv;
      m.sigma_px = t.sigma;
      measurements->push_back(m);
      frames.back().second = measurements->size();
    }
    ceres::ParameterBlockOrdering* ordering = new ceres::ParameterBlockOrdering;
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const CornerTerm& t = terms[frame_term[f]];
      CameraState& cam = *cams[static_cast<std::size_t>(t.camera)];
      PoseBlock& T_B_C = t.camera == 0 ? ref_T_B_C : cam.T_B_C;
      PoseBlock& T_W_B = poses[static_cast<std::size_t>(t.pose)];
      problem.AddResidualBlock(
          MakeBoardFrameCorners(cam.model.type(), measurements->data() + frames[f].first,
                                static_cast<int>(frames[f].second - frames[f].first),
                                huber_threshold),
          nullptr, T_W_B.x, T_B_C.q(), T_B_C.p(), cam.model.mutable_params());
    }
    for (PoseBlock& pose : poses)
      if (problem.HasParameterBlock(pose.x)) {
        problem.SetManifold(pose.x, &board_pose_manifold);
        ordering->AddElementToGroup(pose.x, 0);  // eliminated first (Schur complement)
      }
    return std::shared_ptr<ceres::ParameterBlockOrdering>(ordering);
  };
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering;
  const bool any_mrcal = std::any_of(cams.begin(), cams.end(),
                                     [](const auto& cam) { return cam->model.mrcal_lens(); });
  // mrcal's regularisation of each mrcal lens whose intrinsics are estimated, scaled to the
  // camera's inlier corner residuals (MrcalLens::MakeRegularization).
  auto add_regularization = [&](ceres::Problem& problem) {
    for (std::size_t c = 0; c < cams.size(); ++c) {
      CameraState& cam = *cams[c];
      if (!cam.model.mrcal_lens() || !cam.config->Estimates(EstimateItem::kIntrinsics))
        continue;
      double measurements = 0.0;
      for (const CornerTerm& t : terms)
        measurements += (t.inlier && t.camera == static_cast<int>(c)) ? 2.0 : 0.0;
      auto cost = std::make_unique<MrcalRegularizationCost>(
          cam.model.mrcal_lens()->MakeRegularization(cam.model.resolution(), measurements));
      if (cost->NumTerms() > 0)
        problem.AddResidualBlock(cost.release(), nullptr, cam.model.mutable_params());
    }
  };
  auto build = [&](ceres::Problem& problem, bool robust,
                   std::vector<CornerMeasurement>* measurements) {
    ordering.reset();
    // An mrcal lens has per-corner blocks only (its parameter count is a run-time number), and a
    // problem holds the board poses in one form: then every camera takes per-corner blocks.
    if (options.per_corner_blocks || any_mrcal)
      add_corner_blocks(problem, robust ? &huber : nullptr);
    else
      ordering = add_frame_blocks(problem, robust ? options.huber_whitened : 0.0, measurements);
    add_regularization(problem);
    for (std::size_t c = 0; c < cams.size(); ++c) {
      CameraState& cam = *cams[c];
      PoseBlock& T_B_C = c == 0 ? ref_T_B_C : cam.T_B_C;
      if (!problem.HasParameterBlock(T_B_C.q()))
        continue;
      problem.SetManifold(T_B_C.q(), &so3);
      if (ordering) {
        ordering->AddElementToGroup(T_B_C.q(), 1);
        ordering->AddElementToGroup(T_B_C.p(), 1);
        ordering->AddElementToGroup(cam.model.mutable_params(), 1);
      }
      if (c == 0 || !cam.config->Estimates(EstimateItem::kExtrinsics)) {
        problem.SetParameterBlockConstant(T_B_C.q());
        problem.SetParameterBlockConstant(T_B_C.p());
      }
      double* theta = cam.model.mutable_params();
      if (!cam.config->Estimates(EstimateItem::kIntrinsics)) {
        problem.SetParameterBlockConstant(theta);
        continue;
      }
      Eigen::VectorXd lower, upper;
      cam.model.ParamBounds(&lower, &upper);
      for (int i = 0; i < cam.model.NumParams(); ++i) {
        if (std::isfinite(lower(i)))
          problem.SetParameterLowerBound(theta, i, lower(i));
        if (std::isfinite(upper(i)))
          problem.SetParameterUpperBound(theta, i, upper(i));
      }
    }
  };
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_SCHUR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = threads;
  solver_options.function_tolerance = 1e-10;
  solver_options.parameter_tolerance = 1e-10;
  int iterations = 0;
  auto solve = [&](ceres::Problem& problem, const char* what) {
    solver_options.linear_solver_ordering = ordering;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    iterations += static_cast<int>(summary.iterations.size());
    log << "[camera-only] " << what << " solve: " << summary.num_residuals << " residuals, "
        << summary.iterations.size() << " iterations, cost " << summary.initial_cost << " -> "
        << summary.final_cost << " (" << summary.message << ")\n";
    if (!summary.IsSolutionUsable())
      throw std::runtime_error(std::string("camera-only calibration: the ") + what +
                               " solve failed: " + summary.message);
    return summary.final_cost;
  };

  std::vector<report::StageTime> stages{clock.Lap("initialisation")};
  {
    std::vector<CornerMeasurement> measurements;
    ceres::Problem robust(problem_options);
    build(robust, true, &measurements);
    solve(robust, "robust");
  }
  // Outliers per camera against the robust scale of that camera's whitened errors.
  {
    std::vector<std::vector<double>> norms(cams.size());
    std::vector<double> norm(terms.size(), 0.0);
    for (std::size_t i = 0; i < terms.size(); ++i) {
      double r[2];
      if (!whitened(terms[i], r))
        throw std::runtime_error("camera-only calibration: a corner of camera '" +
                                 cams[static_cast<std::size_t>(terms[i].camera)]->config->name +
                                 "' cannot be projected after the robust solve");
      norm[i] = std::hypot(r[0], r[1]);
      norms[static_cast<std::size_t>(terms[i].camera)].push_back(norm[i]);
    }
    std::vector<double> threshold(cams.size());
    for (std::size_t c = 0; c < cams.size(); ++c)
      threshold[c] = std::max(3.0, options.outlier_robust_sigmas * Median(norms[c]) / 1.1774);
    for (std::size_t i = 0; i < terms.size(); ++i) {
      const auto c = static_cast<std::size_t>(terms[i].camera);
      if (norm[i] > threshold[c]) {
        terms[i].inlier = false;
        ++cams[c]->report.outliers;
      }
    }
  }
  for (auto& cam : cams)
    if (cam->report.outliers > 0)
      log << "[camera-only] " << cam->config->name << ": " << cam->report.outliers
          << " outlier corners removed\n";

  std::vector<CornerMeasurement> measurements;
  ceres::Problem problem(problem_options);
  build(problem, false, &measurements);
  const double final_cost = solve(problem, "final");
  stages.push_back(clock.Lap("solves"));

  // Residuals per camera, raw px and whitened; the report's corner rows (report_data.h): the
  // model at the final values, outliers included.
  std::vector<double> sum_px(cams.size(), 0.0), sum_w(cams.size(), 0.0);
  for (const CornerTerm& t : terms) {
    CameraState& cam = *cams[static_cast<std::size_t>(t.camera)];
    double r[2];
    const bool ok = whitened(t, r);
    if (t.inlier) {
      const auto c = static_cast<std::size_t>(t.camera);
      const double w2 = r[0] * r[0] + r[1] * r[1];
      sum_w[c] += w2;
      sum_px[c] += w2 * t.sigma * t.sigma;
      ++cam.report.corners;
    }
    auto& rows = result.report_data.corners[cam.config->name];
    report::CornerResidual row;
    row.t_ns = t.t_ns;
    row.frame = rows.empty() ? 0 : rows.back().frame + (rows.back().t_ns != t.t_ns);
    row.corner_id = t.corner_id;
    row.u = t.uv.x();
    row.v = t.uv.y();
    // r = (predicted - measured) / sigma in this file's residual.
    row.du = ok ? -r[0] * t.sigma : std::numeric_limits<double>::quiet_NaN();
    row.dv = ok ? -r[1] * t.sigma : std::numeric_limits<double>::quiet_NaN();
    row.whitened = ok ? std::hypot(r[0], r[1]) : std::numeric_limits<double>::quiet_NaN();
    row.outlier = !t.inlier;
    rows.push_back(row);
  }

  stages.push_back(clock.Lap("residuals"));

  // Marginal covariance of the calibration, board poses marginalised.
  std::vector<CalibrationBlock> calib;
  for (std::size_t c = 0; c < cams.size(); ++c) {
    CameraState& cam = *cams[c];
    const std::string& name = cam.config->name;
    if (cam.config->Estimates(EstimateItem::kIntrinsics)) {
      CalibrationBlock b;
      b.values = cam.model.mutable_params();
      const std::vector<std::string> symbols = cam.model.ParamNames();
      for (int i = 0; i < cam.model.NumParams(); ++i) {
        const bool intrinsic = i < cam.model.NumIntrinsics();
        b.names.push_back(ParameterName(name, intrinsic ? "intrinsics" : "distortion_coeffs",
                                        intrinsic ? i : i - cam.model.NumIntrinsics()));
        b.unit.push_back(IsPixelParameter(symbols[static_cast<std::size_t>(i)]) ? 1.0 : 1e-3);
      }
      calib.push_back(b);
    }
    if (c > 0 && cam.config->Estimates(EstimateItem::kExtrinsics)) {
      CalibrationBlock r, t;
      r.values = cam.T_B_C.q();
      t.values = cam.T_B_C.p();
      for (int i = 0; i < 3; ++i) {
        r.names.push_back(ParameterName(name, "R_B_S", i));
        r.unit.push_back(kDeg);
        t.names.push_back(ParameterName(name, "t_B_S", i));
        t.unit.push_back(0.01);
      }
      calib.push_back(r);
      calib.push_back(t);
    }
  }
  Observability obs;
  std::map<std::string, double> sigma_of;
  if (!calib.empty()) {
    const MarginalInformation info = ComputeMarginalInformation(problem, calib, {}, threads);
    const CalibrationCovariance cov = InvertInformation(info);
    result.report_data.correlation =
        CorrelationFromCovariance(cov.covariance, info.names, cov.undetermined);
    // A splined lens's core and control points trade against each other, and its control
    // points outside the observed area are held by the regularisation alone: mrcal judges such a
    // lens by its projection, not per parameter. Its undetermined parameters are counted in one
    // warning instead of one "not determined" each (their sigma stays .inf).
    std::map<std::string, int> regularised;
    for (std::size_t i = 0; i < info.names.size(); ++i) {
      sigma_of[info.names[i]] = cov.undetermined[i] ? std::numeric_limits<double>::infinity()
                                                    : cov.sigma(static_cast<Eigen::Index>(i));
      if (!cov.undetermined[i])
        continue;
      const std::string& n = info.names[i];
      const auto splined = std::find_if(cams.begin(), cams.end(), [&](const auto& cam) {
        return cam->model.mrcal_lens() && cam->model.mrcal_lens()->IsSplined() &&
               n.rfind(cam->config->name + ".intrinsics[", 0) == 0;
      });
      if (splined != cams.end())
        ++regularised[(*splined)->config->name];
      else
        obs.unobservable.push_back(n);
    }
    for (const auto& [name, count] : regularised)
      warn(name + ": " + std::to_string(count) +
           " parameters of its splined lens are set by mrcal's regularisation, not by the data "
           "(sigma .inf): judge the lens by its projection (ctcal compare --projection)");
    for (int col : cov.null_directions) {
      ObservabilityDirection d;
      d.eigenvalue = cov.scaled_eigenvalues(col);
      for (std::size_t i = 0; i < info.names.size(); ++i) {
        const double loading = cov.scaled_eigenvectors(static_cast<Eigen::Index>(i), col);
        if (std::abs(loading) > 0.1)
          d.parameters.push_back({info.names[i], loading});
      }
      obs.directions.push_back(d);
    }
    if (info.nuisance_damping > 0.0)
      warn("some board poses are not determined by their corners (damping " +
           std::to_string(info.nuisance_damping) + ")");
  }

  stages.push_back(clock.Lap("covariance"));

  // Results per camera: values, sigma, weak intrinsics, residuals.
  for (std::size_t c = 0; c < cams.size(); ++c) {
    CameraState& cam = *cams[c];
    SensorConfig& out = *result.rig.Find(cam.config->name);
    out.intrinsics = cam.model.intrinsics();
    out.distortion_coeffs = cam.model.distortion_coeffs();
    if (c > 0)
      out.T_B_S = GetPose(cam.T_B_C).matrix();
    out.sigma = SigmaBlock{};
    auto fill = [&](const std::string& key, int n) {
      std::vector<double> s;
      for (int i = 0; i < n; ++i) {
        const auto it = sigma_of.find(ParameterName(out.name, key, i));
        if (it == sigma_of.end())
          return;
        s.push_back(it->second);
      }
      if (n > 0)
        out.sigma.values[key] = s;
    };
    fill("intrinsics", cam.model.NumIntrinsics());
    fill("distortion_coeffs", cam.model.NumDistortionCoeffs());
    if (c > 0) {
      fill("R_B_S", 3);
      fill("t_B_S", 3);
    }
    const bool splined = cam.model.mrcal_lens() && cam.model.mrcal_lens()->IsSplined();
    if (cam.config->Estimates(EstimateItem::kIntrinsics) && !splined) {
      const int fi = FocalIndex(cam.model);
      std::vector<std::string> weak;
      std::ostringstream why;
      for (int i = fi; i < fi + 2; ++i) {
        const std::string n = ParameterName(out.name, "intrinsics", i);
        const double rel = sigma_of.at(n) / cam.model.params()(i);
        if (rel > options.weak_focal_relative ||
            cam.report.view_spread_deg < options.weak_view_spread_deg)
          weak.push_back(n);
        if (i == fi)
          why << "sigma(f)/f = " << 100.0 * rel << " %, ";
      }
      why << "board normals spread " << cam.report.view_spread_deg << " deg over "
          << cam.views.size() << " views";
      if (!weak.empty()) {
        for (const std::string& n : weak)
          if (std::find(obs.weak.begin(), obs.weak.end(), n) == obs.weak.end())
            obs.weak.push_back(n);
        warn(out.name + ": the views are too alike to determine the focal length (" + why.str() +
             "; weak when above " + std::to_string(100.0 * options.weak_focal_relative) +
             " % or below " + std::to_string(options.weak_view_spread_deg) +
             " deg): tilt the board more between views");
      } else {
        log << "[camera-only] " << out.name << ": intrinsics determined (" << why.str() << ")\n";
      }
    }
    SensorResiduals res;
    res.count = 2 * cam.report.corners;
    if (cam.report.corners > 0) {
      res.rms_px = std::sqrt(sum_px[c] / static_cast<double>(res.count));
      res.rms_whitened = std::sqrt(sum_w[c] / static_cast<double>(res.count));
      log << "[camera-only] " << out.name << ": " << cam.report.corners << " corners, RMS "
          << *res.rms_px << " px, whitened " << *res.rms_whitened << "\n";
    }
    result.rig.residuals[out.name] = res;
    result.cameras[out.name] = cam.report;
  }
  for (const std::string& n : obs.unobservable)
    warn(n + " is not determined by the data (sigma .inf)");
  result.rig.observability = obs;
  result.rig.gravity_W.reset();
  result.rig.sigma_gravity_W.reset();
  SolverSummary solver;
  solver.method = "camera_only";
  solver.iterations = iterations;
  solver.final_cost = final_cost;
  solver.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  result.rig.solver = solver;
  log << "[camera-only] " << report::FormatStageTimes(stages) << "\n";
  return result;
}

}  // namespace ctcal
