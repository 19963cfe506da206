// Initial guesses: table4 draws errors with the report's sigmas and writes them as prior_sigma;
// coarse is a drawing's guess within its stated bounds.
#include <gtest/gtest.h>

#include <cmath>

#include "ctcal/sensors/rig_yaml.h"
#include "ctcal/sim/default_rig.h"
#include "ctcal/sim/perturb.h"
#include "ctcal/spline/so3.h"

namespace ctcal::sim {
namespace {

Eigen::Vector3d RotationError(const Eigen::Matrix3d& R_guess, const Eigen::Matrix3d& R_true) {
  // Left perturbation R_guess = Exp(d) R_true (SPEC section 7).
  return LogSO3<double>(Eigen::Quaterniond(R_guess * R_true.transpose()));
}

// Accumulates (guess - truth) / sigma over many draws; its RMS must be ~1.
struct Whitened {
  double sum2 = 0.0;
  int n = 0;
  void Add(double error, double sigma) {
    sum2 += (error / sigma) * (error / sigma);
    ++n;
  }
  double Rms() const { return std::sqrt(sum2 / n); }
};

TEST(Perturb, Table4DrawsTheReportSigmasAndWritesThemAsPriors) {
  const RigConfig truth = DefaultRig();
  std::map<std::string, Whitened> by_key;
  for (int draw = 0; draw < 300; ++draw) {
    Random rng = Random(draw).Fork(5);
    const RigConfig guess = PerturbRig(truth, Perturbation::kTable4, rng);
    if (draw == 0) {
      EXPECT_NO_THROW(ValidateRig(guess, "table4 guess"));
    }
    for (const SensorConfig& t : truth.sensors) {
      const SensorConfig& g = *guess.Find(t.name);
      const auto& prior = g.prior_sigma.values;
      const auto sigma = [&](const std::string& key) {
        const auto it = prior.find(key);
        EXPECT_NE(it, prior.end()) << t.name << " " << key;
        return it == prior.end() ? std::vector<double>{} : it->second;
      };
      if (t.IsInertial()) {
        const auto s_dw = sigma("Dw");
        for (std::size_t i = 0; i < t.D_w.size() && i < s_dw.size(); ++i)
          by_key["Dw"].Add(g.D_w[i] - t.D_w[i], s_dw[i]);
        EXPECT_EQ(s_dw, std::vector<double>(t.D_w.size(), 0.003));
      }
      if (t.type == SensorType::kImu) {
        const auto s_da = sigma("Da"), s_tg = sigma("Tg"), s_r = sigma("R_I_a");
        for (std::size_t i = 0; i < t.D_a.size(); ++i)
          by_key["Da"].Add(g.D_a[i] - t.D_a[i], s_da.at(i));
        for (std::size_t i = 0; i < t.T_g.size(); ++i)
          by_key["Tg"].Add(g.T_g[i] - t.T_g[i], s_tg.at(i));
        const Eigen::Vector3d d = RotationError(g.R_I_a, t.R_I_a);
        for (int i = 0; i < 3; ++i)
          by_key["R_I_a"].Add(d[i], s_r.at(i));
        EXPECT_EQ(s_tg, std::vector<double>(9, 0.001));
      }
      if (t.type == SensorType::kCamera) {
        const auto s_i = sigma("intrinsics"), s_d = sigma("distortion_coeffs");
        EXPECT_EQ(s_i, std::vector<double>(4, 1.0));
        EXPECT_EQ(s_d, std::vector<double>(4, 0.002));
        for (std::size_t i = 0; i < 4; ++i) {
          by_key["intrinsics"].Add(g.intrinsics[i] - t.intrinsics[i], s_i.at(i));
          by_key["distortion"].Add(g.distortion_coeffs[i] - t.distortion_coeffs[i], s_d.at(i));
        }
      }
      if (t.name == truth.base_imu) {
        EXPECT_EQ(prior.count("R_B_S") + prior.count("t_B_S") + prior.count("time_offset"), 0u);
        continue;
      }
      const std::string kind = t.type == SensorType::kCamera ? "camera" : "inertial";
      const auto s_r = sigma("R_B_S"), s_t = sigma("t_B_S"), s_o = sigma("time_offset");
      EXPECT_EQ(s_r.at(0), kind == "camera" ? 0.004 : 0.003);
      EXPECT_EQ(s_t.at(0), kind == "camera" ? 0.008 : 0.005);
      EXPECT_EQ(s_o.at(0), kind == "camera" ? 0.008 : 0.003);
      const Eigen::Vector3d dr =
          RotationError(g.T_B_S.topLeftCorner<3, 3>(), t.T_B_S.topLeftCorner<3, 3>());
      const Eigen::Vector3d dt = g.T_B_S.topRightCorner<3, 1>() - t.T_B_S.topRightCorner<3, 1>();
      for (int i = 0; i < 3; ++i) {
        by_key[kind + ".R_B_S"].Add(dr[i], s_r.at(i));
        by_key[kind + ".t_B_S"].Add(dt[i], s_t.at(i));
      }
      by_key[kind + ".time_offset"].Add(g.time_offset - t.time_offset, s_o.at(0));
    }
  }
  // >= 600 draws per key: the RMS of a standard normal sample is within ~3 % (1 sigma) of 1.
  for (const auto& [key, w] : by_key) {
    EXPECT_GE(w.n, 600) << key;
    EXPECT_NEAR(w.Rms(), 1.0, 0.12) << key;
  }
  EXPECT_EQ(by_key.size(), 12u);
}

TEST(Perturb, CoarseIsADrawingsGuess) {
  const RigConfig truth = DefaultRig();
  for (int draw = 0; draw < 50; ++draw) {
    Random rng(draw);
    const RigConfig guess = PerturbRig(truth, Perturbation::kCoarse, rng);
    if (draw == 0) {
      EXPECT_NO_THROW(ValidateRig(guess, "coarse guess"));
    }
    for (const SensorConfig& t : truth.sensors) {
      const SensorConfig& g = *guess.Find(t.name);
      EXPECT_TRUE(g.prior_sigma.empty());
      if (t.IsInertial()) {
        EXPECT_EQ(g.D_w, IdentityStored(t.D_w.size()));
        EXPECT_TRUE(g.R_I_a.isIdentity(0.0));
      }
      if (t.type == SensorType::kImu) {
        EXPECT_EQ(g.D_a, IdentityStored(6));
        EXPECT_EQ(g.T_g, std::vector<double>(9, 0.0));
      }
      if (t.type == SensorType::kCamera) {
        for (int i = 0; i < 2; ++i)
          EXPECT_NEAR(std::abs(g.intrinsics[i] / t.intrinsics[i] - 1.0), 0.05, 1e-12);
        EXPECT_EQ(g.intrinsics[2], 0.5 * (t.width - 1));
        EXPECT_EQ(g.intrinsics[3], 0.5 * (t.height - 1));
        EXPECT_EQ(g.distortion_coeffs, std::vector<double>(4, 0.0));
      }
      if (t.name == truth.base_imu)
        continue;
      EXPECT_EQ(g.time_offset, 0.0);
      const double angle =
          RotationError(g.T_B_S.topLeftCorner<3, 3>(), t.T_B_S.topLeftCorner<3, 3>()).norm();
      const double dist = (g.T_B_S.topRightCorner<3, 1>() - t.T_B_S.topRightCorner<3, 1>()).norm();
      EXPECT_LE(angle, 5.0 * M_PI / 180.0 + 1e-12);
      EXPECT_LE(dist, 0.02 + 1e-15);
    }
  }
}

TEST(Perturb, SameStreamSameGuessAndNamesAreParsed) {
  Random a(3), b(3);
  EXPECT_EQ(PerturbRig(DefaultRig(), Perturbation::kTable4, a),
            PerturbRig(DefaultRig(), Perturbation::kTable4, b));
  EXPECT_EQ(ParsePerturbation("coarse"), Perturbation::kCoarse);
  EXPECT_EQ(ParsePerturbation("table4"), Perturbation::kTable4);
  EXPECT_THROW(ParsePerturbation("Table4"), std::invalid_argument);
}

TEST(DefaultRig, IsAValidRigWithTheTable4Sensors) {
  const RigConfig rig = DefaultRig();
  EXPECT_NO_THROW(ValidateRig(rig, "default rig"));
  // Survives the file round trip exactly.
  EXPECT_EQ(ParseRigString(EmitRig(rig)), rig);
  EXPECT_EQ(rig.Find("imu0")->noise.update_rate, 250.0);
  EXPECT_EQ(rig.Find("imu1")->noise.update_rate, 300.0);
  EXPECT_EQ(rig.Find("gyro0")->noise.update_rate, 200.0);
  EXPECT_EQ(rig.Find("cam0")->width, 752);
  EXPECT_EQ(rig.Find("cam1")->distortion_model, "equidistant");
  for (const SensorConfig& s : rig.sensors) {
    if (s.name != rig.base_imu) {
      EXPECT_GE(std::abs(s.time_offset), 0.002) << s.name;
      const double lever = s.T_B_S.topRightCorner<3, 1>().norm();
      EXPECT_GE(lever, 0.02) << s.name;
    }
  }
}

}  // namespace
}  // namespace ctcal::sim
