// Where a tag's refined corners lie against its own edges, and the tags dropped for it.
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>

#include "detector_internal.h"

namespace ctcal::internal {
namespace {

// How far each refined corner of a tag lies off the tag's own edges (px), a check the grid and the
// code cannot make: on a foreshortened fisheye view a corner can slide 1-2 px along a narrow bit
// onto the corner square's side and the tag still reads as its code. Each edge's position is
// measured across it (the centroid of the intensity rise from the black border into the white
// gap) at 8 places along its middle (15-85 %, clear of the corner squares), relative to the edge
// the four refined corners predict (homography, tag cells -> px). Lens distortion bends the edge
// into a bow, zero at both ends: the offsets d(t) are fitted by
//   d(t) = alpha (1 - t) + beta t + gamma t (1 - t),
// and alpha, beta are the edge's offsets at its two corners, i.e. the corners' offsets across it.
// A corner's two edges give its offset; -1 where an edge cannot be measured (image border).
// The four edges of a tag measured against the edges its corners predict (see below).
struct TagEdgeFit {
  Eigen::Matrix3d H;  // tag cells (x right, y down the printed tag) -> px, through the corners
  // Each edge's offset at its start and end corner (cells, outward positive), where measured.
  std::array<Eigen::Vector2d, 4> ends;
  std::array<bool, 4> measured{};
};

// The tag's corners in tag cells, in the tag's corner order.
std::array<Eigen::Vector2d, 4> TagCellCorners(int cells) {
  const double n = cells;
  return {Eigen::Vector2d(0.0, n), Eigen::Vector2d(n, n), Eigen::Vector2d(n, 0.0),
          Eigen::Vector2d(0.0, 0.0)};
}

// Outward unit normal (tag cells) of edge k -> k+1: corners run clockwise on the printed tag
// (x right, y down), so outward is to the left.
Eigen::Vector2d TagEdgeOutward(int cells, size_t k) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  const Eigen::Vector2d along = (cell[(k + 1) % 4] - cell[k]) / cells;
  return Eigen::Vector2d(-along.y(), along.x());
}

Eigen::Vector2d ToPixel(const Eigen::Matrix3d& H, const Eigen::Vector2d& x) {
  return (H * x.homogeneous()).hnormalized();
}

// `reach`: how far across each edge (cells) the profile runs each way.
TagEdgeFit FitTagEdges(const cv::Mat& gray, const std::array<Eigen::Vector2d, 4>& corners,
                       int cells, double reach) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  std::vector<cv::Point2f> from, to;
  for (size_t k = 0; k < 4; ++k) {
    from.emplace_back(static_cast<float>(cell[k].x()), static_cast<float>(cell[k].y()));
    to.emplace_back(static_cast<float>(corners[k].x()), static_cast<float>(corners[k].y()));
  }
  const cv::Mat Hcv = cv::getPerspectiveTransform(from, to);
  TagEdgeFit fit;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      fit.H(r, c) = Hcv.at<double>(r, c);
  constexpr double kStep = 0.1;
  constexpr int kSamples = 8;
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = cell[k], b = cell[(k + 1) % 4];
    const Eigen::Vector2d outward = TagEdgeOutward(cells, k);
    Eigen::Matrix<double, kSamples, 3> A;
    Eigen::Matrix<double, kSamples, 1> d;
    bool ok = true;
    for (int j = 0; j < kSamples && ok; ++j) {
      const double t = 0.15 + 0.7 * j / (kSamples - 1);
      // The profile's points base + s outward map to H base + s H outward in homogeneous px:
      // one division per sample.
      const Eigen::Vector3d base = fit.H * (a + t * (b - a)).homogeneous();
      const Eigen::Vector3d across = fit.H.leftCols<2>() * outward;
      double previous = -1.0, sum_g = 0.0, sum_gs = 0.0;
      for (double s = -reach; s <= reach + 1e-9 && ok; s += kStep) {
        const Eigen::Vector3d p = base + s * across;
        const double inverse_z = 1.0 / p.z();
        const double value = SampleBilinear(gray, p.x() * inverse_z, p.y() * inverse_z);
        ok = value >= 0.0;
        if (ok && previous >= 0.0 && value > previous) {
          sum_g += value - previous;
          sum_gs += (value - previous) * (s - 0.5 * kStep);
        }
        previous = value;
      }
      ok = ok && sum_g > 0.0;
      A(j, 0) = 1.0 - t;
      A(j, 1) = t;
      A(j, 2) = t * (1.0 - t);
      d(j) = ok ? sum_gs / sum_g : 0.0;
    }
    if (!ok)
      continue;
    const Eigen::Vector3d x = A.colPivHouseholderQr().solve(d);
    fit.ends[k] = x.head<2>();
    fit.measured[k] = true;
  }
  return fit;
}

std::array<double, 4> TagCornerEdgeOffsets(const cv::Mat& gray,
                                           const std::array<Eigen::Vector2d, 4>& corners,
                                           int black_border, int cells) {
  const std::array<Eigen::Vector2d, 4> cell = TagCellCorners(cells);
  // Across the edge: inside stays in the black border, outside in the white gap.
  const TagEdgeFit fit = FitTagEdges(gray, corners, cells, std::min(0.8 * black_border, 1.6));
  const auto& ends = fit.ends;
  const auto& measured = fit.measured;
  const auto to_px = [&fit](const Eigen::Vector2d& x) { return ToPixel(fit.H, x); };
  const double n = cells;
  // Ends in px across their edge, with the tag's scale at each corner.
  std::array<Eigen::Vector2d, 4> ends_px;
  std::vector<double> all_ends;
  for (size_t k = 0; k < 4; ++k) {
    if (!measured[k])
      continue;
    const Eigen::Vector2d outward =
        Eigen::Vector2d(-(cell[(k + 1) % 4] - cell[k]).y(), (cell[(k + 1) % 4] - cell[k]).x()) / n;
    for (int e = 0; e < 2; ++e) {
      const Eigen::Vector2d& c = cell[(k + static_cast<size_t>(e)) % 4];
      ends_px[k](e) = ends[k](e) * (to_px(c + 0.5 * outward) - to_px(c - 0.5 * outward)).norm();
      all_ends.push_back(ends_px[k](e));
    }
  }
  // Ink spreads on the print and the camera's response is not linear: every edge of a real tag
  // sits a common distance outside (or inside) the line through its X-junctions (0.3-0.6 px on
  // EuRoC's views), which moves no X-junction. The median over the tag's edge ends is that
  // distance; a corner's offset is what remains.
  double spread = 0.0;
  if (!all_ends.empty()) {
    std::nth_element(all_ends.begin(), all_ends.begin() + static_cast<long>(all_ends.size() / 2),
                     all_ends.end());
    spread = all_ends[all_ends.size() / 2];
  }
  std::array<double, 4> offsets;
  for (size_t k = 0; k < 4; ++k) {
    const size_t before = (k + 3) % 4;  // the edge ending at corner k
    offsets[k] = measured[k] && measured[before]
                     ? std::hypot(ends_px[k](0) - spread, ends_px[before](1) - spread)
                     : -1.0;
  }
  return offsets;
}

}  // namespace

// Half-width of a tag corner's refinement window: `borders` black borders of the tag's shortest
// edge (the clean neighbourhood of the junction is the border's width and the corner square),
// at least Kalibr's 5 x 5.
int TagCornerHalfWindow(int black_border, double bit_px, double borders) {
  return std::clamp(static_cast<int>(borders * black_border * bit_px), 2, 12);
}

// The tags whose four corners are all among `corners`.
TagCorners TagsOfCorners(const Board& board, const std::vector<DetectedCorner>& corners) {
  // Each corner id's position (the last of a repeated id, as a map filled in order keeps it).
  std::vector<const Eigen::Vector2d*> uv_of(static_cast<size_t>(board.NumCorners()), nullptr);
  for (const DetectedCorner& c : corners)
    if (c.id >= 0 && c.id < board.NumCorners())
      uv_of[static_cast<size_t>(c.id)] = &c.uv;
  TagCorners tags;
  for (int id = 0; id < board.NumTags(); ++id) {
    const std::array<int, 4> ids = board.TagCornerIds(id);
    if (std::all_of(ids.begin(), ids.end(),
                    [&](int k) { return uv_of[static_cast<size_t>(k)] != nullptr; })) {
      std::array<Eigen::Vector2d, 4> c;
      for (size_t k = 0; k < 4; ++k)
        c[k] = *uv_of[static_cast<size_t>(ids[k])];
      tags.emplace_hint(tags.end(), id, c);
    }
  }
  return tags;
}

// Drops every accepted tag with a corner off the tag's own edges (TagCornerEdgeOffsets). How well
// the edges can be measured depends on the view (blur, ink, the camera's response: good corners
// of real TUM-VI views sit up to 1 px off, those of rendered views within 0.6 px), so a tag is an
// outlier when its largest offset exceeds both max_edge_offset_px and `kViewMedians` times the
// view's median of that largest offset.
void DropTagsOffTheirEdges(const cv::Mat& gray, const Board& board, const DetectorOptions& options,
                           DetectionResult* result) {
  constexpr double kViewMedians = 4.0;
  const int border = board.config().black_tag_border;
  const int cells = Board::kTagDataBits + 2 * border;
  const TagCorners tags = TagsOfCorners(board, result->corners);
  std::map<int, double> worst;
  for (const auto& [id, uv] : tags) {
    const std::array<double, 4> offsets = TagCornerEdgeOffsets(gray, uv, border, cells);
    worst[id] = *std::max_element(offsets.begin(), offsets.end());
  }
  if (worst.empty())
    return;
  std::vector<double> values;
  for (const auto& entry : worst)
    values.push_back(entry.second);
  std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2),
                   values.end());
  const double bound =
      std::max(options.max_edge_offset_px, kViewMedians * values[values.size() / 2]);
  for (const auto& [id, offset] : worst) {
    if (!(offset > bound))
      continue;
    const std::array<int, 4> ids = board.TagCornerIds(id);
    result->corners.erase(std::remove_if(result->corners.begin(), result->corners.end(),
                                         [&ids](const DetectedCorner& c) {
                                           return std::find(ids.begin(), ids.end(), c.id) !=
                                                  ids.end();
                                         }),
                          result->corners.end());
    --result->tags_accepted;
    result->rejected.push_back({id, RejectReason::kOffEdges});
  }
}

}  // namespace ctcal::internal
