#pragma once
// The lines of a cycle for `lec cycle run`: one Client per axis, axes on
// one line sharing its master. An axis without `line:` is on the --port
// line. `--port sim` puts every line on an in-process twin (a controller per
// axis, with the file's workpieces) on one virtual clock: the cycle runs in
// simulated time. The twin is `lec sim`'s default, or the field profile of
// --profile FILE (a calibrated twin: `lec sim --calibrate`); --baud,
// --silent-interval and --td apply where the profile does not say.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cli/app.hpp"
#include "lec6/client/client.hpp"
#include "lec6/cycle/cycle.hpp"

namespace lec6::sim {
class Bus;
}

namespace lec6::cli {

class CycleLines {
 public:
  // Opens every line (UsageError for a port that cannot be named or opened).
  CycleLines(const cycle::Cycle& cycle, const GlobalOptions& globals, const std::string& port,
             const std::string& profile_file = {});
  ~CycleLines();
  CycleLines(const CycleLines&) = delete;
  CycleLines& operator=(const CycleLines&) = delete;

  std::map<std::string, client::Client*> clients();
  bool simulated() const noexcept { return simulated_; }
  // "in-process twin (simulated time)", "/dev/ttyUSB0 @ 38400".
  std::string describe() const;
  // --port sim: the twin's line of `axis` (nullptr on a real line), and the
  // virtual clock the twins run on.
  sim::Bus* twin_bus(const std::string& axis);
  const Clock& clock() const;
  // Serial mode, servo on, return to origin, for every axis (the twin's
  // controllers start unpowered, like a machine switched on).
  void prepare(const cycle::Cycle& cycle);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  bool simulated_ = false;
};

}  // namespace lec6::cli
