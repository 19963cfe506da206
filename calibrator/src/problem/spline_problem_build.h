// The continuous-time problem's building (SplineProblem, spline_problem.h): the initial
// trajectory fit, the parameter blocks, the camera, inertial and prior residuals with the
// segments they read. Included through spline_problem_impl.h.
#pragma once

#include "spline_problem.h"

namespace ctcal {
namespace spline_internal {

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::InitializeTrajectory() {
  const auto& poses = prep_.base_poses;
  TrajectoryFit<N, Rep>::SeedKnots(poses, &spline_);
  const PreparedInertial& base = prep_.inertial.front();
  std::vector<BaseRateSample> imu;
  imu.reserve(base.imu.size());
  for (const ImuSample& s : base.imu) {
    BaseRateSample z;
    z.t_ns = s.t_ns;
    base.state->imu->TrueFromRaw(s.w_m, s.a_m, base.state->bias_gyro.Evaluate(s.t_ns),
                                 base.state->bias_accel.Evaluate(s.t_ns), &z.w_I, &z.a_I);
    imu.push_back(z);
  }
  Eigen::Vector3d g_W = state_.gravity();
  TrajectoryFitOptions fit;
  fit.threads = options_.threads;
  const TrajectoryFitReport r = TrajectoryFit<N, Rep>(poses, imu, fit).Run(&spline_, &g_W);
  state_.SetGravity(g_W);
  char line[200];
  std::snprintf(line, sizeof line,
                "  spline fit: %d knots (dt %.4f s) to %zu poses and %zu base IMU samples, cost "
                "%.3e -> %.3e, %d iterations",
                spline_.NumKnots(), spline_.timing().dt_s(), poses.size(), imu.size(),
                r.initial_cost, r.final_cost, r.iterations);
  log_(line);
  LogMemory(log_, "trajectory fitted");
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::Build(bool robust) {
  robust_ = robust;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  // With an evaluation callback Ceres writes every evaluation point into the parameter blocks'
  // memory before evaluating, which the split frames' intrinsic rows read their pose from
  // (frame_corners_residual.h) and the inertial row groups their earlier knots, counting the
  // points (inertial_row_groups.h); without either nothing reads it, so Ceres need not copy.
  const bool any_split = std::any_of(prep_.cameras.begin(), prep_.cameras.end(),
                                     [&](const PreparedCamera& c) { return SplitsFrameRows(c); });
  point_in_memory_used_ = any_split || options_.split_inertial_rows;
  po.evaluation_callback = point_in_memory_used_ ? &point_in_memory_ : nullptr;
  solver_.reset();  // it reads the old problem
  problem_ = std::make_unique<ceres::Problem>(po);
  kept_corners_.clear();
  inertial_ids_.clear();
  camera_ids_.clear();
  inertial_rows_per_sample_.clear();
  prior_ids_.clear();
  segments_.clear();
  ceres::Problem& P = *problem_;

  for (int k = 0; k < spline_.NumKnots(); ++k) {
    double* d = spline_.KnotData(k);
    if constexpr (Rep == Se3Representation::kJoint) {
      P.AddParameterBlock(d, 7, &se3_right_);
    } else {
      P.AddParameterBlock(d, 4, &so3_right_);
      P.AddParameterBlock(d + 4, 3);
    }
  }
  blocks_ = state_.Blocks();
  for (ParameterBlockInfo& b : blocks_) {
    if (b.key == "gravity_W")
      P.AddParameterBlock(b.values, 3, &sphere_);
    else if (b.left_rotation)
      P.AddParameterBlock(b.values, 4, &so3_left_);
    else
      P.AddParameterBlock(b.values, b.ambient_size);
  }

  for (PreparedCamera& cam : prep_.cameras) {
    camera_ids_.emplace_back();
    AddCamera(&cam, robust);
  }
  for (PreparedInertial& in : prep_.inertial)
    AddInertial(in);
  AddPriors();

  // Constant what is not estimated; bounds of the camera models' domains.
  for (ParameterBlockInfo& b : blocks_) {
    if (!P.HasParameterBlock(b.values))
      continue;
    if (!b.estimated)
      P.SetParameterBlockConstant(b.values);
  }
  BoundCameraParameters(prep_.cameras, &P);
  LogMemory(log_, "problem built");
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddCameraFrames(PreparedCamera* cam, bool robust) {
  SensorState& s = *cam->state;
  const bool split = SplitsFrameRows(*cam);
  ForEachFrame(*cam, [&](std::size_t first, std::size_t last) {
    if (!AnyLeft(*cam, first, last))
      return;
    const std::int64_t stamp = cam->Stamp(first);
    const int seg = SegmentOf(stamp, s.time_offset);
    segments_.push_back(seg);
    typename FrameCornersResidual<N, Rep>::Parameters p;
    p.traj = TrajBlocks(seg);
    p.q_B_C = s.q_B_S.data();
    p.t_B_C = s.t_B_S.data();
    p.time_offset = &s.time_offset;
    p.params = s.camera->mutable_params();
    const SegmentClock clock = SegmentClock::At(stamp, spline_.timing(), seg);
    const double huber = robust ? options_.huber_threshold : 0.0;
    // The block reads the frame's corners and board points where Prepare put them (prep_
    // outlives the problem): the corners are held once, not once more per block; a frame with
    // outliers removed reads the rest from kept_corners_ (the problem's).
    const HeldCorner* corners = &cam->corners[first];
    const Eigen::Vector3d* board_W = cam->board_W.data();
    int count = static_cast<int>(last - first);
    if (std::any_of(cam->removed.begin() + static_cast<std::ptrdiff_t>(first),
                    cam->removed.begin() + static_cast<std::ptrdiff_t>(last),
                    [](bool r) { return r; })) {
      std::vector<HeldCorner> kept;
      for (std::size_t i = first; i < last; ++i) {
        if (!cam->removed[i])
          kept.push_back(cam->corners[i]);
      }
      kept_corners_.push_back(std::move(kept));
      corners = kept_corners_.back().data();
      count = static_cast<int>(kept_corners_.back().size());
    }
    const std::vector<double*> blocks = FrameCornersResidual<N, Rep>::Blocks(p);
    std::vector<ceres::ResidualBlockId>& ids = camera_ids_.back();
    if (!split) {
      ids.push_back(problem_->AddResidualBlock(
          MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners, count, board_W, clock, huber),
          nullptr, blocks));
      return;
    }
    ids.push_back(problem_->AddResidualBlock(
        MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners, count, board_W, clock, huber,
                                         FrameRows::kPose),
        nullptr, blocks));
    ids.push_back(problem_->AddResidualBlock(
        MakeFrameCornersResidual<N, Rep>(s.camera->type(), corners, count, board_W, clock, huber,
                                         FrameRows::kIntrinsics, blocks),
        nullptr, p.params));
  });
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddCamera(PreparedCamera* cam, bool robust) {
  if (Compressed(*cam)) {
    AddCameraFrames(cam, robust);
    return;
  }
  SensorState& s = *cam->state;
  ceres::LossFunction* loss = nullptr;
  for (std::size_t i = 0; i < cam->corners.size(); ++i) {
    if (cam->removed[i])
      continue;
    const std::int64_t stamp = cam->Stamp(i);
    const int seg = SegmentOf(stamp, s.time_offset + cam->corners[i].uv.y() * s.line_delay);
    segments_.push_back(seg);
    const SegmentClock clock = SegmentClock::At(stamp, spline_.timing(), seg);
    typename CornerResidual<N, Rep>::Parameters p;
    p.traj = TrajBlocks(seg);
    p.q_B_C = s.q_B_S.data();
    p.t_B_C = s.t_B_S.data();
    p.time_offset = &s.time_offset;
    p.line_delay = &s.line_delay;
    p.params = s.camera->mutable_params();
    ceres::CostFunction* cost =
        MakeCameraCornerResidual<N, Rep>(options_.analytic, *s.camera, cam->Measurement(i), clock);
    if (robust)
      loss = new ceres::HuberLoss(options_.huber_threshold);
    camera_ids_.back().push_back(
        problem_->AddResidualBlock(cost, loss, CornerResidual<N, Rep>::Blocks(p)));
  }
  AddLensRegularization(*cam);
}

// mrcal's regularisation of an mrcal lens (residuals/mrcal_regularization.h), as in the
// camera-only problem: a data term of its own (not a prior on the rig file's values), scaled to
// the camera's corners, so the covariance keeps it.
template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddLensRegularization(const PreparedCamera& cam) {
  SensorState& s = *cam.state;
  const MrcalLens* lens = s.camera->mrcal_lens();
  if (lens == nullptr || !s.config.Estimates(EstimateItem::kIntrinsics))
    return;
  const double measurements =
      2.0 * static_cast<double>(std::count(cam.removed.begin(), cam.removed.end(), false));
  auto cost = std::make_unique<MrcalRegularizationCost>(
      lens->MakeRegularization(s.camera->resolution(), measurements));
  if (cost->NumTerms() > 0)
    problem_->AddResidualBlock(cost.release(), nullptr, s.camera->mutable_params());
}

template <int N, Se3Representation Rep>
template <class F>
void SplineProblem<N, Rep>::VisitSamples(PreparedInertial& in, F&& f) {
  SensorState& s = *in.state;
  const InertialNoise& noise = s.config.noise;
  const double shift = s.is_base ? 0.0 : s.time_offset;
  // The sample on its segments (InertialBlockResidual places held samples the same way).
  const auto place = [&](const auto& z, auto* set, auto* setup) {
    const int seg = SegmentOf(z.t_ns, shift);
    const int bseg = BiasSegmentOf(s.bias_gyro, z.t_ns);
    set->seg.push_back(seg);
    set->bseg.push_back(bseg);
    PlaceSample(z, SegmentClock::At(z.t_ns, spline_.timing(), seg),
                SegmentClock::At(z.t_ns, s.bias_gyro.timing, bseg), setup);
  };
  const auto imu_set = [&](auto* set) {
    set->sizes = std::decay_t<decltype(*set)>::Residual::BlockSizes(s.imu->layout());
    set->raw = in.imu.data();
    set->functors.reserve(in.imu.size());
    ImuSampleSetup setup;
    setup.layout = s.imu->layout();
    const ImuWhitening W = ImuWhitening::Of(noise);
    for (const ImuSample& z : in.imu) {
      place(z, set, &setup);
      // The sample's noise window's own level (the noise estimation; 1 before it).
      setup.W.inv_sigma_gyro = W.inv_sigma_gyro / in.GyroScale(set->bseg.back());
      setup.W.inv_sigma_accel = W.inv_sigma_accel / in.AccelScale(set->bseg.back());
      set->functors.emplace_back(setup);
    }
  };
  if (!in.imu.empty() && s.is_base) {
    using R = BaseImuResidual<N, Rep, Nb>;
    SampleSetOf<R> set;
    imu_set(&set);
    f(set, [&](int seg, int bseg) {
      typename R::Parameters p;
      p.traj = TrajBlocks(seg);
      p.g_W = state_.g_W();
      p.bg = BiasBlocks(s.bias_gyro, bseg);
      p.ba = BiasBlocks(s.bias_accel, bseg);
      p.intrinsics = &*s.imu;
      return R::Blocks(p);
    });
  } else if (!in.imu.empty()) {
    using R = AuxImuResidual<N, Rep, Nb>;
    SampleSetOf<R> set;
    imu_set(&set);
    f(set, [&](int seg, int bseg) {
      typename R::Parameters p;
      p.traj = TrajBlocks(seg);
      p.g_W = state_.g_W();
      p.q_B_S = s.q_B_S.data();
      p.t_B_S = s.t_B_S.data();
      p.time_offset = &s.time_offset;
      p.bg = BiasBlocks(s.bias_gyro, bseg);
      p.ba = BiasBlocks(s.bias_accel, bseg);
      p.intrinsics = &*s.imu;
      return R::Blocks(p);
    });
  }
  if (!in.gyro.empty()) {
    using R = AuxGyroResidual<N, Rep, Nb>;
    SampleSetOf<R> set;
    set.sizes = R::BlockSizes(s.gyro->model());
    set.raw = in.gyro.data();
    set.functors.reserve(in.gyro.size());
    GyroSampleSetup setup;
    setup.model = s.gyro->model();
    setup.inv_sigma = 1.0 / noise.GyroSampleSigma();
    const double inv_sigma = setup.inv_sigma;
    for (const GyroSample& z : in.gyro) {
      place(z, &set, &setup);
      setup.inv_sigma = inv_sigma / in.GyroScale(set.bseg.back());
      set.functors.push_back(typename R::Functor{setup});
    }
    f(set, [&](int seg, int bseg) {
      typename R::Parameters p;
      p.traj = TrajBlocks(seg);
      p.q_B_S = s.q_B_S.data();
      p.time_offset = &s.time_offset;
      p.bg = BiasBlocks(s.bias_gyro, bseg);
      p.intrinsics = &*s.gyro;
      return R::Blocks(p);
    });
  }
}

template <int N, Se3Representation Rep>
template <class Set>
int SplineProblem<N, Rep>::InertialSegments(const Set& set,
                                            const std::vector<double*>& common) const {
  using R = typename Set::Residual;
  if (!options_.analytic || !options_.compress_inertial || set.seg.size() < 2)
    return 0;
  if (options_.inertial_block_segments > 0)
    return std::min(options_.inertial_block_segments, 255);
  const double span_segments = static_cast<double>(set.seg.back() - set.seg.front() + 1);
  const double per_segment = static_cast<double>(set.seg.size()) / span_segments;
  int cols = 0, rank = 0;
  for (std::size_t b = R::kNumTrajBlocks; b < set.sizes.size(); ++b) {
    cols += set.sizes[b];
    rank += CommonRank(common[b - R::kNumTrajBlocks], set.sizes[b]);
  }
  return InertialBlockSegments(per_segment, R::kNumResiduals, N, cols, rank);
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddInertial(PreparedInertial& in) {
  SensorState& s = *in.state;
  const InertialNoise& noise = s.config.noise;
  std::vector<ceres::ResidualBlockId> ids;
  bool per_sample = true;
  VisitSamples(in, [&](auto& set, auto&& blocks_of) {
    using R = typename std::decay_t<decltype(set)>::Residual;
    segments_.insert(segments_.end(), set.seg.begin(), set.seg.end());
    const std::size_t count = set.functors.size();
    std::vector<double*> first = blocks_of(set.seg.front(), set.bseg.front());
    const std::vector<double*> common(first.begin() + R::kNumTrajBlocks, first.end());
    const int compressed = InertialSegments(set, common);
    const bool stacked = compressed == 0 && options_.analytic && options_.compress_inertial &&
                         options_.stacked_inertial_segments > 0;
    const int K = stacked ? std::min(options_.stacked_inertial_segments, 255) : compressed;
    per_sample = per_sample && (K == 0 || stacked);
    if (K == 0) {
      for (std::size_t i = 0; i < count; ++i) {
        const typename R::Setup& setup = set.functors[i].s;
        ceres::CostFunction* cost =
            options_.analytic ? new typename R::Analytic(setup) : R::MakeAutoDiff(setup);
        ids.push_back(
            problem_->AddResidualBlock(cost, nullptr, blocks_of(set.seg[i], set.bseg[i])));
      }
      return;
    }
    // The row groups of the last runs, added interleaved (AddRowGroups).
    std::vector<std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>> batch;
    // Runs of at most K segments whose samples share one bias segment.
    std::size_t begin = 0;
    while (begin < count) {
      std::size_t end = begin + 1;
      while (end < count && set.bseg[end] == set.bseg[begin] && set.seg[end] - set.seg[begin] < K &&
             set.seg[end] >= set.seg[end - 1])
        ++end;
      const int first_seg = set.seg[begin];
      const int num_segments = set.seg[end - 1] - first_seg + 1;
      // The block reads its samples where Prepare put them (prep_ outlives the problem).
      HeldInertialSamples<typename InertialBlockResidual<R>::Raw> held;
      held.samples = set.raw + begin;
      held.trajectory = spline_.timing();
      held.first_segment = first_seg;
      held.bias = s.bias_gyro.timing;
      held.bias_segment = set.bseg[begin];
      std::vector<std::uint8_t> offsets;
      for (std::size_t i = begin; i < end; ++i)
        offsets.push_back(static_cast<std::uint8_t>(set.seg[i] - first_seg));
      const std::vector<double*> sample = blocks_of(first_seg, set.bseg[begin]);
      std::vector<double*> blocks =
          InertialBlockResidual<R>::TrajectoryBlocks(spline_, first_seg, num_segments);
      std::vector<const ceres::Manifold*> manifolds;
      for (std::size_t b = R::kNumTrajBlocks; b < sample.size(); ++b) {
        blocks.push_back(sample[b]);
        manifolds.push_back(LiftedManifold(sample[b]));
      }
      auto whole = std::make_unique<InertialBlockResidual<R>>(set.functors[begin], held,
                                                              std::move(offsets), num_segments,
                                                              set.sizes, manifolds, 0.0, stacked);
      begin = end;
      if (stacked || !options_.split_inertial_rows) {
        ids.push_back(problem_->AddResidualBlock(whole.release(), nullptr, blocks));
        continue;
      }
      // The factor's rows in groups over the blocks they touch (inertial_row_groups.h).
      const int num_knot_blocks = static_cast<int>(blocks.size() - manifolds.size());
      const std::vector<InertialRowGroupLayout> groups =
          InertialRowGroups(whole->TangentColumns(), num_knot_blocks, whole->num_residuals());
      const auto run = std::make_shared<SharedInertialRun>(std::move(whole), blocks,
                                                           &point_in_memory_.generation);
      auto& added = batch.emplace_back();
      for (const InertialRowGroupLayout& g : groups) {
        added.emplace_back(new InertialRowGroup(run, g.first_block, g.row0, g.rows,
                                                static_cast<int>(groups.size())),
                           std::vector<double*>(blocks.begin() + g.first_block, blocks.end()));
      }
      if (static_cast<int>(batch.size()) >= std::max(1, options_.threads) || begin == count)
        AddRowGroups(&batch, &ids);
    }
  });
  // Bias random walks between consecutive knots (these are part of the inertial model, kept
  // with the sensor's residuals but not in its residual statistics).
  const double dt_b = s.bias_gyro.timing.dt_s();
  for (int k = 0; k + 1 < s.bias_gyro.NumKnots(); ++k) {
    problem_->AddResidualBlock(
        MakeBiasRandomWalkResidual(options_.analytic, noise.gyroscope_random_walk, dt_b), nullptr,
        s.bias_gyro.Knot(k), s.bias_gyro.Knot(k + 1));
  }
  for (int k = 0; k + 1 < s.bias_accel.NumKnots(); ++k) {
    problem_->AddResidualBlock(
        MakeBiasRandomWalkResidual(options_.analytic, noise.accelerometer_random_walk, dt_b),
        nullptr, s.bias_accel.Knot(k), s.bias_accel.Knot(k + 1));
  }
  inertial_ids_.emplace_back(s.name(), std::move(ids));
  inertial_rows_per_sample_.push_back(per_sample);
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddRowGroups(
    std::vector<std::vector<std::pair<ceres::CostFunction*, std::vector<double*>>>>* batch,
    std::vector<ceres::ResidualBlockId>* ids) {
  std::size_t most = 0;
  for (const auto& run : *batch)
    most = std::max(most, run.size());
  for (std::size_t k = 0; k < most; ++k) {
    for (const auto& run : *batch) {
      if (k < run.size())
        ids->push_back(problem_->AddResidualBlock(run[k].first, nullptr, run[k].second));
    }
  }
  batch->clear();
}

template <int N, Se3Representation Rep>
void SplineProblem<N, Rep>::AddPriors() {
  if (prior_center_.empty()) {
    // On the rig file's values, not on the initialisation's (coarse_init.h): same block order.
    CalibrationState guess(state_.rig());
    for (const ParameterBlockInfo& b : guess.Blocks())
      prior_center_.emplace_back(b.values, b.values + b.ambient_size);
  }
  const std::vector<ceres::ResidualBlockId> ids =
      AddCalibrationPriors(problem_.get(), blocks_, prior_center_, options_.analytic);
  prior_ids_.insert(prior_ids_.end(), ids.begin(), ids.end());
}

}  // namespace spline_internal
}  // namespace ctcal
