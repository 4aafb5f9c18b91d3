// The one strict JSON parse (core/json_io.h): nesting limited at parse time, duplicate keys and
// numbers beyond a double refused, every error one line naming the source.
#include "core/json_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "core/error.h"
#include "tests/support/test_support.h"

namespace turbid {
namespace {

using nlohmann::json;

std::string Nested(int levels, const std::string& open, const std::string& close,
                   const std::string& inner = "1") {
  std::string text;
  for (int i = 0; i < levels; ++i) text += open;
  text += inner;
  for (int i = 0; i < levels; ++i) text += close;
  return text;
}

// The message of the JsonError ParseJson throws for `text` ("" when it parses).
std::string ParseError(const std::string& text, const std::string& source = "in.json") {
  try {
    ParseJson(text, source);
  } catch (const JsonError& e) {
    return e.what();
  }
  return "";
}

void ExpectOneLine(const std::string& message, const std::string& start, const std::string& part) {
  EXPECT_EQ(message.rfind(start, 0), 0u) << message;
  EXPECT_EQ(std::count(message.begin(), message.end(), '\n'), 0) << message;
  EXPECT_NE(message.find(part), std::string::npos) << message;
}

TEST(JsonIo, NestingUpToTheLimitParses) {
  const json arrays = ParseJson(Nested(kMaxJsonDepth, "[", "]"), "a.json");
  const json objects = ParseJson(Nested(kMaxJsonDepth, "{\"k\": ", "}"), "o.json");
  const json* node = &objects;
  int depth = 0;
  while (node->is_object()) node = &node->at("k"), ++depth;
  EXPECT_EQ(depth, kMaxJsonDepth);
  EXPECT_EQ(*node, 1);
  EXPECT_TRUE(arrays.is_array());
}

TEST(JsonIo, DeeperNestingIsOneLineNamingTheSource) {
  // 10^5 levels (the issue's stack overflow) and the first level past the limit, as arrays,
  // objects and mixed, at the top and inside an otherwise valid document.
  const std::vector<std::string> deep = {
      Nested(kMaxJsonDepth + 1, "[", "]"),
      Nested(kMaxJsonDepth + 1, "{\"k\": ", "}"),
      Nested(100000, "[", "]"),
      Nested(100000, "{\"a\":", "}"),
      Nested(50000, "[{\"a\":", "}]"),
      "{\"grid\": {\"water.type\": " + Nested(100000, "[", "]") + "}}",
      Nested(100000, "[", ""),  // unterminated: still refused at the limit, not a syntax error
  };
  for (const std::string& text : deep) {
    const std::string message = ParseError(text, "deep.json");
    ExpectOneLine(message, "deep.json: invalid JSON: ", "nested deeper than 64 levels");
  }
}

TEST(JsonIo, DuplicateKeysAreRefusedNamingTheKey) {
  ExpectOneLine(ParseError(R"({"a": 1, "b": 2, "a": 3})"),
                "in.json: invalid JSON: ", "duplicate key 'a'");
  ExpectOneLine(ParseError(R"({"x": {"psf": {"q": 1, "q": 2}}})"),
                "in.json: ", "duplicate key 'q'");
  // The same key in different objects, or in sibling objects of an array, is fine.
  EXPECT_EQ(ParseError(R"({"a": {"a": 1}, "b": [{"a": 1}, {"a": 2}], "c": {"a": {"a": 0}}})"), "");
  EXPECT_EQ(ParseError(R"([{"k": 1}, {"k": 1}])"), "");
  // After a nested object closes, the outer object's keys are still tracked.
  ExpectOneLine(ParseError(R"({"a": {"b": 1}, "b": 2, "a": 3})"), "in.json: ", "duplicate key 'a'");
}

TEST(JsonIo, NumbersBeyondADoubleAreOneLineNamingTheSource) {
  for (const std::string text : {"1e999", "[1, -1e999]", "{\"x\": 2.3e1964}"}) {
    ExpectOneLine(ParseError(text, "n.json"), "n.json: invalid JSON: ", "number out of range");
  }
  EXPECT_EQ(ParseJson("[1e308, 123456789012345678901234567890, -0.0]", "n.json").size(), 3u);
}

TEST(JsonIo, SyntaxErrorsKeepTheirShape) {
  ExpectOneLine(ParseError(R"({"type": "rgbd", )", "s.json"),
                "s.json: invalid JSON: ", "parse error");
  EXPECT_THROW(ParseJson("", "e.json"), JsonError);
}

TEST(JsonIo, ParseJsonIfValidSeparatesSyntaxFromRefusal) {
  EXPECT_FALSE(ParseJsonIfValid("uniform", "--set").has_value());  // a bare string
  EXPECT_EQ(*ParseJsonIfValid("0.5", "--set"), 0.5);
  EXPECT_THROW(ParseJsonIfValid(Nested(100000, "[", "]"), "--set 'a=...'"), JsonError);
  EXPECT_THROW(ParseJsonIfValid(R"({"a": 1, "a": 2})", "--set"), JsonError);
  EXPECT_THROW(ParseJsonIfValid("1e999", "--set"), JsonError);
}

TEST(JsonIo, ReadJsonFileNamesTheFile) {
  testing::TempDir dir;
  const std::string good = dir.Write("good.json", R"({"a": [1, 2]})");
  EXPECT_EQ(ReadJsonFile(good).at("a").size(), 2u);
  const std::string deep = dir.Write("deep.json", Nested(100000, "[", "]"));
  try {
    ReadJsonFile(deep);
    FAIL();
  } catch (const Error& e) {
    ExpectOneLine(e.what(), deep + ": invalid JSON: ", "nested deeper");
  }
  try {
    ReadJsonFile(dir.File("missing.json"));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), dir.File("missing.json") + ": file not found");
  }
}

}  // namespace
}  // namespace turbid
