#include "core/fields.h"

#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>

namespace turbid {
namespace {

using nlohmann::json;

enum class Shape { kRound, kSquare };

struct Inner {
  int bins = 256;
  double alpha = 0.4;
};

struct Example {
  double beta = 0.1;
  int tiles = 8;
  uint64_t seed = 7;
  bool denoise = true;
  std::string name = "x";
  Shape shape = Shape::kRound;
  Inner inner;
};

const Fields<Inner>& InnerFields() {
  static const Fields<Inner> fields =
      Fields<Inner>()
          .Integer("bins", &Inner::bins, "histogram bins", 2, 65536)
          .Number("alpha", &Inner::alpha, "distribution parameter", NumberRange::Above(0));
  return fields;
}

const Fields<Example>& ExampleFields() {
  static const Fields<Example> fields =
      Fields<Example>()
          .Number("beta", &Example::beta, "attenuation, 1/m", NumberRange::AtLeast(0))
          .Integer("tiles", &Example::tiles, "tiles", 2, 1024)
          .Unsigned("seed", &Example::seed, "seed")
          .Boolean("denoise", &Example::denoise, "denoise first")
          .String("name", &Example::name, "a name")
          .Choice("shape", &Example::shape, {{"round", Shape::kRound}, {"square", Shape::kSquare}},
                  "the shape")
          .Nested("clahe_", &Example::inner, InnerFields());
  return fields;
}

std::string ReadError(const json& in) {
  Example e;
  try {
    ExampleFields().Read(in, &e, "f.json", "params");
  } catch (const Error& error) {
    return error.what();
  }
  return "";
}

TEST(Fields, ReadsEveryKindAndKeepsAbsentKeys) {
  Example e;
  ExampleFields().Read(json::parse(R"({"beta": 0.5, "tiles": 4.0, "seed": 18446744073709551615,
      "denoise": false, "name": "y", "shape": "square", "clahe_bins": 64})"),
                       &e, "f.json");
  EXPECT_EQ(e.beta, 0.5);
  EXPECT_EQ(e.tiles, 4);  // 4.0 is the integer 4 (JSON does not tell them apart)
  EXPECT_EQ(e.seed, 18446744073709551615ull);
  EXPECT_FALSE(e.denoise);
  EXPECT_EQ(e.name, "y");
  EXPECT_EQ(e.shape, Shape::kSquare);
  EXPECT_EQ(e.inner.bins, 64);
  EXPECT_EQ(e.inner.alpha, 0.4);                      // absent: kept
  ExampleFields().Read(json(nullptr), &e, "f.json");  // null reads nothing
  EXPECT_EQ(e.beta, 0.5);
}

TEST(Fields, ToJsonWritesEveryKeyInDeclarationOrderAndReadsBack) {
  Example e;
  e.shape = Shape::kSquare;
  e.inner.bins = 17;
  const json out = ExampleFields().ToJson(e);
  std::vector<std::string> keys;
  for (auto it = out.begin(); it != out.end(); ++it) keys.push_back(it.key());
  // nlohmann::json sorts object keys; the declaration order is the order of Keys().
  EXPECT_EQ(ExampleFields().Keys(),
            (std::vector<std::string>{"beta", "tiles", "seed", "denoise", "name", "shape",
                                      "clahe_bins", "clahe_alpha"}));
  EXPECT_EQ(out.size(), 8u);
  EXPECT_EQ(out["shape"], "square");
  EXPECT_EQ(out["clahe_bins"], 17);
  Example back;
  ExampleFields().Read(out, &back, "round trip");
  EXPECT_EQ(ExampleFields().ToJson(back), out);
}

TEST(Fields, ErrorsNameTheSourceTheKeyAndTheProblem) {
  EXPECT_EQ(ReadError(json::parse(R"({"beta": "x"})")),
            "f.json: 'params.beta': expected a number, got \"x\"");
  EXPECT_EQ(ReadError(json::parse(R"({"beta": -1})")),
            "f.json: 'params.beta': must be >= 0, got -1");
  EXPECT_EQ(ReadError(json::parse(R"({"tiles": 2.5})")),
            "f.json: 'params.tiles': expected an integer, got 2.5");
  EXPECT_EQ(ReadError(json::parse(R"({"tiles": 1e300})")),
            "f.json: 'params.tiles': expected an integer, got 1e+300");
  EXPECT_EQ(ReadError(json::parse(R"({"tiles": 1})")),
            "f.json: 'params.tiles': must be in [2, 1024], got 1");
  EXPECT_EQ(ReadError(json::parse(R"({"seed": -1})")),
            "f.json: 'params.seed': must be an integer in [0, 18446744073709551615], got -1");
  EXPECT_EQ(ReadError(json::parse(R"({"denoise": 1})")),
            "f.json: 'params.denoise': expected true or false, got 1");
  EXPECT_EQ(ReadError(json::parse(R"({"shape": "oval"})")),
            "f.json: 'params.shape': expected one of round, square, got \"oval\"");
  EXPECT_EQ(ReadError(json::parse(R"({"clahe_alpha": 0})")),
            "f.json: 'params.clahe_alpha': must be > 0, got 0");
  EXPECT_EQ(ReadError(json::parse(R"({"parms": 1})")),
            "f.json: unknown key 'params.parms' (known: beta, tiles, seed, denoise, name, shape, "
            "clahe_bins, clahe_alpha)");
  EXPECT_EQ(ReadError(json::parse("[1]")), "f.json: 'params' must be a JSON object, got [1]");
}

TEST(Fields, ANounNamesTheKeysInMessages) {
  Inner inner;
  try {
    InnerFields().Read(json{{"bins", "many"}}, &inner, "clahe", "", "parameter");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "clahe: parameter 'bins': expected an integer, got \"many\"");
  }
  try {
    InnerFields().Read(json{{"bns", 3}}, &inner, "clahe", "", "parameter");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "clahe: unknown parameter 'bns' (known: bins, alpha)");
  }
}

struct Derived : Inner {
  bool extra = false;
};

TEST(Fields, MemberTakesTheKindFromTheTypeAndBaseMembersWork) {
  const Fields<Derived> fields = Fields<Derived>()
                                     .Member("bins", &Inner::bins, "b")
                                     .Member("alpha", &Inner::alpha, "a")
                                     .Member("extra", &Derived::extra, "e");
  const std::vector<FieldInfo> info = fields.Info();
  EXPECT_EQ(info[0].type, "integer");
  EXPECT_EQ(info[1].type, "number");
  EXPECT_EQ(info[2].type, "boolean");
  Derived d;
  fields.Read(json{{"bins", 9}, {"alpha", 2.5}, {"extra", true}}, &d, "f");
  EXPECT_EQ(d.bins, 9);
  EXPECT_EQ(d.alpha, 2.5);
  EXPECT_TRUE(d.extra);
}

TEST(Fields, TagsLabelTheLastField) {
  const Fields<Inner> fields =
      Fields<Inner>().Integer("bins", &Inner::bins, "b").Tag(3).Number("alpha", &Inner::alpha, "a");
  EXPECT_EQ(fields.Info()[0].tag, 3);
  EXPECT_EQ(fields.Info()[1].tag, 0);
  EXPECT_THROW(Fields<Inner>().Tag(1), std::logic_error);
}

TEST(Fields, ALongValueIsCutInTheMessage) {
  json big = json::array();
  for (int i = 0; i < 1000; ++i) big.push_back(i);
  const std::string message = ReadError(json{{"name", big}});
  EXPECT_LT(message.size(), 140u) << message;
  EXPECT_NE(message.find("..."), std::string::npos);
}

TEST(Fields, AFailedReadLeavesTheFieldAsItWas) {
  Example e;
  EXPECT_NE(ReadError(json{{"tiles", 5000}}), "");
  ExampleFields().Read(json{{"tiles", 16}}, &e, "f");
  try {
    ExampleFields().Read(json{{"tiles", 5000}}, &e, "f");
  } catch (const Error&) {
  }
  EXPECT_EQ(e.tiles, 16);
}

TEST(Fields, InfoCarriesTypesRangesDefaultsAndDocs) {
  Example defaults;
  defaults.beta = 0.25;
  const std::vector<FieldInfo> rows = ExampleFields().Info(defaults);
  ASSERT_EQ(rows.size(), 8u);
  EXPECT_EQ(rows[0].key, "beta");
  EXPECT_EQ(rows[0].type, "number");
  EXPECT_EQ(rows[0].range, ">= 0");
  EXPECT_EQ(rows[0].default_value, 0.25);
  EXPECT_EQ(rows[0].doc, "attenuation, 1/m");
  EXPECT_EQ(rows[1].range, "in [2, 1024]");
  EXPECT_EQ(rows[5].type, "one of: round, square");
  EXPECT_EQ(rows[7].key, "clahe_alpha");
  EXPECT_EQ(rows[7].range, "> 0");
  const std::string table = FieldsMarkdown(rows);
  EXPECT_NE(table.find("| `beta` | number, >= 0 | `0.25` | attenuation, 1/m |"), std::string::npos)
      << table;
}

// Sub-objects: Object (a member struct under its own key), OptionalObject (null = nullopt) and
// Inline (more members of the same struct under a key); errors name the whole key path, also
// through Nested.
struct Outer {
  Inner inner;
  std::optional<Inner> maybe;
  double x = 0, y = 0;  // written as {"at": {"x", "y"}}
};

const Fields<Outer>& AtFields() {
  static const Fields<Outer> fields =
      Fields<Outer>().Number("x", &Outer::x, "x").Number("y", &Outer::y, "y");
  return fields;
}

const Fields<Outer>& OuterFields() {
  static const Fields<Outer> fields =
      Fields<Outer>()
          .Object("inner", &Outer::inner, InnerFields(), "an object")
          .OptionalObject("maybe", &Outer::maybe, InnerFields(), "an object or null")
          .Inline("at", AtFields(), "x and y");
  return fields;
}

struct Wrapper {
  Outer outer;
};

TEST(Fields, SubObjectsReadWriteAndNameTheirPath) {
  Outer o;
  OuterFields().Read(json::parse(R"({"inner": {"bins": 16}, "maybe": {"alpha": 2},
                                      "at": {"x": 1, "y": 2}})"),
                     &o, "f.json");
  EXPECT_EQ(o.inner.bins, 16);
  EXPECT_EQ(o.inner.alpha, 0.4);  // absent: kept
  ASSERT_TRUE(o.maybe.has_value());
  EXPECT_EQ(o.maybe->alpha, 2.0);
  EXPECT_EQ(o.maybe->bins, 256);
  EXPECT_EQ(o.x, 1.0);
  EXPECT_EQ(o.y, 2.0);
  const json written = OuterFields().ToJson(o);
  EXPECT_EQ(written["at"], json::parse(R"({"x": 1.0, "y": 2.0})"));
  EXPECT_EQ(written["inner"]["bins"], 16);
  Outer back;
  OuterFields().Read(written, &back, "w.json");
  EXPECT_EQ(OuterFields().ToJson(back), written);
  OuterFields().Read(json::parse(R"({"maybe": null})"), &back, "n.json");
  EXPECT_FALSE(back.maybe.has_value());
  EXPECT_TRUE(OuterFields().ToJson(back)["maybe"].is_null());

  auto error_of = [](const char* text) {
    try {
      Outer x;
      OuterFields().Read(json::parse(text), &x, "e.json", "top");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error_of(R"({"inner": {"bins": 1}})"),
            "e.json: 'top.inner.bins': must be in [2, 65536], got 1");
  EXPECT_EQ(error_of(R"({"maybe": {"z": 1}})"),
            "e.json: unknown key 'top.maybe.z' (known: bins, alpha)");
  EXPECT_EQ(error_of(R"({"at": {"x": "a"}})"), "e.json: 'top.at.x': expected a number, got \"a\"");
  EXPECT_EQ(error_of(R"({"inner": 3})"), "e.json: 'top.inner' must be a JSON object, got 3");

  // Through Nested: the sub-object keeps its reader.
  const Fields<Wrapper> wrapper = Fields<Wrapper>().Nested("w_", &Wrapper::outer, OuterFields());
  Wrapper w;
  wrapper.Read(json::parse(R"({"w_inner": {"bins": 4}})"), &w, "n.json");
  EXPECT_EQ(w.outer.inner.bins, 4);
}

TEST(Fields, DeclaringAKeyTwiceIsAProgrammingError) {
  EXPECT_THROW(
      Fields<Inner>().Integer("bins", &Inner::bins, "a").Integer("bins", &Inner::bins, "b"),
      std::logic_error);
}

TEST(NumberRange, TextAndContains) {
  EXPECT_EQ(NumberRange::Any().Text(), "");
  EXPECT_EQ(NumberRange::Between(0, 1).Text(), "in [0, 1]");
  EXPECT_EQ(NumberRange::AboveUpTo(0, 1).Text(), "in (0, 1]");
  EXPECT_EQ(NumberRange::Above(0.5).Text(), "> 0.5");
  EXPECT_TRUE(NumberRange::AboveUpTo(0, 1).Contains(1));
  EXPECT_FALSE(NumberRange::AboveUpTo(0, 1).Contains(0));
  EXPECT_FALSE(NumberRange::Any().Contains(NAN));
  EXPECT_FALSE(NumberRange::Any().Contains(INFINITY));
}

}  // namespace
}  // namespace turbid
