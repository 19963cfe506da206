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

}  // namespace
}  // namespace ctcal
