#include "ctcal/calibrator/init/board_order.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <set>
#include <utility>

#include "ctcal/calibrator/init/camera_init.h"
#include "ctcal/sensors/camera_model.h"
#include "ctcal/targets/board.h"
#include "ctcal/targets/board_symmetry.h"

namespace ctcal {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

int Mod4(int q) {
  return ((q % 4) + 4) % 4;
}

double AngleDeg(const Eigen::Matrix3d& R) {
  return Eigen::AngleAxisd(R).angle() / kDeg;
}

Eigen::Matrix3d Turn(int quarter_turns) {
  return Eigen::AngleAxisd(quarter_turns * 0.5 * kPi, Eigen::Vector3d::UnitZ()).matrix();
}

// One view with a PnP pose: P = T_C_W of its corners as labelled. With the view's turn s
// relative to the board's order (its labels are turned_id_s of the board's), the board's own pose
// is T_C_W = P * T_turn(s): the rotation R_C_W = R_P * Rz(s * 90 deg).
struct Node {
  int camera = 0;
  std::int64_t t_ns = 0;
  double t_base = 0.0;  // s, base clock
  Eigen::Matrix3d R_P = Eigen::Matrix3d::Identity();
};

// Union-find whose offset is the turn: s_v - s_root (mod 4 quarter turns).
class TurnGroups {
 public:
  explicit TurnGroups(std::size_t n) : parent_(n), offset_(n, 0) {
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  std::pair<int, int> Find(int v) {
    int root = v, off = 0;
    while (parent_[root] != root) {
      off += offset_[root];
      root = parent_[root];
    }
    for (int cur = v, cur_off = off; parent_[cur] != cur;) {  // path compression
      const int next = parent_[cur];
      const int step = offset_[cur];
      parent_[cur] = root;
      offset_[cur] = Mod4(cur_off);
      cur_off -= step;
      cur = next;
    }
    return {root, Mod4(off)};
  }
  // s_b - s_a = q; false when the groups already hold another relation.
  bool Join(int a, int b, int q) {
    const auto [ra, oa] = Find(a);
    const auto [rb, ob] = Find(b);
    if (ra == rb)
      return Mod4(ob - oa - q) == 0;
    parent_[rb] = ra;
    offset_[rb] = Mod4(q - ob + oa);
    return true;
  }

 private:
  std::vector<int> parent_;
  std::vector<int> offset_;
};

// The views' PnP poses with the guessed intrinsics, or with intrinsics initialised from the views
// when the guess reprojects poorly (a camera alone does not mind the turns).
std::vector<BoardView> PosesOf(const SensorConfig& s, const std::vector<CornerObservation>& corners,
                               const Board& board, const BoardOrderOptions& options) {
  CameraModel model = CameraModel::Create(s.camera_model, s.intrinsics, s.distortion_model,
                                          s.distortion_coeffs, Eigen::Vector2i(s.width, s.height));
  // fx leads mrcal's intrinsics; SPEC section 4's end with fu fv pu pv.
  const int focal = model.mrcal_lens() ? 0 : model.NumIntrinsics() - 4;
  try {
    BoardPosesResult guess =
        InitBoardPoses(s.name, model, board, corners, options.min_corners, 0, {}, options.threads);
    // The intrinsics stage fits SPEC section 4's models only: an mrcal lens keeps its guess.
    if (guess.median_rms_ray * model.params()(focal) <= options.reinit_rms_px || model.mrcal_lens())
      return std::move(guess.views);
  } catch (const InitError&) {
    // no pose with the guess: the intrinsics from the views below
  }
  IntrinsicsInitOptions init;
  init.min_corners = options.min_corners;
  model = InitCameraIntrinsics(s.name, model, board, corners, init, {}).camera;
  return InitBoardPoses(s.name, model, board, corners, options.min_corners, 0, {}, options.threads)
      .views;
}

double MedianPeriod(const std::vector<Node>& nodes, const std::vector<int>& of_camera) {
  std::vector<double> gaps;
  for (std::size_t i = 1; i < of_camera.size(); ++i)
    gaps.push_back(nodes[of_camera[i]].t_base - nodes[of_camera[i - 1]].t_base);
  if (gaps.empty())
    return 0.0;
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

// The angle (deg) the base gyroscope turns through from t1 to t2 (base clock, s): raw rates, whose
// bias and scale errors move it by far less than the 90 deg between turns.
double GyroAngleDeg(const std::vector<ImuSample>& imu, double t1, double t2) {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  auto it = std::upper_bound(imu.begin(), imu.end(), t1,
                             [](double t, const ImuSample& s) { return t < s.t_ns * 1e-9; });
  if (it != imu.begin())
    --it;
  for (; it != imu.end() && it->t_ns * 1e-9 < t2; ++it) {
    const double a = std::max(it->t_ns * 1e-9, t1);
    const double b = std::next(it) == imu.end() ? t2 : std::min(std::next(it)->t_ns * 1e-9, t2);
    const Eigen::Vector3d phi = it->w_m * std::max(0.0, b - a);
    if (phi.norm() > 0.0)
      q = q * Eigen::Quaterniond(Eigen::AngleAxisd(phi.norm(), phi.normalized()));
  }
  return Eigen::AngleAxisd(q).angle() / kDeg;
}

struct Relation {
  int a = 0, b = 0, q = 0;  // s_b - s_a = q
};

// Across the cameras of one instant: for each matched pair (a, b) of views, the relative rotation
// R_Cb_Ca of every turn q, R_Pb Rz(q) R_Pa^T. The true turns give the same rotation at every
// instant: the one most candidates agree with (tried from up to 64 anchors, then averaged over
// its agreeing candidates) picks each pair's turn.
std::vector<Relation> CrossCameraRelations(const std::vector<Node>& nodes,
                                           const std::vector<std::pair<int, int>>& pairs,
                                           const std::vector<int>& turns, double max_deg,
                                           std::string* why_not) {
  std::vector<std::vector<Eigen::Matrix3d>> cand(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i)
    for (int q : turns)
      cand[i].push_back(nodes[pairs[i].second].R_P * Turn(q) *
                        nodes[pairs[i].first].R_P.transpose());
  const auto agreeing = [&](const Eigen::Matrix3d& anchor, std::vector<int>* pick) {
    int count = 0;
    for (std::size_t j = 0; j < pairs.size(); ++j) {
      int best = -1;
      double best_deg = max_deg;
      for (std::size_t k = 0; k < turns.size(); ++k) {
        const double deg = AngleDeg(anchor.transpose() * cand[j][k]);
        if (deg < best_deg) {
          best_deg = deg;
          best = static_cast<int>(k);
        }
      }
      count += best >= 0;
      if (pick)
        (*pick)[j] = best;
    }
    return count;
  };
  Eigen::Matrix3d anchor = Eigen::Matrix3d::Identity();
  int best_count = 0;
  const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 64);
  for (std::size_t i = 0; i < pairs.size(); i += stride) {
    for (std::size_t k = 0; k < turns.size(); ++k) {
      const int count = agreeing(cand[i][k], nullptr);
      if (count > best_count) {
        best_count = count;
        anchor = cand[i][k];
      }
    }
  }
  if (best_count < 2 || 2 * best_count < static_cast<int>(pairs.size())) {
    *why_not = std::to_string(best_count) + " of " + std::to_string(pairs.size()) +
               " shared views agree on one relative rotation";
    return {};
  }
  std::vector<int> pick(pairs.size(), -1);
  agreeing(anchor, &pick);
  // The chordal mean of the agreeing candidates, then the final pick.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < pairs.size(); ++j)
    if (pick[j] >= 0)
      sum += cand[j][static_cast<std::size_t>(pick[j])];
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  agreeing(svd.matrixU() * D * svd.matrixV().transpose(), &pick);
  std::vector<Relation> out;
  for (std::size_t j = 0; j < pairs.size(); ++j)
    if (pick[j] >= 0)
      out.push_back({pairs[j].first, pairs[j].second, turns[static_cast<std::size_t>(pick[j])]});
  return out;
}

// Along time: consecutive views v1, v2 of one camera rotate by R_C1_C2 = R_P1 Rz(s1 - s2) R_P2^T,
// whose angle must be the gyroscope's. Kept when exactly one turn is within the tolerance.
std::vector<Relation> TimeRelations(const std::vector<Node>& nodes, const std::vector<int>& order,
                                    const std::vector<ImuSample>& imu,
                                    const std::vector<int>& turns,
                                    const BoardOrderOptions& options) {
  std::vector<Relation> out;
  for (std::size_t i = 1; i < order.size(); ++i) {
    const Node& n1 = nodes[order[i - 1]];
    const Node& n2 = nodes[order[i]];
    if (n2.t_base - n1.t_base > options.max_gap_s)
      continue;
    const double gyro = GyroAngleDeg(imu, n1.t_base, n2.t_base);
    const double tolerance = options.max_angle_deg + 0.1 * gyro;
    int found = -1, within = 0;
    for (int q : turns) {
      if (std::abs(AngleDeg(n1.R_P * Turn(q) * n2.R_P.transpose()) - gyro) < tolerance) {
        found = q;
        ++within;
      }
    }
    if (within == 1)
      out.push_back({order[i - 1], order[i], Mod4(-found)});  // s2 - s1 = -(s1 - s2)
  }
  return out;
}

}  // namespace

BoardOrderResult ResolveBoardOrder(const RigConfig& rig, std::map<std::string, SensorData>* data,
                                   const BoardOrderOptions& options, const InitLog& log) {
  BoardOrderResult result;
  const Board board(rig.target);
  const std::vector<BoardTurn> symmetries = BoardSymmetries(board);
  result.symmetries = static_cast<int>(symmetries.size());
  if (symmetries.empty())
    return result;
  std::vector<int> turns{0};
  std::map<int, const std::vector<int>*> turned_id;
  for (const BoardTurn& t : symmetries) {
    turns.push_back(t.quarter_turns);
    turned_id[t.quarter_turns] = &t.turned_id;
  }
  const std::string board_words = std::to_string(board.rows()) + "x" +
                                  std::to_string(board.cols()) + " inner corners, the same after " +
                                  (symmetries.size() == 1 ? "a half turn" : "a quarter turn");

  // The views with a pose, per camera in time order.
  std::vector<const SensorConfig*> cameras;
  std::vector<Node> nodes;
  std::vector<std::vector<int>> of_camera;
  for (const SensorConfig& s : rig.sensors) {
    if (s.type != SensorType::kCamera)
      continue;
    const auto it = data->find(s.name);
    if (it == data->end() || it->second.corners.empty())
      continue;
    std::vector<BoardView> views;
    try {
      views = PosesOf(s, it->second.corners, board, options);
    } catch (const std::exception& e) {
      result.warnings.push_back(s.name + ": the corner order of its views is not resolved (" +
                                board_words + "): no board poses: " + e.what());
      continue;
    }
    const int c = static_cast<int>(cameras.size());
    cameras.push_back(&s);
    of_camera.emplace_back();
    std::set<std::int64_t> frames;
    for (const CornerObservation& o : it->second.corners)
      frames.insert(o.t_ns);
    result.views[s.name] = static_cast<int>(frames.size());
    for (const BoardView& v : views) {
      of_camera.back().push_back(static_cast<int>(nodes.size()));
      nodes.push_back({c, v.t_ns, v.t_ns * 1e-9 + (s.name == rig.base_imu ? 0.0 : s.time_offset),
                       v.T_C_W.linear()});
    }
  }

  // Instants: each view of camera b matched to camera a's nearest within half a frame period.
  std::vector<std::vector<std::pair<int, int>>> pairs_of(cameras.size() * cameras.size());
  for (std::size_t a = 0; a < cameras.size(); ++a) {
    for (std::size_t b = a + 1; b < cameras.size(); ++b) {
      const double pa = MedianPeriod(nodes, of_camera[a]), pb = MedianPeriod(nodes, of_camera[b]);
      const double tolerance = 0.5 * (pa > 0 && pb > 0 ? std::min(pa, pb) : std::max(pa, pb));
      auto& pairs = pairs_of[a * cameras.size() + b];
      for (int nb : of_camera[b]) {
        const auto& va = of_camera[a];
        const auto near = std::lower_bound(va.begin(), va.end(), nodes[nb].t_base,
                                           [&](int n, double t) { return nodes[n].t_base < t; });
        int best = -1;
        double best_dt = tolerance;
        for (auto it = near == va.begin() ? near : std::prev(near); it != va.end() && it <= near;
             ++it) {
          const double dt = std::abs(nodes[*it].t_base - nodes[nb].t_base);
          if (dt <= best_dt) {
            best_dt = dt;
            best = *it;
          }
        }
        if (best >= 0)
          pairs.emplace_back(best, nb);
      }
    }
  }

  TurnGroups groups(nodes.size());
  TurnGroups instants(nodes.size());  // the turn unused: views of one instant
  for (std::size_t a = 0; a < cameras.size(); ++a) {
    for (std::size_t b = a + 1; b < cameras.size(); ++b) {
      const auto& pairs = pairs_of[a * cameras.size() + b];
      if (pairs.empty())
        continue;
      for (const auto& [na, nb] : pairs)
        instants.Join(na, nb, 0);
      std::string why_not;
      const std::vector<Relation> relations =
          CrossCameraRelations(nodes, pairs, turns, options.max_angle_deg, &why_not);
      if (!why_not.empty())
        result.warnings.push_back(cameras[b]->name + " and " + cameras[a]->name +
                                  ": the corner order of their shared views is not resolved (" +
                                  board_words + "): " + why_not);
      for (const Relation& r : relations)
        result.conflicts += !groups.Join(r.a, r.b, r.q);
    }
  }
  const auto base = data->find(rig.base_imu);
  const bool inertial = !rig.IsCameraOnly() && base != data->end() && !base->second.imu.empty();
  if (inertial) {
    for (const std::vector<int>& order : of_camera)
      for (const Relation& r : TimeRelations(nodes, order, base->second.imu, turns, options))
        result.conflicts += !groups.Join(r.a, r.b, r.q);
  }

  // Which views stay: with an IMU the board is one world, so the group holding the most views;
  // without, each instant keeps the group most of its views are in (the reference camera's on a
  // tie), and a view alone at its instant needs no relation.
  std::vector<bool> keep(nodes.size(), true);
  if (inertial) {
    std::map<int, int> size;
    for (std::size_t v = 0; v < nodes.size(); ++v)
      ++size[groups.Find(static_cast<int>(v)).first];
    int main_group = -1;
    for (const auto& [root, n] : size)
      if (main_group < 0 || n > size[main_group])
        main_group = root;
    for (std::size_t v = 0; v < nodes.size(); ++v)
      keep[v] = groups.Find(static_cast<int>(v)).first == main_group;
  } else {
    std::map<int, std::vector<int>> members;
    for (std::size_t v = 0; v < nodes.size(); ++v)
      members[instants.Find(static_cast<int>(v)).first].push_back(static_cast<int>(v));
    for (const auto& [instant, views] : members) {
      std::map<int, int> count;  // views per turn group
      for (int v : views)
        ++count[groups.Find(v).first];
      int chosen = groups.Find(views.front()).first;  // the lowest camera's (views in order)
      for (const auto& [root, n] : count)
        if (n > count[chosen])
          chosen = root;
      for (int v : views)
        keep[static_cast<std::size_t>(v)] = groups.Find(v).first == chosen;
    }
  }

  // Rename and drop, frame by frame.
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    std::map<std::int64_t, int> action;  // frame -> turn to undo, -1 drop
    for (int v : of_camera[c])
      action[nodes[v].t_ns] = keep[static_cast<std::size_t>(v)] ? groups.Find(v).second : -1;
    std::vector<CornerObservation>& corners = (*data)[cameras[c]->name].corners;
    std::vector<CornerObservation> renamed;
    renamed.reserve(corners.size());
    const std::string& name = cameras[c]->name;
    for (std::size_t begin = 0; begin < corners.size();) {
      std::size_t end = begin;
      while (end < corners.size() && corners[end].t_ns == corners[begin].t_ns)
        ++end;
      const auto it = action.find(corners[begin].t_ns);
      const int turn = it == action.end() ? 0 : it->second;
      if (turn < 0) {
        ++result.dropped[name];
      } else {
        const std::size_t first = renamed.size();
        renamed.insert(renamed.end(), corners.begin() + static_cast<std::ptrdiff_t>(begin),
                       corners.begin() + static_cast<std::ptrdiff_t>(end));
        if (turn != 0) {
          // Labels are turned_id_s of the group's order: undo with the inverse turn, -s.
          const std::vector<int>& undo = *turned_id.at(Mod4(-turn));
          for (std::size_t k = first; k < renamed.size(); ++k)
            renamed[k].corner_id = undo[static_cast<std::size_t>(renamed[k].corner_id)];
          std::sort(renamed.begin() + static_cast<std::ptrdiff_t>(first), renamed.end(),
                    [](const CornerObservation& x, const CornerObservation& y) {
                      return x.corner_id < y.corner_id;
                    });
          ++result.turned[name];
        }
      }
      begin = end;
    }
    corners = std::move(renamed);
    const int dropped = result.dropped[name], turned = result.turned[name];
    log(
        FormatInitLine("board order: %s: %d of %d views renamed into the rig's corner order, %d "
                       "dropped (%s)",
                       name.c_str(), turned, result.views[name], dropped, board_words.c_str()));
    if (dropped > 0)
      result.warnings.push_back(
          name + ": " + std::to_string(dropped) + " of " + std::to_string(result.views[name]) +
          " views dropped: the board looks the same turned (" + board_words +
          ") and neither the other cameras of their instant" +
          (inertial ? " nor the base gyroscope" : "") + " settle their corner order");
  }
  if (result.conflicts > 0)
    log(FormatInitLine("board order: %d relations contradicted the views' groups (not used)",
                       result.conflicts));
  return result;
}

}  // namespace ctcal
