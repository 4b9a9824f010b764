// Every exception of the library derives from lec6::Error, so one catch
// clause catches them all (lec6/error.hpp).

#include <system_error>
#include <type_traits>

#include <gtest/gtest.h>

#include "lec6/client/errors.hpp"
#include "lec6/client/link.hpp"
#include "lec6/error.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/transport/serial_link.hpp"

namespace lec6 {
namespace {

static_assert(std::is_base_of_v<Error, InvalidArgument>);
static_assert(std::is_base_of_v<Error, SystemError>);
static_assert(std::is_base_of_v<Error, client::LinkError>);
static_assert(std::is_base_of_v<Error, client::TransportError>);
static_assert(std::is_base_of_v<Error, client::ControllerException>);
static_assert(std::is_base_of_v<Error, client::AlarmError>);
static_assert(std::is_base_of_v<Error, client::DeadlineError>);
static_assert(std::is_base_of_v<Error, client::Cancelled>);
static_assert(std::is_base_of_v<InvalidArgument, client::InvalidRequest>);
// Still a std::exception, through one path only (no ambiguous base).
static_assert(std::is_base_of_v<std::exception, Error>);

TEST(Error, BadInputToEachLayerIsCaughtAsLec6Error) {
  EXPECT_THROW(transport::parse_port_spec("foo"), Error);
  EXPECT_THROW(transport::SerialLink("/dev/null", {.baud = 1234}), Error);
  sim::Bus bus;
  EXPECT_THROW(bus.add(0), Error);
  EXPECT_THROW(transport::SerialLink("/nonexistent/tty", {}), Error);
}

TEST(Error, SystemErrorWordsItLikeStdSystemError) {
  const SystemError e(EBADF, "write");
  const std::system_error std_e(EBADF, std::generic_category(), "write");
  EXPECT_STREQ(e.what(), std_e.what());
  EXPECT_EQ(e.code(), std_e.code());
}

}  // namespace
}  // namespace lec6
