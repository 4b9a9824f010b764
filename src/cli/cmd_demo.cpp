// `lec demo`: the manual's four operation examples as one guided run, on the
// built-in twin unless --port is given.

#include <unistd.h>

#include "cli/app.hpp"
#include "cli/views.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {
namespace {

struct Stage {
  std::string name;
  double seconds;
  std::string result;
};

class Demo {
 public:
  explicit Demo(Session& s) : s_(s), axis_(s.axis("sim")), client_(s.client("sim")) {}

  void run() {
    if (!s_.json())
      fmt::print("lec demo on {} (controller ID {})\n\n", s_.port_description(), s_.options().id);
    stage("1. Serial input mode (Y30 = 1)             manual §4.1.1", [&] {
      axis_.set_serial_mode(true);
      return std::string("Y30 = 1");
    });
    stage("2. Servo on (Y19), wait SVRE (X49)         manual §4.1.2-3", [&] {
      axis_.servo_on(s_.deadline_in(std::chrono::seconds(5)), s_.wait_options());
      return client_.read_flags().describe();
    });
    stage("3. Return to origin (Y1C), wait SETON      manual §4.2", [&] {
      const auto r =
          axis_.home(s_.deadline_in(std::chrono::seconds(60)), s_.wait_options(progress()));
      return fmt::format("{} at {} mm", r.flags.describe(), lec::format_mm(r.state.position_001mm));
    });
    stage("4. Edit step 1: position 150.00 mm          manual §5", [&] {
      lec::StepData step = client_.read_step(1);
      if (step.is_blank()) {
        // The manual's example writes only the position; a blank step needs
        // the rest too, so it gets the manual's §7.3.1 values.
        step = {lec::MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};
        client_.write_step(1, step);
      } else {
        step.position_001mm = 15000;
        client_.write_step_registers(1, step, 2, 2);
      }
      return std::string("D0412 = 15000 (150.00 mm)");
    });
    stage("5. Run step 1 (IN0-IN5 = 1, DRIVE)          manual §4.3-4", [&] {
      const auto r =
          axis_.run_step(1, s_.deadline_in(std::chrono::seconds(60)), s_.wait_options(progress()));
      return fmt::format("BUSY fell, INP = {}", r.in_position ? 1 : 0);
    });
    stage("6. Read the position (D9000)               manual §6", [&] {
      position_after_step_ = client_.read_state().position_001mm;
      return fmt::format("{} mm", lec::format_mm(position_after_step_));
    });
    stage("7. Direct operation to 300.00 mm (D9102-D9111, D9100)  manual §7", [&] {
      client::DirectMove m;
      m.position_001mm = 30000;
      m.speed_mm_s = 500;
      m.acceleration_mm_s2 = 5000;
      m.deceleration_mm_s2 = 5000;
      m.moving_force_pct = 100;
      m.in_position_001mm = 100;
      m.pushing_speed_mm_s = 20;
      m.area1_001mm = 0;
      m.area2_001mm = 0;
      m.pushing_force_pct = 0;
      const auto r =
          axis_.move(m, s_.deadline_in(std::chrono::seconds(60)), s_.wait_options(progress()));
      final_position_ = r.state.position_001mm;
      in_position_ = r.in_position;
      return fmt::format("{} mm, INP = {}", lec::format_mm(final_position_), r.in_position ? 1 : 0);
    });
    summary();
  }

 private:
  std::function<void(const client::Progress&)> progress() {
    if (s_.json() || !isatty(fileno(stdout))) return {};
    return [](const client::Progress& p) {
      fmt::print("\r     {}\033[K", progress_line(p.state, p.flags));
      std::fflush(stdout);
    };
  }

  template <typename F>
  void stage(const std::string& name, F&& f) {
    if (!s_.json()) {
      fmt::print("{}\n", name);
      std::fflush(stdout);
    }
    const TimePoint t0 = client_.clock().now();
    const std::string result = f();
    const double secs = to_seconds(client_.clock().now() - t0);
    stages_.push_back({name, secs, result});
    if (!s_.json()) {
      const bool tty = isatty(fileno(stdout));
      fmt::print("{}     -> {} ({:.2f} s){}\n", tty ? "\r" : "", result, secs, tty ? "\033[K" : "");
    }
  }

  void summary() {
    const bool ok = position_after_step_ == 15000 && final_position_ == 30000 && in_position_;
    const auto& st = client_.stats();
    if (s_.json()) {
      nlohmann::json stages = nlohmann::json::array();
      for (const auto& x : stages_)
        stages.push_back({{"stage", x.name}, {"seconds", x.seconds}, {"result", x.result}});
      print_json({{"ok", ok},
                  {"stages", stages},
                  {"position_after_step_mm", mm_json(position_after_step_)},
                  {"final_position_mm", mm_json(final_position_)},
                  {"transactions", st.transactions},
                  {"retries", st.retries}});
    } else {
      double total = 0;
      for (const auto& x : stages_) total += x.seconds;
      fmt::print("\nSummary: {} — step 1 reached {} mm, direct operation reached {} mm\n",
                 ok ? "all four manual examples ran as the manual says" : "FAILED",
                 lec::format_mm(position_after_step_), lec::format_mm(final_position_));
      fmt::print("         {} transactions in {:.2f} s, {} retries, {} timeouts\n", st.transactions,
                 total, st.retries, st.timeouts);
    }
    if (!ok) throw CommandFailed(kFailure, "the demo did not end where the manual says");
  }

  Session& s_;
  client::Actuator& axis_;
  client::Client& client_;
  std::vector<Stage> stages_;
  int32_t position_after_step_ = 0;
  int32_t final_position_ = 0;
  bool in_position_ = false;
};

}  // namespace

void add_demo_command(CLI::App& app, Session& session) {
  app.add_subcommand(
         "demo",
         "The manual's four operation examples as one guided run (built-in twin unless --port)")
      ->callback([&session] { Demo(session).run(); });
}

}  // namespace lec6::cli
