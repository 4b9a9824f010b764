// Expected::value() on an error throws a lec6::Error in every build type
// (README: one `catch (const lec6::Error&)` catches everything the library
// throws), saying what the error was.
#include "lec6/expected.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lec6/modbus/pdu.hpp"

namespace lec6 {
namespace {

TEST(Expected, ValueOfAnErrorThrowsALec6ErrorWithItsMessage) {
  const Expected<int, std::string> e = unexpected(std::string("speed 0: the range is 1-500 mm/s"));
  try {
    (void)e.value();
    FAIL() << "value() of an error returned";
  } catch (const Error& x) {
    EXPECT_STREQ(x.what(), "speed 0: the range is 1-500 mm/s");
  }
  EXPECT_THROW((void)*e, BadExpectedAccess);
}

TEST(Expected, TheThrownErrorCarriesTheErrorValue) {
  Expected<int, modbus::Error> e =
      unexpected(modbus::Error{modbus::ErrorKind::BadCrc, "CRC 1234, expected 4321"});
  try {
    (void)e.value();
    FAIL();
  } catch (const BadExpectedAccessOf<modbus::Error>& x) {
    EXPECT_EQ(x.error().kind, modbus::ErrorKind::BadCrc);
    EXPECT_STREQ(x.what(), "CRC 1234, expected 4321");
  }
}

TEST(Expected, AListOfErrorsIsJoined) {
  Expected<int, std::vector<std::string>> e =
      unexpected(std::vector<std::string>{"line 2: speed", "line 3: position"});
  try {
    (void)std::move(e).value();
    FAIL();
  } catch (const Error& x) {
    EXPECT_STREQ(x.what(), "line 2: speed; line 3: position");
  }
}

TEST(Expected, VoidValueThrowsOnlyOnAnError) {
  const Expected<void, std::string> ok;
  EXPECT_NO_THROW(ok.value());
  const Expected<void, std::string> bad = unexpected(std::string("disk full"));
  EXPECT_THROW(bad.value(), Error);
}

TEST(Expected, AValueIsReturned) {
  Expected<std::string, std::string> e = std::string("LEC6");
  EXPECT_EQ(e.value(), "LEC6");
  EXPECT_EQ(e->size(), 4u);
}

}  // namespace
}  // namespace lec6
