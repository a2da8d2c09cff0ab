// TOML text as cdshear writes it (src/io/toml_text.hpp): floats in their shortest exact form,
// and every document read back by the TOML library as the table it was written from.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>

#include "case_file.hpp"
#include "shear_case.hpp"
#include "toml_text.hpp"

namespace cdshear {
namespace {

double read_back(const std::string& text) {
  const toml::table t = toml::parse("x = " + text);
  const toml::node* x = t.get("x");
  EXPECT_TRUE(x != nullptr && x->is_floating_point()) << text << " is not read as a float";
  return x != nullptr && x->is_floating_point() ? x->as_floating_point()->get() : 0.0;
}

TEST(TomlText, FloatsAreShortestAndReadBackBitForBit) {
  EXPECT_EQ(toml_float_text(0.05), "0.05");
  EXPECT_EQ(toml_float_text(0.1 + 0.2), "0.30000000000000004");  // no shorter text gives it
  EXPECT_EQ(toml_float_text(20.0), "20.0");                      // stays a float
  EXPECT_EQ(toml_float_text(1e-5), "1e-5");
  EXPECT_EQ(toml_float_text(-2.5e300), "-2.5e300");
  EXPECT_EQ(toml_float_text(std::numeric_limits<double>::infinity()), "inf");
  EXPECT_EQ(toml_float_text(-std::numeric_limits<double>::infinity()), "-inf");
  EXPECT_TRUE(std::isnan(read_back(toml_float_text(std::nan("")))));
  // Doubles of every magnitude, subnormals included, from random bit patterns.
  std::mt19937_64 bits(12345);
  int tested = 0;
  for (int i = 0; i < 20000; ++i) {
    const double v = std::bit_cast<double>(bits());
    if (!std::isfinite(v)) continue;
    const std::string text = toml_float_text(v);
    ASSERT_EQ(std::bit_cast<std::uint64_t>(read_back(text)), std::bit_cast<std::uint64_t>(v))
        << text;
    ++tested;
  }
  EXPECT_GT(tested, 19000);
  EXPECT_EQ(std::bit_cast<std::uint64_t>(read_back(toml_float_text(-0.0))),
            std::bit_cast<std::uint64_t>(-0.0));
}

TEST(TomlText, DocumentsReadBackAsTheirTable) {
  const toml::table table = toml::parse(R"(
top = 0.1
when = 1979-05-27T07:32:00Z
"key with spaces" = "a \"quoted\" value\nwith a newline and \u00e8"
list = [1, 2.5, "three", [4, 5], { inline = true }]
empty_list = []
[a]
x = 0.7
[a.b.c]
y = -3
[a.b.c."dotted.key"]
z = 1e-300
[empty]
[[group]]
purpose = "first"
v = [0.065, 0.09]
[[group]]
purpose = "second"
[group.inner]
w = 4.0
)");
  const std::string text = toml_document_text(table);
  EXPECT_EQ(toml::parse(text), table) << text;
  EXPECT_NE(text.find("top = 0.1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("v = [0.065, 0.09]\n"), std::string::npos) << text;
  // A table holding only tables needs no header of its own; an empty one keeps its header.
  EXPECT_EQ(text.find("[a.b]\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\n[empty]\n"), std::string::npos) << text;
}

TEST(TomlText, ResolvedCaseReadsBackWithShortNumbers) {
  CaseSource source;
  source.system = 5;
  source.velocity = 0.1;
  source.overrides = {"measure.boundary_thickness=[3, 5, 7, 10]", "step.dt=3e-4"};
  const toml::table resolved = case_to_toml(load_case(source));
  const std::string text = toml_document_text(resolved);
  EXPECT_EQ(toml::parse(text), resolved) << text;
  EXPECT_NE(text.find("\nvelocity = 0.1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("\nboundary_thickness = [3.0, 5.0, 7.0, 10.0]\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("0000000"), std::string::npos) << text;  // no 17-digit rounding tails
}

}  // namespace
}  // namespace cdshear
