// Kalibr target files: every value survives a write/read round trip exactly and is written as the
// short decimal a person typed; bad files name the file and the key.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <fstream>
#include <random>
#include <string>

#include "ctcal/targets/target_config.h"

namespace ctcal {
namespace {

std::string Emit(const TargetConfig& t) {
  YAML::Emitter out;
  EmitTargetConfig(t, out);
  return out.c_str();
}

TEST(TargetConfig, AprilGridWritesShortDecimalsAndReadsBackExactly) {
  TargetConfig t;
  t.tag_size = 0.088;
  t.tag_spacing = 0.3;
  const std::string text = Emit(t);
  EXPECT_NE(text.find("tagSize: 0.088\n"), std::string::npos) << text;
  EXPECT_NE(text.find("tagSpacing: 0.3\n"), std::string::npos) << text;
  const TargetConfig back = ParseTargetConfig(YAML::Load(text), "test");
  EXPECT_EQ(back.tag_cols, 6);
  EXPECT_EQ(back.tag_size, 0.088);
  EXPECT_EQ(back.tag_spacing, 0.3);
  EXPECT_EQ(back.black_tag_border, 2);
}

TEST(TargetConfig, RandomSpacingsRoundTripBitExactly) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> size(1e-3, 1.0);
  for (int i = 0; i < 200; ++i) {
    TargetConfig t;
    t.type = TargetType::kCheckerboard;
    t.target_cols = 7;
    t.target_rows = 5;
    t.row_spacing_m = size(rng);
    t.col_spacing_m = size(rng);
    const TargetConfig back = ParseTargetConfig(YAML::Load(Emit(t)), "test");
    ASSERT_EQ(back.row_spacing_m, t.row_spacing_m);
    ASSERT_EQ(back.col_spacing_m, t.col_spacing_m);
  }
}

TEST(TargetConfig, IntegralValuesStayFloats) {
  TargetConfig t;
  t.tag_size = 1.0;
  EXPECT_NE(Emit(t).find("tagSize: 1.0\n"), std::string::npos);
}

TEST(TargetConfig, BadFilesNameTheFileAndKey) {
  const std::string path = ::testing::TempDir() + "/bad_target.yaml";
  {
    std::ofstream f(path);
    f << "target_type: aprilgrid\ntagCols: 6\ntagRows: 6\ntagSize: 0.088\ntagSpacing: 0.3\n"
         "tagColour: red\n";
  }
  try {
    LoadTargetConfig(path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown key 'tagColour'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(LoadTargetConfig(path + ".missing"), std::runtime_error);
  EXPECT_THROW(ParseTargetConfig(YAML::Load("target_type: circles"), "t"), std::runtime_error);
  EXPECT_THROW(ParseTargetConfig(YAML::Load("{target_type: aprilgrid, tagCols: 6, tagRows: 6, "
                                            "tagSize: -1, tagSpacing: 0.3}"),
                                 "t"),
               std::runtime_error);
  std::remove(path.c_str());
}

// ChArUco (docs/targets.md: OpenCV's names): a round trip, and bad values named with their key.
TEST(TargetConfig, CharucoRoundTripAndBadValues) {
  TargetConfig t;
  t.type = TargetType::kCharuco;
  t.squares_x = 7;
  t.squares_y = 5;
  t.square_length_m = 0.04;
  t.marker_length_m = 0.03;
  t.dictionary = "DICT_5X5_100";
  const std::string text = Emit(t);
  const TargetConfig back = ParseTargetConfig(YAML::Load(text), "test");
  EXPECT_EQ(back.type, TargetType::kCharuco);
  EXPECT_EQ(back.squares_x, 7);
  EXPECT_EQ(back.squares_y, 5);
  EXPECT_EQ(back.square_length_m, 0.04);
  EXPECT_EQ(back.marker_length_m, 0.03);
  EXPECT_EQ(back.dictionary, "DICT_5X5_100");
  EXPECT_EQ(ArucoDictionaryId("DICT_4X4_50"), 0);
  EXPECT_EQ(ArucoDictionaryId("DICT_APRILTAG_36h11"), 20);
  EXPECT_EQ(ArucoDictionaryId("DICT_9X9"), -1);
  const auto message = [](const std::string& yaml) {
    try {
      ParseTargetConfig(YAML::Load(yaml), "board.yaml");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string base =
      "{target_type: charuco, squaresX: 7, squaresY: 5, squareLength: 0.04, markerLength: ";
  EXPECT_NE(message(base + "0.05}").find("markerLength"), std::string::npos);
  EXPECT_NE(message(base + "0.03, dictionary: DICT_9X9}").find("unknown dictionary 'DICT_9X9'"),
            std::string::npos);
  EXPECT_NE(message("{target_type: charuco, squaresX: 7, squaresY: 5, squareLength: 0.04}")
                .find("missing required key 'markerLength'"),
            std::string::npos);
  EXPECT_NE(message(base + "0.03, tagSize: 1}").find("unknown key 'tagSize' for charuco"),
            std::string::npos);
}

}  // namespace
}  // namespace ctcal
