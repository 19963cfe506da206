// RefineIntrinsicsAndPoses, the intrinsics initialisation's own Levenberg-Marquardt: on simulated
// board views of every camera model it recovers the truth from a perturbed start, reaches the
// minimum Ceres reaches with the same residual, loss and manifold (the solver it replaced), holds
// the trailing parameters when asked and keeps parameters within their bounds.
#include "../../../calibrator/src/init/intrinsics_refinement.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "../../../calibrator/src/init/corner_reprojection.h"
#include "../residuals/residual_test_utils.h"

namespace ctcal {
namespace {

struct Scene {
  Eigen::VectorXd truth;
  std::vector<ViewState> views;  // true poses
  std::vector<CornerRef> corners;
};

// A 7 x 6 grid of 4 cm squares seen from 24 poses (tilted 10-40 deg, 0.5-0.9 m away); corners
// that project inside a 640 x 480 image (with a margin) are kept, with pixel noise of `noise_px`
// and every 50th corner moved by 6 px (an outlier the Cauchy loss must tolerate).
Scene MakeScene(CameraModelType type, double noise_px, unsigned seed) {
  Scene scene;
  scene.truth = testing::CameraParams(type);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  int count = 0;
  VisitCameraModel(type, [&](auto model) {
    using Model = decltype(model);
    for (int v = 0; v < 24; ++v) {
      const Eigen::Vector3d axis =
          Eigen::Vector3d(uniform(rng), uniform(rng), 0.2 * uniform(rng)).normalized();
      const double angle = (25.0 + 15.0 * uniform(rng)) * M_PI / 180.0;
      const Eigen::Quaterniond q(Eigen::AngleAxisd(angle, axis));
      const Eigen::Vector3d centre(0.05 * uniform(rng), 0.05 * uniform(rng),
                                   0.7 + 0.2 * uniform(rng));
      const ViewState view{q, centre - q * Eigen::Vector3d(0.12, 0.1, 0.0)};
      const int index = static_cast<int>(scene.views.size());
      int seen = 0;
      std::vector<CornerRef> corners;
      for (int i = 0; i < 7; ++i) {
        for (int j = 0; j < 6; ++j) {
          const Eigen::Vector3d p_W(0.04 * i, 0.04 * j, 0.0);
          Eigen::Vector2d uv;
          if (!Model::Project(scene.truth.data(), Eigen::Vector3d(q * p_W + view.t_C_W), &uv,
                              nullptr, nullptr) ||
              uv.x() < 20 || uv.y() < 20 || uv.x() > 620 || uv.y() > 460)
            continue;
          uv += noise_px * Eigen::Vector2d(gauss(rng), gauss(rng));
          if (++count % 50 == 0)
            uv.x() += 6.0;
          corners.push_back({index, p_W, uv});
          ++seen;
        }
      }
      if (seen < 12)
        continue;
      scene.views.push_back(view);
      scene.corners.insert(scene.corners.end(), corners.begin(), corners.end());
    }
  });
  return scene;
}

// The start: focal lengths 3 % long, the distortion at zero (omni's xi, the unified models'
// alpha / beta kept), the poses 1.5 deg and 1.5 cm off.
void Perturb(CameraModelType type, Eigen::VectorXd* params, std::vector<ViewState>* views,
             unsigned seed) {
  const CameraModel camera(type, *params, Eigen::Vector2i(640, 480));
  const std::vector<std::string> names = camera.ParamNames();
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == "fu" || names[i] == "fv")
      (*params)[static_cast<long>(i)] *= 1.03;
    if (static_cast<int>(i) >= camera.NumIntrinsics())
      (*params)[static_cast<long>(i)] = 0.0;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (ViewState& v : *views) {
    const Eigen::Vector3d w(uniform(rng), uniform(rng), uniform(rng));
    v.q_C_W = Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * M_PI / 180.0, w.normalized())) * v.q_C_W;
    v.t_C_W += 0.015 * Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
  }
}

// The refinement as it ran in Ceres before (one thread, sparse normal Cholesky or dense Schur).
void CeresRefine(CameraModelType type, Eigen::VectorXd* params, std::vector<ViewState>* views,
                 const std::vector<CornerRef>& corners, int first_held_param, double* cost) {
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::CauchyLoss loss(2.0);
  for (const CornerRef& c : corners) {
    ViewState& v = (*views)[static_cast<std::size_t>(c.view)];
    ceres::CostFunction* f = VisitCameraModel(type, [&](auto model) {
      return static_cast<ceres::CostFunction*>(
          new CornerReprojection<decltype(model)>(c.p_W, c.uv));
    });
    problem.AddResidualBlock(f, &loss, params->data(), v.q_C_W.coeffs().data(), v.t_C_W.data());
  }
  for (ViewState& v : *views)
    problem.SetManifold(v.q_C_W.coeffs().data(), new ceres::EigenQuaternionManifold);
  if (first_held_param >= 0) {
    std::vector<int> held;
    for (int i = first_held_param; i < params->size(); ++i)
      held.push_back(i);
    problem.SetManifold(params->data(),
                        new ceres::SubsetManifold(static_cast<int>(params->size()), held));
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)
                                   ? ceres::SPARSE_NORMAL_CHOLESKY
                                   : ceres::DENSE_SCHUR;
  options.max_num_iterations = 200;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();
  *cost = summary.final_cost;
}

CameraModel Camera(CameraModelType type, const Eigen::VectorXd& params) {
  return CameraModel(type, params, Eigen::Vector2i(640, 480));
}

std::string Name(CameraModelType type) {
  return CameraModelName(type) + "-" + DistortionModelName(type);
}

Eigen::VectorXd NoBound(long n, double sign) {
  return Eigen::VectorXd::Constant(n, sign * std::numeric_limits<double>::infinity());
}

TEST(IntrinsicsRefinement, RecoversEveryModelFromAPerturbedStart) {
  for (const CameraModelType type : kAllCameraModelTypes) {
    if (type == CameraModelType::kMrcal)
      continue;
    SCOPED_TRACE(Name(type));
    const Scene scene = MakeScene(type, 0.0, 3);
    ASSERT_GE(scene.views.size(), 15u);
    Eigen::VectorXd params = scene.truth;
    std::vector<ViewState> views = scene.views;
    Perturb(type, &params, &views, 5);
    Eigen::VectorXd lower, upper;
    Camera(type, params).ParamBounds(&lower, &upper);
    IntrinsicsRefinementOptions options;
    options.max_iterations = 200;
    // Without the outliers: noiseless corners fit exactly, to the solver's tolerance (a step
    // that changes the cost by 1e-6 of it ends the solve).
    std::vector<CornerRef> inliers;
    for (std::size_t k = 0; k < scene.corners.size(); ++k)
      if ((k + 1) % 50 != 0)
        inliers.push_back(scene.corners[k]);
    const IntrinsicsRefinementSummary s =
        RefineIntrinsicsAndPoses(type, &params, lower, upper, &views, inliers, options);
    ASSERT_TRUE(s.usable);
    EXPECT_LT(s.final_cost, 1e-12 * s.initial_cost);
    for (long i = 0; i < params.size(); ++i)
      EXPECT_NEAR(params[i], scene.truth[i], 1e-5 * std::max(1.0, std::abs(scene.truth[i])))
          << "parameter " << i;
    for (std::size_t v = 0; v < views.size(); ++v) {
      EXPECT_LT(views[v].q_C_W.angularDistance(scene.views[v].q_C_W), 1e-7);
      EXPECT_LT((views[v].t_C_W - scene.views[v].t_C_W).norm(), 1e-7);
    }
  }
}

TEST(IntrinsicsRefinement, ReachesCeresMinimumWithNoiseAndOutliers) {
  for (const CameraModelType type :
       {CameraModelType::kPinholeRadtan, CameraModelType::kPinholeEquidistant,
        CameraModelType::kOmniRadtan, CameraModelType::kDoubleSphere}) {
    SCOPED_TRACE(Name(type));
    const Scene scene = MakeScene(type, 0.3, 11);
    Eigen::VectorXd start = scene.truth;
    std::vector<ViewState> start_views = scene.views;
    Perturb(type, &start, &start_views, 13);
    Eigen::VectorXd lower, upper;
    Camera(type, start).ParamBounds(&lower, &upper);
    for (const int held : {-1, Camera(type, start).NumIntrinsics()}) {
      SCOPED_TRACE(held < 0 ? "all parameters" : "distortion held");
      Eigen::VectorXd own = start, ceres_params = start;
      std::vector<ViewState> own_views = start_views, ceres_views = start_views;
      IntrinsicsRefinementOptions options;
      options.max_iterations = 200;
      options.first_held_param = held;
      const IntrinsicsRefinementSummary s =
          RefineIntrinsicsAndPoses(type, &own, lower, upper, &own_views, scene.corners, options);
      ASSERT_TRUE(s.usable);
      double ceres_cost = 0.0;
      CeresRefine(type, &ceres_params, &ceres_views, scene.corners, held, &ceres_cost);
      // Both stop when a step changes the cost by 1e-6 of it.
      EXPECT_NEAR(s.final_cost, ceres_cost, 2e-6 * ceres_cost);
      for (long i = 0; i < own.size(); ++i) {
        if (held >= 0 && i >= held)
          EXPECT_EQ(own[i], start[i]) << "held parameter " << i;
        else
          EXPECT_NEAR(own[i], ceres_params[i], 2e-4 * std::max(1.0, std::abs(ceres_params[i])))
              << "parameter " << i;
      }
      for (std::size_t v = 0; v < own_views.size(); ++v)
        EXPECT_LT((own_views[v].t_C_W - ceres_views[v].t_C_W).norm(), 1e-5);
    }
  }
}

// A pinhole-radtan scene, its start (perturbed or the truth) and the model's bounds.
struct RadtanProblem {
  RadtanProblem(double noise_px, bool perturb)
      : scene(MakeScene(kType, noise_px, 3)), params(scene.truth), views(scene.views) {
    if (perturb)
      Perturb(kType, &params, &views, 5);
    Camera(kType, params).ParamBounds(&lower, &upper);
  }
  IntrinsicsRefinementSummary Refine(const IntrinsicsRefinementOptions& options) {
    return RefineIntrinsicsAndPoses(kType, &params, lower, upper, &views, scene.corners, options);
  }
  static constexpr CameraModelType kType = CameraModelType::kPinholeRadtan;
  Scene scene;
  Eigen::VectorXd params;
  std::vector<ViewState> views;
  Eigen::VectorXd lower, upper;
};

TEST(IntrinsicsRefinement, ParametersStayWithinTheirBounds) {
  RadtanProblem p(0.0, true);
  p.lower = NoBound(p.params.size(), -1.0);
  p.upper = NoBound(p.params.size(), 1.0);
  p.upper[0] = 0.99 * p.scene.truth[0];  // fu cannot reach the truth
  p.lower[1] = 1.01 * p.scene.truth[1];  // nor fv
  const IntrinsicsRefinementSummary s = p.Refine(IntrinsicsRefinementOptions{});
  ASSERT_TRUE(s.usable);
  EXPECT_EQ(p.params[0], p.upper[0]);
  EXPECT_EQ(p.params[1], p.lower[1]);
  EXPECT_LT(s.final_cost, s.initial_cost);
}

TEST(IntrinsicsRefinement, StopsAfterMaxIterations) {
  RadtanProblem p(0.3, true);
  IntrinsicsRefinementOptions options;
  options.max_iterations = 2;
  const IntrinsicsRefinementSummary s = p.Refine(options);
  ASSERT_TRUE(s.usable);
  EXPECT_EQ(s.iterations, 2);
  EXPECT_LT(s.final_cost, s.initial_cost);
}

TEST(IntrinsicsRefinement, UnprojectableStartIsNotUsable) {
  RadtanProblem p(0.0, false);
  p.views[0].t_C_W.z() -= 5.0;  // the first view's corners behind the camera
  const IntrinsicsRefinementSummary s = p.Refine(IntrinsicsRefinementOptions{});
  EXPECT_FALSE(s.usable);
  EXPECT_EQ(p.params, p.scene.truth);
}

}  // namespace
}  // namespace ctcal
