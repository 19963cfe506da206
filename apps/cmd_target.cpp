// `ctcal target --target TARGET.yaml --out board.pdf` (SPEC section 8): a printable board at true
// scale from a Kalibr target file (targets/board_pdf.h).
#include <cstdio>
#include <memory>

#include "cli_common.h"
#include "commands.h"
#include "ctcal/targets/board_pdf.h"

namespace ctcal::app {

int RunTarget(int argc, char** argv) {
  namespace po = boost::program_options;
  CommandLine cli("target", "--target TARGET.yaml --out board.pdf",
                  "Write a printable PDF of the board at true scale (Kalibr's layout, a scale bar "
                  "and the target parameters in the margin). Print it at 100 %.");
  std::string target_path, out_path;
  cli.options().add_options()("target", po::value(&target_path)->required(),
                              "Kalibr target file (aprilgrid or checkerboard)")(
      "out", po::value(&out_path)->required(), "the PDF to write");
  if (const auto exit_code = cli.Parse(argc, argv))
    return *exit_code;
  std::unique_ptr<Board> board;
  try {
    board = std::make_unique<Board>(LoadTargetConfig(target_path));
  } catch (const std::exception& e) {
    return cli.InputError(e.what());
  }
  try {
    WriteBoardPdf(*board, out_path);
  } catch (const std::exception& e) {
    return cli.RunFailed(e.what());
  }
  const Eigen::Vector2d page = BoardPdfPageSize(*board);
  std::printf(
      "wrote %s: %.1f x %.1f mm page, %d corners; print at 100 %% and check the %s scale "
      "bar\n",
      out_path.c_str(), page.x() * 1000.0, page.y() * 1000.0, board->NumCorners(),
      board->PatternBox().sizes().x() >= 0.11 ? "100 mm" : "50 mm");
  return kExitOk;
}

}  // namespace ctcal::app
