// client::SharedMaster: threads, each with its own Client, share one line (a
// twin on a real pseudo-terminal) transaction by transaction, first come
// first served. No sleeps: the order test waits on the master's own queue.

#include "lec6/client/shared_master.hpp"

#include <gtest/gtest.h>

#include <future>
#include <mutex>
#include <thread>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/transport/serial_link.hpp"
#include "twin/served_twin.hpp"

namespace lec6::client {
namespace {

using lec6::testing::ServedTwin;

struct Line {
  explicit Line(ServedTwin& twin)
      : link(twin.path(), transport::SerialOptions{.baud = 38400}), rtu(link), shared(rtu) {}
  transport::SerialLink link;
  RtuMaster rtu;
  SharedMaster shared;
};

// Spins (yielding) until `n` threads wait for the line.
void until_waiting(const SharedMaster& m, std::size_t n) {
  while (m.waiting() < n) std::this_thread::yield();
}

TEST(SharedMaster, ThreadsWithTheirOwnClientsShareOneLine) {
  ServedTwin twin({1, 2, 3, 4});
  Line line(twin);
  constexpr int kThreads = 4;
  constexpr int kEach = 20;
  std::vector<std::future<int>> done;
  for (int t = 0; t < kThreads; ++t) {
    done.push_back(std::async(std::launch::async, [&line, t] {
      Client c(line.shared, {.id = static_cast<uint8_t>(t + 1)});
      int ok = 0;
      for (int i = 0; i < kEach; ++i) {
        const auto data = static_cast<uint16_t>(t * 1000 + i);
        if (c.echo(data) == data) ++ok;
        c.read_state();
      }
      return ok;
    }));
  }
  for (auto& d : done) EXPECT_EQ(d.get(), kEach);
  // Every exchange went out (a retry on a loaded machine adds one); none
  // crossed: echo checks its data, the RTU master the replying ID.
  EXPECT_GE(line.shared.stats().transactions, uint64_t{kThreads * kEach * 2});
}

TEST(SharedMaster, TheLineGoesToThreadsInTheOrderTheyAsked) {
  ServedTwin twin({1});
  Line line(twin);
  std::promise<void> release;
  std::vector<int> order;
  std::mutex order_mutex;
  auto note = [&](int who) {
    std::lock_guard lock(order_mutex);
    order.push_back(who);
  };
  // The holder keeps the line until released; 1, 2 and 3 then queue in turn.
  std::promise<void> held;
  auto holder = std::async(std::launch::async, [&] {
    line.shared.with_line([&](void*) {
      held.set_value();
      release.get_future().wait();
    });
  });
  held.get_future().wait();
  std::vector<std::future<void>> queued;
  for (int who = 1; who <= 3; ++who) {
    queued.push_back(std::async(std::launch::async, [&, who] {
      Client c(line.shared, {.id = 1});
      line.shared.with_line([&](void*) { note(who); });
      c.echo(static_cast<uint16_t>(who));
    }));
    until_waiting(line.shared, static_cast<std::size_t>(who));
  }
  release.set_value();
  holder.get();
  for (auto& q : queued) q.get();
  EXPECT_EQ(order, (std::vector<int>{1, 2, 3}));
}

TEST(SharedMaster, AfterCloseExchangesFailWithAPortError) {
  ServedTwin twin({1});
  Line line(twin);
  Client c(line.shared, {.id = 1});
  EXPECT_EQ(c.echo(0x1234), 0x1234);
  line.shared.close();
  EXPECT_TRUE(line.shared.closed());
  try {
    c.echo(0x1234);
    FAIL() << "an exchange after close() went out";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Port);
  }
}

}  // namespace
}  // namespace lec6::client
