// File names from data (core/safe_name.h): one plain component, or a one-line error.
#include "core/safe_name.h"

#include <gtest/gtest.h>

#include <string>

#include "core/error.h"

namespace turbid {
namespace {

TEST(SafeName, PlainNamesPass) {
  for (const std::string& name : {std::string("hull"), std::string("room.v2"), std::string("a-b_c"),
                                  std::string("Reef 1"), std::string(200, 'x')}) {
    std::string why;
    EXPECT_TRUE(IsSafeFileComponent(name, &why)) << name << ": " << why;
    EXPECT_EQ(SafeFileComponent("scene name", name), name);
  }
}

TEST(SafeName, PathsControlCharactersAndHiddenNamesAreRefused) {
  const std::string nul("a\0b", 3);
  for (const std::string& name :
       {std::string(""), std::string("."), std::string(".."), std::string("../x"),
        std::string("a/../../x"), std::string("/abs/x"), std::string("a\\b"), std::string("a\nb"),
        nul, std::string("\x7f"), std::string(".hidden"), std::string(".x.png.tmp12ab.png"),
        std::string(201, 'x')}) {
    std::string why;
    EXPECT_FALSE(IsSafeFileComponent(name, &why)) << name;
    try {
      SafeFileComponent("scene name", name);
      ADD_FAILURE() << name << " accepted";
    } catch (const Error& error) {
      const std::string message = error.what();
      EXPECT_EQ(message.rfind("scene name '", 0), 0u) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << message;  // shown escaped: one line
      EXPECT_EQ(message.find('\0'), std::string::npos);
    }
  }
  EXPECT_EQ(PrintableName("a\nb"), "a\\x0ab");
}

TEST(SafeName, CollisionKeyIgnoresAsciiCase) {
  EXPECT_EQ(FileNameKey("Reef"), FileNameKey("reef"));
  EXPECT_NE(FileNameKey("reef"), FileNameKey("reef2"));
}

}  // namespace
}  // namespace turbid
