// The error vocabulary of engine/common/error.h: field errors, their names inside an owner's
// options, and the excerpt every message quotes user text through.
#include "engine/common/error.h"

#include <string>

#include <gtest/gtest.h>

namespace machplan {
namespace {

struct Inner {
  double v = 1;
  void validate() const { require_field(v > 0, "v_mm", v, "must be > 0 mm"); }
};

struct Outer {
  Inner inner;
  void validate() const { validate_member("inner", inner); }
};

TEST(InputError, AFieldErrorNamesTheFieldItsValueAndTheRule) {
  try {
    require_field(false, "kerf_mm", -1, "must be in [0, 100] mm");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "kerf_mm");
    EXPECT_STREQ(e.what(), "kerf_mm: -1 must be in [0, 100] mm");
    const InputError flag = e.renamed("--kerf");
    EXPECT_FALSE(flag.is_field());
    EXPECT_STREQ(flag.what(), "--kerf: -1 must be in [0, 100] mm");
  }
}

TEST(InputError, AMembersFieldComesOutUnderItsOwnersName) {
  Outer o;
  o.inner.v = 0;
  try {
    o.validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "inner.v_mm");
    EXPECT_EQ(e.message(), "0 must be > 0 mm");
  }
  // A file's error is not a field's: it passes unchanged.
  const InputError file("part.ngc", 3, "bad word");
  EXPECT_STREQ(file.within("inner").what(), "part.ngc:3: bad word");
}

TEST(Excerpt, ShortTextIsQuotedWhole) {
  EXPECT_EQ(excerpt("kerf"), "kerf");
  EXPECT_EQ(excerpt(""), "");
  EXPECT_EQ(excerpt(std::string(kExcerptChars, 'a')), std::string(kExcerptChars, 'a'));
}

TEST(Excerpt, LongTextIsCutToItsFirstCharacters) {
  const std::string ten_mb(10u << 20, 'x');
  const std::string e = excerpt(ten_mb);
  EXPECT_EQ(e, std::string(kExcerptChars, 'x') + "...");
  EXPECT_EQ(excerpt("abcdef", 3), "abc...");
}

TEST(Excerpt, ControlAndBrokenBytesAreEscapedAndCharactersAreNeverCut) {
  EXPECT_EQ(excerpt("a\nb\x1b[2J"), "a\\x0ab\\x1b[2J");
  EXPECT_EQ(excerpt("\xff\xfe"), "\\xff\\xfe");
  // "Süd" is three characters, four bytes: kept whole, and counted as characters.
  EXPECT_EQ(excerpt("S\xc3\xbc" "d"), "S\xc3\xbc" "d");
  EXPECT_EQ(excerpt("\xc3\xbc\xc3\xbc\xc3\xbc", 2), "\xc3\xbc\xc3\xbc...");
  // A sequence cut short by the end of the text, an overlong form, a surrogate.
  EXPECT_EQ(excerpt("a\xc3"), "a\\xc3");
  EXPECT_EQ(excerpt("\xc0\xaf"), "\\xc0\\xaf");
  EXPECT_EQ(excerpt("\xed\xa0\x80"), "\\xed\\xa0\\x80");
}

}  // namespace
}  // namespace machplan
