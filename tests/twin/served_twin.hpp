#pragma once
// A twin bus served by a SimServer (a pseudo-terminal by default, and/or TCP)
// on its own thread for the fixture's lifetime: the real event loop, reached
// through a real SerialLink or TcpLink.

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "lec6/sim/bus.hpp"
#include "lec6/twin/sim_server.hpp"

namespace lec6::testing {

inline twin::SimServerOptions pty_only() {
  twin::SimServerOptions o;
  o.pty = true;
  return o;
}

class ServedTwin {
 public:
  explicit ServedTwin(std::vector<uint8_t> ids = {1}, twin::SimServerOptions options = pty_only(),
                      sim::LineConfig line = {}, sim::FaultConfig faults = {})
      : bus_(line, faults) {
    for (uint8_t id : ids) bus_.add(id, {}, SteadyClock{}.now());
    server_ = std::make_unique<twin::SimServer>(bus_, std::move(options));
    thread_ = std::thread([this] {
      try {
        server_->run();
      } catch (const std::exception& e) {
        error_ = e.what();
      }
      done_ = true;
    });
  }
  ~ServedTwin() { stop(); }
  ServedTwin(const ServedTwin&) = delete;
  ServedTwin& operator=(const ServedTwin&) = delete;

  // Ends the server's loop; it must have ended without an error.
  void stop() {
    if (!thread_.joinable()) return;
    server_->stop();
    thread_.join();
    EXPECT_EQ(error_, "");
  }
  twin::SimServer& server() { return *server_; }
  // The bus: touch it only after stop() (the server's thread owns it until then).
  sim::Bus& bus() { return bus_; }
  bool done() const { return done_; }
  // The pseudo-terminal's device, for a SerialLink.
  std::string path() const { return server_->pty()->slave_path(); }

 private:
  sim::Bus bus_;
  std::unique_ptr<twin::SimServer> server_;
  std::thread thread_;
  std::string error_;
  std::atomic<bool> done_{false};
};

}  // namespace lec6::testing
