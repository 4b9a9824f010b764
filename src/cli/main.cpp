// `lec`: the command line for LEC□6 controllers.

#include <csignal>

#include "cli/app.hpp"
#include "cli/duration_option.hpp"
#include "cli/suggest.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/link.hpp"
#include "lec6/version.hpp"

namespace lec6::cli {
std::atomic<bool> g_interrupted{false};
}

namespace {

using namespace lec6;

constexpr const char* kExitCodes = R"(Exit codes:
  0  success (a move: reached its target, or pushed the workpiece)
  1  a move ended without success: stopped (HOLD / stop / servo off / another master),
     push missed, or the controller did not start it; any other failure
  2  usage error (bad arguments or values; nothing was sent)
  3  transport error (port missing or busy, timeout, CRC, framing)
  4  the controller answered with an exception (01/02/03)
  5  the controller raised an alarm
  6  a wait ran past its deadline
  7  lec doctor: degraded (the line works, but slower or less reliable than it could)
  8  lec doctor: broken (something on the line does not work)
  130 interrupted by Ctrl-C (a moving axis is stopped first)

)";
constexpr const char* kPorts =
    R"(Ports: --port /dev/ttyUSB0 | tcp://host:502 (Modbus TCP, e.g. lec serve) | rtu+tcp://host:4001
(RTU frames over TCP) | sim (in-process twin); LEC_PORT sets a default.)";
// Each subcommand's help ends with this (CLI11 hands a footer down to the
// subcommands created after it); the exit-code table is lec --help's and
// the man page's only (issue 27).
constexpr const char* kSubcommandFooter =
    R"(Exit codes: see `lec --help` (0 success, 2 usage error: nothing sent).
Ports: --port /dev/ttyUSB0 | tcp://host:502 (Modbus TCP, e.g. lec serve) | rtu+tcp://host:4001
(RTU frames over TCP) | sim (in-process twin); LEC_PORT sets a default.)";

void on_signal(int) {
  cli::g_interrupted = true;
}

void install_signal_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

int fail(int code, const std::string& message) {
  fmt::print(stderr, "lec: {}\n", message);
  return code;
}

void add_global_options(CLI::App& app, cli::GlobalOptions& o) {
  app.add_option("--port,-p", o.port,
                 "Port: /dev/ttyUSB0, tcp://host:502 (Modbus TCP), rtu+tcp://host:port or sim "
                 "(default: $LEC_PORT)");
  app.add_option("--baud,-b", o.baud, "Line speed (9600 19200 38400 57600 115200 230400)")
      ->capture_default_str()
      ->check(CLI::IsMember({9600, 19200, 38400, 57600, 115200, 230400}));
  app.add_option("--id", o.id, "Controller ID (1-255; 0 = broadcast, for writes only)")
      ->capture_default_str()
      ->check(CLI::Range(0, 255));
  app.add_option("--soft-limits", o.soft_limits,
                 "MIN:MAX in mm, e.g. 0:400: moves and steps to a target outside are refused "
                 "before anything is written (the stroke is not in the memory map)")
      ->envname("LEC_SOFT_LIMITS");
  app.add_option("--alarm-polarity", o.alarm_polarity,
                 "How the controller reports X4F ALARM: active-high (the manual: 1 = alarm) or "
                 "active-low (inverted, as some controllers do); lec status and lec doctor say "
                 "when X4F and the alarm code disagree")
      ->envname("LEC_ALARM_POLARITY")
      ->capture_default_str()
      ->check(CLI::IsMember({"active-high", "active-low"}));
  app.add_option("--sim-profile", o.sim_profile,
                 "The twin behind --port sim (and lec serve's sim line): default (lec sim's: "
                 "the field's evidence), ideal (the manual's, as lec sim --ideal) or a field "
                 "profile FILE")
      ->envname("LEC_SIM_PROFILE")
      ->capture_default_str();
  using std::chrono::milliseconds;
  using std::chrono::seconds;
  cli::add_duration_option(&app, "--reply-margin", o.reply_margin,
                           "Margin added to the manual's response time Tx (USB adapters add "
                           "up to 16 ms)",
                           {Duration::zero(), seconds(60)});
  cli::add_renamed_duration_option(
      &app, "--timeout", "--reply-margin", o.reply_margin, cli::BareNumber::Milliseconds,
      {Duration::zero(), seconds(60)},
      " as the reply margin (move, home, servo and follow take --timeout DURATION as their "
      "deadline)");
  app.add_option("--retries", o.retries, "Retries of reads and absolute writes after a lost reply")
      ->capture_default_str()
      ->check(CLI::Range(0, 10));
  app.add_flag("--json", o.json, "Machine-readable JSON output");
  app.add_option("--record", o.record,
                 "Write every frame on the line, both directions, with timestamps, to FILE (a "
                 "capture, docs/capture-format.md: lec replay and lec sim --calibrate read it)")
      ->type_name("FILE");
  app.add_flag("--trace", o.trace,
               "Show every frame sent and received (hex and decoded) on stderr");
  app.add_flag("--rs485", o.rs485, "Kernel RS485 mode (TIOCSRS485): RTS on while sending");
  app.add_flag("--rs485-rts-after-send", o.rs485_rts_after_send,
               "RS485: RTS level after sending is 1");
  const cli::DurationLimits rs485_delay{Duration::zero(), seconds(1), milliseconds(1)};
  cli::add_duration_option(&app, "--rs485-delay-before", o.rs485_delay_before,
                           "RS485: delay before send (whole ms)", rs485_delay,
                           cli::BareNumber::Milliseconds);
  cli::add_duration_option(&app, "--rs485-delay-after", o.rs485_delay_after,
                           "RS485: delay after send (whole ms)", rs485_delay,
                           cli::BareNumber::Milliseconds);
  app.add_flag("--echo", o.echo,
               "The adapter echoes what it sends (2-wire): verify and discard the echo");
  app.add_option("--silent-interval", o.silent_interval_k,
                 "The controller's silent interval setting k (Ts = k x 3.5 chars)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  cli::add_duration_option(&app, "--td", o.delay_td,
                           "The controller's minimum communication delay Td",
                           {Duration::zero(), seconds(1)});
  cli::add_renamed_duration_option(&app, "--delay-ms", "--td", o.delay_td,
                                   cli::BareNumber::Milliseconds, {Duration::zero(), seconds(1)});
  app.add_flag("--no-silence-wait", o.no_silence_wait,
               "Do not wait Ts of silence before each query (only for a --timing fast twin or TCP; "
               "never on RS485)");
  cli::add_duration_option(&app, "--reply-spin", o.reply_spin,
                           "Look for each reply this long without sleeping before sleeping on "
                           "the port (busy-waits a core; only for a --timing fast twin, where "
                           "150us gains a third in rate; never on RS485)",
                           {Duration::zero(), milliseconds(1)});
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lec: drive SMC LEC\u25A16 electric-actuator controllers over RS485 (Modbus RTU)",
               "lec"};
  app.footer(kSubcommandFooter);
  app.set_version_flag("--version", std::string("lec ") + LEC6_VERSION_STRING,
                       "Print the version and exit");
  app.require_subcommand(1);
  app.fallthrough();
  cli::GlobalOptions options;
  add_global_options(app, options);
  cli::Session session(options);
  cli::add_status_commands(app, session);
  cli::add_motion_commands(app, session);
  cli::add_line_commands(app, session);
  cli::add_demo_command(app, session);
  cli::add_step_commands(app, session);
  cli::add_sim_command(app, options);
  cli::add_serve_command(app, options);
  cli::add_follow_command(app, session);
  cli::add_sniff_command(app, options);
  cli::add_replay_command(app, options);
  cli::add_doctor_command(app, session);
  app.footer(std::string(kExitCodes) + kPorts);
  cli::add_history_commands(app, options);  // issue 26
  cli::add_cycle_commands(app, options);    // issue 34
  install_signal_handlers();

  try {
    app.parse(argc, argv);
    return cli::kSuccess;
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // A mistyped command: name the nearest one rather than CLI11's generic words.
    if (auto m = cli::unknown_command_message(app, argc, argv)) return fail(cli::kUsage, *m);
    // Every usage error starts with `lec:`, CLI11's own too (issue 27).
    return fail(cli::kUsage, fmt::format("{}\nRun with --help for more information.", e.what()));
  } catch (const cli::UsageError& e) {
    return fail(cli::kUsage, e.what());
  } catch (const client::InvalidRequest& e) {
    return fail(cli::kUsage, e.what());
  } catch (const InvalidArgument& e) {  // a port spec, an option value, a configuration
    return fail(cli::kUsage, e.what());
  } catch (const std::invalid_argument& e) {  // a number the standard library could not convert
    return fail(cli::kUsage, e.what());
  } catch (const client::TransportError& e) {
    return fail(cli::kTransport, e.what());
  } catch (const client::LinkError& e) {
    return fail(cli::kTransport, e.what());
  } catch (const client::ControllerException& e) {
    return fail(cli::kException, e.what());
  } catch (const client::AlarmError& e) {
    return fail(cli::kAlarm, e.what());
  } catch (const client::DeadlineError& e) {
    return fail(cli::kDeadline, e.what());
  } catch (const client::Cancelled& e) {
    return fail(cli::kInterrupted, e.what());
  } catch (const client::MoveNotStarted& e) {
    return fail(cli::kFailure, e.what());
  } catch (const cli::CommandFailed& e) {
    return fail(e.code(), e.what());
  } catch (const std::exception& e) {
    return fail(cli::kFailure, e.what());
  }
}
