// A printable PDF of a board at true scale (`ctcal target`), in Kalibr's layout: tag 0 at the
// bottom-left, x to the right, y up, the corner squares; with a scale bar and the target file's
// parameters in the margin so that a print can be checked and matched to its YAML.
#pragma once

#include <string>

#include "ctcal/targets/board.h"

namespace ctcal {

struct BoardPdfOptions {
  double margin_m = 0.015;  // white paper around the pattern, on every side
};

// Throws std::runtime_error naming `path` if cairo cannot write it.
void WriteBoardPdf(const Board& board, const std::string& path,
                   const BoardPdfOptions& options = {});

// The page size WriteBoardPdf uses (m): pattern, margins and the caption band.
Eigen::Vector2d BoardPdfPageSize(const Board& board, const BoardPdfOptions& options = {});

}  // namespace ctcal
