// The one YAML section reader of the configuration files (common/yaml_section.h): every bad
// field is a ConfigError naming file and field path, absent fields take their defaults.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "krr_core/common/yaml_section.h"

using krr::ConfigError;
using krr::YamlSection;

namespace {

YamlSection section(const std::string& text, const std::set<std::string>& allowed) {
  static YAML::Node keep;  // the section refers to its node
  keep = krr::parseYaml(text, "f.yaml");
  return YamlSection(keep["s"], "f.yaml", "s", allowed);
}

// The ConfigError message of `f`, or "" when it throws none.
template <class F>
std::string errorOf(F f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(YamlSection, ReadsFieldsAndDefaults) {
  const YamlSection s = section(
      "s: {x: 0.5, n: 3, name: shop, on: true, list: [a, b], k: 7}\n",
      {"x", "n", "name", "on", "list", "k", "absent"});
  EXPECT_DOUBLE_EQ(s.number("x", 0, 0, 1), 0.5);
  EXPECT_EQ(s.integer("n", 0, 0, 10), 3);
  EXPECT_EQ(s.string("name", ""), "shop");
  EXPECT_TRUE(s.boolean("on", false));
  EXPECT_EQ(s.strings("list", {}), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(s.count("k", 0, 1, 10), 7u);
  EXPECT_DOUBLE_EQ(s.number("absent", 2.5, 0, 10), 2.5);
  EXPECT_EQ(s.string("absent", "def"), "def");
  EXPECT_FALSE(s.has("absent"));
  EXPECT_EQ(s.field("x"), "s.x");
  EXPECT_EQ(s.requiredInteger("n", 0, 10), 3);
}

TEST(YamlSection, NullSectionIsEmpty) {
  // "s:" with nothing under it, and an absent section: every field takes its default.
  EXPECT_EQ(section("s:\n", {"x"}).number("x", 4, 0, 10), 4);
  EXPECT_EQ(section("t: 1\n", {"x"}).integer("x", 4, 0, 10), 4);
}

TEST(YamlSection, BadFieldsNameFileAndPath) {
  EXPECT_EQ(errorOf([] { section("s: {y: 1}\n", {"x"}); }), "f.yaml: unknown field 's.y' (expected x)");
  EXPECT_EQ(errorOf([] { section("s: [1, 2]\n", {"x"}); }),
            "f.yaml: field 's': value '[1, 2]' must be a mapping");
  EXPECT_EQ(errorOf([] { section("s: {x: lots}\n", {"x"}).number("x", 0, 0, 1); }),
            "f.yaml: field 's.x': value 'lots' is not a number");
  EXPECT_EQ(errorOf([] { section("s: {x: 1.5}\n", {"x"}).number("x", 0, 0, 1); }),
            "f.yaml: field 's.x': value 1.5 must be in [0, 1]");
  EXPECT_EQ(errorOf([] {
              section("s: {x: 0}\n", {"x"}).number("x", 1, 0, 1, YamlSection::kLowerOpen);
            }),
            "f.yaml: field 's.x': value 0 must be in (0, 1]");
  EXPECT_EQ(errorOf([] { section("s: {n: 2.5}\n", {"n"}).integer("n", 0, 0, 10); }),
            "f.yaml: field 's.n': value '2.5' is not an integer");
  EXPECT_EQ(errorOf([] { section("s: {n: 11}\n", {"n"}).count("n", 0, 0, 10); }),
            "f.yaml: field 's.n': value 11 must be in [0, 10]");
  EXPECT_EQ(errorOf([] { section("s: {b: maybe}\n", {"b"}).boolean("b", false); }),
            "f.yaml: field 's.b': value 'maybe' must be true or false");
  EXPECT_EQ(errorOf([] { section("s: {t: [a]}\n", {"t"}).string("t", ""); }),
            "f.yaml: field 's.t': value '[a]' must be a non-empty string");
  EXPECT_EQ(errorOf([] { section("s: {l: [a, [b]]}\n", {"l"}).strings("l", {}); }),
            "f.yaml: field 's.l': element '[b]' is not a name");
  EXPECT_EQ(errorOf([] { section("s: {}\n", {"x"}).requiredNumber("x", 0, 1); }),
            "f.yaml: missing field 's.x'");
}

TEST(YamlSection, BrokenAndUnreadableFiles) {
  EXPECT_EQ(errorOf([] { krr::parseYaml("a: [1, 2\n", "f.yaml"); }).rfind("f.yaml:2:1: broken YAML", 0),
            0u);
  EXPECT_THROW(krr::parseYaml<krr::MapError>("a: [1\n", "m.yaml"), krr::MapError);
  EXPECT_THROW(krr::loadYamlFile("/nonexistent/x.yaml", "test config"), ConfigError);
  EXPECT_THROW(krr::loadYamlMapFile("/nonexistent/x.yaml", "map YAML"), krr::MapError);
  const std::string p = ::testing::TempDir() + "/yaml_section_ok.yaml";
  krr::writeFileAtomic(p, "s: {x: 1}\n");
  EXPECT_EQ(krr::loadYamlFile(p, "test config")["s"]["x"].as<int>(), 1);
}

// map_server's map YAML: keys it does not read are ignored, as map_server does, and every
// error is a MapError (the map loaders' type) with the same "file: field" text.
TEST(YamlSection, MapServerFormatIgnoresUnknownKeysAndThrowsMapError) {
  const YAML::Node n = krr::parseYaml("{resolution: -1, origin: [1, x, 0], sampler: extra}", "m.yaml");
  const YamlSection s(n, "m.yaml", "", {}, YamlSection::Format::kMapServer);
  try {
    s.requiredNumber("resolution", 0.0, 1.0, YamlSection::kLowerOpen);
    ADD_FAILURE() << "no error";
  } catch (const krr::MapError& e) {
    EXPECT_STREQ(e.what(), "m.yaml: field 'resolution': value -1 must be in (0, 1]");
  }
  try {
    s.requiredNumbers("origin", 3, "[x, y, yaw]");
    ADD_FAILURE() << "no error";
  } catch (const krr::MapError& e) {
    EXPECT_STREQ(e.what(), "m.yaml: field 'origin': value '[1, x, 0]' must be 3 numbers [x, y, yaw]");
  }
  EXPECT_THROW(s.requiredString("image"), krr::MapError);
  // The same document is refused by a configuration section (unknown keys) with ConfigError.
  EXPECT_THROW(YamlSection(n, "m.yaml", "", {"resolution", "origin"}), ConfigError);
  const YAML::Node ok = krr::parseYaml("{origin: [1, 2, 0.5]}", "m.yaml");
  EXPECT_EQ(YamlSection(ok, "m.yaml", "", {"origin"}).requiredNumbers("origin", 3, "[x, y, yaw]"),
            (std::vector<double>{1, 2, 0.5}));
}
