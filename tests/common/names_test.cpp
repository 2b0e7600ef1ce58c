// One spelling per name, the old one still read with a note (engine/common/names.h).
#include "engine/common/names.h"

#include <gtest/gtest.h>

#include "engine/common/error.h"

namespace machplan {
namespace {

constexpr Spelling kNames[] = {{"planned"}, {"paper-open", "paper_open"}};

TEST(ParseName, TheCanonicalSpellingGivesNoNote) {
  const Parsed<std::size_t> p = parse_name(kNames, "paper-open", "mode", "mode");
  EXPECT_EQ(p.value, 1u);
  EXPECT_EQ(p.note, "");
}

TEST(ParseName, AnOldSpellingIsReadWithANote) {
  const Parsed<std::size_t> p = parse_name(kNames, "paper_open", "mode", "mode");
  EXPECT_EQ(p.value, 1u);
  EXPECT_EQ(p.note, "'paper_open' is the old spelling of 'paper-open'");
}

TEST(ParseName, AnUnknownNameIsAFieldErrorListingTheCanonicalOnes) {
  try {
    parse_name(kNames, "fast", "mode", "mode");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_TRUE(e.is_field());
    EXPECT_EQ(e.where(), "mode");
    EXPECT_EQ(e.message(), "unknown mode 'fast' (known: planned, paper-open)");
  }
  // The user's text is quoted as an excerpt.
  try {
    parse_name(kNames, std::string(1000, 'z'), "mode", "mode");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_LT(e.message().size(), 200u);
  }
}

}  // namespace
}  // namespace machplan
