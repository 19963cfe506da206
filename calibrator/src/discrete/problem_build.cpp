// The discrete problem's building (discrete_problem.h): preintegration factors of the base IMU,
// interpolated auxiliary inertial residuals, and camera residuals at their keyframe slots.
#include "discrete_problem.h"

namespace ctcal {
namespace discrete_internal {

void DiscreteProblem::Build(bool robust) {
  robust_ = robust;
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_ = std::make_unique<ceres::Problem>(po);
  corner_slots_.clear();
  inertial_ids_.clear();
  slots_.clear();
  ceres::Problem& P = *problem_;
  blocks_ = state_.Blocks();
  if (prior_center_.empty()) {
    // On the rig file's values, not on the initialisation's (coarse_init.h), as the spline's.
    CalibrationState guess(state_.rig());
    for (const ParameterBlockInfo& b : guess.Blocks())
      prior_center_.emplace_back(b.values, b.values + b.ambient_size);
  }
  for (ParameterBlockInfo& b : blocks_) {
    if (b.key == "gravity_W")
      P.AddParameterBlock(b.values, 3, &sphere_);
    else if (b.left_rotation)
      P.AddParameterBlock(b.values, 4, &so3_left_);
    else
      P.AddParameterBlock(b.values, b.ambient_size);
  }
  for (Keyframe& k : kf_)
    P.AddParameterBlock(k.q_W_B.data(), 4, &so3_left_);

  AddBaseImu();
  for (AuxStates& a : aux_)
    AddAux(&a);
  for (PreparedCamera& cam : prep_.cameras)
    AddCamera(&cam, robust);
  prior_ids_ = spline_internal::AddCalibrationPriors(problem_.get(), blocks_, prior_center_,
                                                     spline_options_.analytic);

  // Constant: every calibration block not estimated (also those only a residual reads, e.g. a
  // global-shutter camera's line delay or the base intrinsics of an A.1 interpolation).
  std::set<double*> estimated;
  for (const ParameterBlockInfo& b : blocks_) {
    if (b.estimated)
      estimated.insert(b.values);
  }
  for (double* p : calib_ptrs_) {
    if (P.HasParameterBlock(p) && estimated.count(p) == 0)
      P.SetParameterBlockConstant(p);
  }
  for (const ParameterBlockInfo& b : blocks_) {
    if (P.HasParameterBlock(b.values) && !b.estimated)
      P.SetParameterBlockConstant(b.values);
  }
  spline_internal::BoundCameraParameters(prep_.cameras, &P);
}

RawImuSample DiscreteProblem::RawAt(const std::vector<RawImuSample>& s, double t) {
  const auto it = std::upper_bound(s.begin(), s.end(), t,
                                   [](double x, const RawImuSample& r) { return x < r.t; });
  const std::size_t k = static_cast<std::size_t>(std::max<std::ptrdiff_t>(
      0, std::min<std::ptrdiff_t>(it - s.begin() - 1, static_cast<std::ptrdiff_t>(s.size()) - 2)));
  return discrete::detail::InterpolateRaw(s, k, t);
}

bool DiscreteProblem::BaseIntrinsicsEstimated() const {
  for (const ParameterBlockInfo& b : blocks_) {
    if (b.sensor == state_.base().name() && b.estimated)
      return true;
  }
  return false;
}

void DiscreteProblem::AddBaseImu() {
  SensorState& s = state_.base();
  ImuIntrinsics& intr = *s.imu;
  const InertialNoise& noise = s.config.noise;
  const bool reintegrate = BaseIntrinsicsEstimated();
  std::vector<ceres::ResidualBlockId> ids;
  for (double* p : {intr.Dw(), intr.Da(), intr.Tg(), intr.q_rotation()}) {
    if (p != nullptr)
      calib_ptrs_.insert(p);
  }
  for (std::size_t k = 0; k + 1 < kf_.size(); ++k) {
    Keyframe& a = kf_[k];
    Keyframe& b = kf_[k + 1];
    auto pre = std::make_shared<Preintegration>(base_samples_, a.t, b.t, intr, noise,
                                                Eigen::Vector3d(a.b_g.data()),
                                                Eigen::Vector3d(a.b_a.data()));
    std::vector<double*> blocks{a.q_W_B.data(), a.p_W_B.data(), a.v_W.data(),
                                a.b_g.data(),   a.b_a.data(),   b.q_W_B.data(),
                                b.p_W_B.data(), b.v_W.data(),   state_.g_W()};
    ceres::CostFunction* cost = nullptr;
    if (reintegrate) {
      for (double* p : {intr.Dw(), intr.Da(), intr.Tg(), intr.q_rotation()}) {
        if (p != nullptr)
          blocks.push_back(p);
      }
      cost = discrete::ReintegrationFactor::CreateSplit(pre, intr);
    } else {
      cost = discrete::PreintegrationFactor::Create(pre);
    }
    ids.push_back(problem_->AddResidualBlock(cost, nullptr, blocks));
    const double dt = b.t - a.t;
    problem_->AddResidualBlock(MakeBiasRandomWalkResidual(true, noise.gyroscope_random_walk, dt),
                               nullptr, a.b_g.data(), b.b_g.data());
    problem_->AddResidualBlock(
        MakeBiasRandomWalkResidual(true, noise.accelerometer_random_walk, dt), nullptr,
        a.b_a.data(), b.b_a.data());
  }
  inertial_ids_.emplace_back(s.name(), std::move(ids));
}

void DiscreteProblem::AddAux(AuxStates* a) {
  SensorState& s = *a->in->state;
  SensorState& base = state_.base();
  const InertialNoise& noise = s.config.noise;
  const bool imu = s.config.type == SensorType::kImu;
  const bool rigid = options_.aux_velocity == AuxVelocityModel::kRigid;
  a->time_offset_at_build = s.time_offset;
  std::vector<ceres::ResidualBlockId> ids;
  calib_ptrs_.insert(s.q_B_S.data());
  calib_ptrs_.insert(s.t_B_S.data());
  calib_ptrs_.insert(&s.time_offset);
  if (imu) {
    for (double* p : {s.imu->Dw(), s.imu->Da(), s.imu->Tg(), s.imu->q_rotation()}) {
      if (p != nullptr)
        calib_ptrs_.insert(p);
    }
  } else if (s.gyro->Dw() != nullptr) {
    calib_ptrs_.insert(s.gyro->Dw());
  }
  for (std::size_t k = 0; k + 1 < kf_.size(); ++k) {
    const double tau_i = kf_[k].t - s.time_offset;
    const double tau_j = kf_[k + 1].t - s.time_offset;
    BlockList list;
    const BaseSource src_i = BaseSource::Add(&list, &kf_[k], nullptr, &*base.imu, state_.g_W());
    const BaseSource src_j = BaseSource::Add(&list, &kf_[k + 1], nullptr, &*base.imu, state_.g_W());
    ceres::CostFunction* cost = nullptr;
    if (imu) {
      AuxImuIndex ix;
      ix.intr = ImuBlockIndex::Add(&list, &*s.imu);
      ix.q_B_A = list.Add(s.q_B_S.data(), 4);
      ix.t_B_A = list.Add(s.t_B_S.data(), 3);
      ix.time_offset = list.Add(&s.time_offset, 1);
      if (!rigid) {
        ix.v_i = list.Add(a->v[k].data(), 3);
        ix.v_j = list.Add(a->v[k + 1].data(), 3);
      }
      ix.bg = list.Add(a->bg[k].data(), 3);
      ix.ba = list.Add(a->ba[k].data(), 3);
      auto pre = std::make_shared<Preintegration>(a->samples, tau_i, tau_j, *s.imu, noise,
                                                  Eigen::Vector3d(a->bg[k].data()),
                                                  Eigen::Vector3d(a->ba[k].data()));
      cost = discrete::MakeSplitIntegration(AuxImuFunctor{pre, src_i, src_j, ix}, list, 9);
    } else {
      AuxGyroIndex ix;
      ix.model = s.gyro->model();
      if (s.gyro->Dw() != nullptr)
        ix.Dw = list.Add(s.gyro->Dw(), s.gyro->DwSize());
      ix.q_B_G = list.Add(s.q_B_S.data(), 4);
      ix.time_offset = list.Add(&s.time_offset, 1);
      ix.bg = list.Add(a->bg[k].data(), 3);
      auto pre = std::make_shared<GyroPreintegration>(a->samples, tau_i, tau_j, *s.gyro, noise,
                                                      Eigen::Vector3d(a->bg[k].data()));
      cost = discrete::MakeSplitIntegration(AuxGyroFunctor{pre, src_i, src_j, ix}, list, 3);
    }
    ids.push_back(problem_->AddResidualBlock(cost, nullptr, list.blocks()));
    const double dt = tau_j - tau_i;
    problem_->AddResidualBlock(MakeBiasRandomWalkResidual(true, noise.gyroscope_random_walk, dt),
                               nullptr, a->bg[k].data(), a->bg[k + 1].data());
    if (imu)
      problem_->AddResidualBlock(
          MakeBiasRandomWalkResidual(true, noise.accelerometer_random_walk, dt), nullptr,
          a->ba[k].data(), a->ba[k + 1].data());
  }
  inertial_ids_.emplace_back(s.name(), std::move(ids));
}

double DiscreteProblem::CornerTime(const PreparedCamera& cam, std::size_t i) const {
  const SensorState& s = *cam.state;
  return 1e-9 * static_cast<double>(cam.Stamp(i) - prep_.t0_ns) + s.time_offset +
         cam.corners[i].uv.y() * s.line_delay;
}

CornerSlot DiscreteProblem::SlotOf(double t) const {
  const auto it = std::lower_bound(kf_.begin(), kf_.end(), t,
                                   [](const Keyframe& k, double x) { return k.t < x; });
  const int hi = static_cast<int>(it - kf_.begin());
  int nearest = hi;
  if (hi == static_cast<int>(kf_.size()) || (hi > 0 && t - kf_[hi - 1].t < kf_[hi].t - t))
    nearest = hi - 1;
  CornerSlot slot;
  if (std::abs(t - kf_[nearest].t) <= options_.kinematic_window_s) {
    slot.k = nearest;
    slot.kinematic = true;
  } else if (hi > 0 && hi < static_cast<int>(kf_.size())) {
    slot.k = hi - 1;
    slot.kinematic = false;
  }
  return slot;
}

ceres::CostFunction* DiscreteProblem::CornerCost(PreparedCamera* cam, std::size_t i,
                                                 const CornerSlot& slot, BlockList* list) {
  SensorState& s = *cam->state;
  const std::size_t k = static_cast<std::size_t>(slot.k);
  const BaseSource src = BaseSource::Add(list, &kf_[k], slot.kinematic ? nullptr : &kf_[k + 1],
                                         &*state_.base().imu, state_.g_W());
  CornerIndex c;
  c.q_B_C = list->Add(s.q_B_S.data(), 4);
  c.t_B_C = list->Add(s.t_B_S.data(), 3);
  c.time_offset = list->Add(&s.time_offset, 1);
  c.line_delay = list->Add(&s.line_delay, 1);
  c.params = list->Add(s.camera->mutable_params(), s.camera->NumParams());
  return discrete::MakeDiscreteCorner(s.camera->type(), cam->Measurement(i), Stamp(*cam, i), src, c,
                                      *list);
}

double DiscreteProblem::Stamp(const PreparedCamera& cam, std::size_t i) const {
  return 1e-9 * static_cast<double>(cam.Stamp(i) - prep_.t0_ns);
}

bool DiscreteProblem::EvaluateCorner(const PreparedCamera& cam, std::size_t i,
                                     const CornerSlot& slot, Eigen::Vector2d* e) {
  BlockList list;
  const std::unique_ptr<ceres::CostFunction> cost(
      CornerCost(const_cast<PreparedCamera*>(&cam), i, slot, &list));
  return cost->Evaluate(list.blocks().data(), e->data(), nullptr) && e->allFinite();
}

bool DiscreteProblem::Compressed(const PreparedCamera& cam) const {
  const SensorState& s = *cam.state;
  return options_.compress_frames && !s.config.Estimates(EstimateItem::kLineDelay) &&
         s.line_delay == 0.0;
}

void DiscreteProblem::AddCamera(PreparedCamera* cam, bool robust) {
  SensorState& s = *cam->state;
  std::vector<std::pair<std::size_t, CornerSlot>> in_problem;
  for (double* p :
       {s.q_B_S.data(), s.t_B_S.data(), &s.time_offset, &s.line_delay, s.camera->mutable_params()})
    calib_ptrs_.insert(p);
  for (std::size_t i = 0; i < cam->corners.size(); ++i) {
    if (cam->removed[i])
      continue;
    const CornerSlot slot = SlotOf(CornerTime(*cam, i));
    slots_.push_back(slot);
    if (slot.k >= 0)
      in_problem.emplace_back(i, slot);
  }
  if (Compressed(*cam)) {
    AddCameraFrames(cam, in_problem, robust);
  } else {
    for (const auto& [i, slot] : in_problem) {
      BlockList list;
      ceres::CostFunction* cost = CornerCost(cam, i, slot, &list);
      ceres::LossFunction* loss = robust ? new ceres::HuberLoss(options_.huber_threshold) : nullptr;
      problem_->AddResidualBlock(cost, loss, list.blocks());
    }
  }
  corner_slots_.push_back(std::move(in_problem));
}

void DiscreteProblem::AddCameraFrames(
    PreparedCamera* cam, const std::vector<std::pair<std::size_t, CornerSlot>>& in_problem,
    bool robust) {
  SensorState& s = *cam->state;
  std::size_t first = 0;
  while (first < in_problem.size()) {
    const std::size_t i0 = in_problem[first].first;
    const CornerSlot slot = in_problem[first].second;
    std::size_t last = first + 1;
    while (last < in_problem.size() &&
           cam->corners[in_problem[last].first].frame == cam->corners[i0].frame)
      ++last;
    std::vector<CornerMeasurement> corners;
    for (std::size_t j = first; j < last; ++j)
      corners.push_back(cam->Measurement(in_problem[j].first));
    BlockList list;
    const std::size_t k = static_cast<std::size_t>(slot.k);
    const BaseSource src = BaseSource::Add(&list, &kf_[k], slot.kinematic ? nullptr : &kf_[k + 1],
                                           &*state_.base().imu, state_.g_W());
    discrete::FramePoseIndex c;
    c.q_B_C = list.Add(s.q_B_S.data(), 4);
    c.t_B_C = list.Add(s.t_B_S.data(), 3);
    c.time_offset = list.Add(&s.time_offset, 1);
    list.Add(s.camera->mutable_params(), s.camera->NumParams());
    problem_->AddResidualBlock(
        discrete::MakeDiscreteFrameCorners(s.camera->type(), std::move(corners), Stamp(*cam, i0),
                                           src, c, list, robust ? options_.huber_threshold : 0.0),
        nullptr, list.blocks());
    first = last;
  }
}

}  // namespace discrete_internal
}  // namespace ctcal
