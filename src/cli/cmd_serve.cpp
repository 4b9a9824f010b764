// `lec serve`: the bus owner (src/serve/). Reads its config (or makes one
// from the global options and --ids), prints where it listens, and runs until
// SIGTERM or Ctrl-C.

#include <fmt/chrono.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <mutex>

#include "cli/app.hpp"
#include "lec6/serve/daemon.hpp"
#include "lec6/serve/mqtt_topics.hpp"

namespace lec6::cli {
namespace {

struct ServeArgs {
  std::string config;
  std::string ids = "1";
  double telemetry_hz = 10;
  std::string modbus_tcp = "127.0.0.1:1502";
  std::string rtu_tcp;
  std::string http = "127.0.0.1:8080";
  std::string token;
  std::string sim_timing = "real";
  std::string mqtt;  // broker URL: the bridge with its defaults (docs/mqtt.md)
  std::string mqtt_prefix = "lec6";
  std::string record;       // --record FILE (also the global --record)
  std::string state_dir;    // the move history (docs/history.md)
  bool no_history = false;  // issue 32: on by default, in the default directory
  bool check = false;
  std::string sparkplug;  // issue 35: broker URL of the Sparkplug B edge node (docs/sparkplug.md)
  std::string sparkplug_group;  // default: the file's, else lec6
  std::string sparkplug_node;   // default: the host name
  std::string sparkplug_host;   // the primary host application to wait for
  std::string cycles;           // issue 34: a cycle file or a directory of them (docs/cycles.md)
};

// --sparkplug BROKER: the edge node with its defaults, with or without --config.
void apply_sparkplug(const ServeArgs& a, serve::ServeConfig& c) {
  if (a.sparkplug.empty()) return;
  serve::SparkplugConfig s = c.sparkplug.value_or(serve::SparkplugConfig{});
  s.broker = a.sparkplug;
  try {
    (void)s.url();
  } catch (const std::invalid_argument& e) {
    throw UsageError(fmt::format("--sparkplug: {}", e.what()));
  }
  if (!a.sparkplug_group.empty()) s.group_id = a.sparkplug_group;
  if (!a.sparkplug_node.empty()) s.edge_node_id = a.sparkplug_node;
  if (!a.sparkplug_host.empty()) s.primary_host_id = a.sparkplug_host;
  for (auto [flag, id] : {std::pair{"--sparkplug-group", &s.group_id},
                          {"--sparkplug-node", &s.edge_node_id},
                          {"--sparkplug-host", &s.primary_host_id}}) {
    if (id->empty()) continue;
    if (const auto why = serve::check_sparkplug_id(*id)) {
      throw UsageError(fmt::format("{}: {}", flag, *why));
    }
  }
  for (const auto& l : c.lines) {
    for (const auto& ax : l.axes) {
      if (const auto why = serve::check_sparkplug_id(ax.name)) {
        throw UsageError(fmt::format("--sparkplug: axis {} as a device id: {}", ax.name, *why));
      }
    }
  }
  c.sparkplug = s;
}

void log_line(serve::LogLevel level, std::string_view text) {
  static std::mutex m;
  std::lock_guard lock(m);
  const auto now = std::chrono::system_clock::now();
  const char* tag = level == serve::LogLevel::Warning ? "warning: "
                    : level == serve::LogLevel::Error ? "error: "
                                                      : "";
  fmt::print(stderr, "{:%H:%M:%S} lec serve: {}{}\n",
             std::chrono::floor<std::chrono::milliseconds>(now), tag, text);
}

serve::ServeConfig make_config_of(const GlobalOptions& g, const ServeArgs& a);

// The move history is on by default (issue 32): without --state-dir or a
// history: section, in the default directory (serve/history/state_dir.hpp);
// --no-history or `history: false` keep none.
serve::ServeConfig make_config(const GlobalOptions& g, const ServeArgs& a) {
  if (a.no_history && !a.state_dir.empty()) {
    throw UsageError("give either --state-dir DIR or --no-history, not both");
  }
  auto c = make_config_of(g, a);
  if (!a.cycles.empty()) serve::add_cycles(c, a.cycles);  // beside the config's cycles:
  if (a.no_history) {
    c.history.reset();
  } else if (!c.history && !c.history_off) {
    c.history = serve::HistoryConfig{};  // an empty state_dir: the default directory
  }
  return c;
}

serve::ServeConfig make_config_of(const GlobalOptions& g, const ServeArgs& a) {
  if (!a.config.empty()) {
    if (!g.port.empty()) {
      throw UsageError("give either --config FILE or --port with --ids, not both");
    }
    if (g.alarm_polarity != "active-high") {
      throw UsageError(
          "--alarm-polarity (LEC_ALARM_POLARITY) with --config: set alarm_polarity: in the file, "
          "per line or per axis (docs/serve.md)");
    }
    if (g.sim_profile != "default") {
      throw UsageError(
          "--sim-profile (LEC_SIM_PROFILE) with --config: set sim: {profile: ...} on the sim "
          "line in the file (docs/serve.md)");
    }
    auto c = serve::load_config(a.config);
    if (!a.state_dir.empty()) {  // --state-dir wins over the file's history.state_dir
      if (!c.history) c.history = serve::HistoryConfig{};
      c.history->state_dir = a.state_dir;
    }
    apply_sparkplug(a, c);
    return c;
  }
  serve::FlagConfig f;
  f.port = g.port;
  if (f.port.empty()) {
    if (const char* env = std::getenv("LEC_PORT"); env && *env) f.port = env;
  }
  f.ids = a.ids;
  f.baud = g.baud;
  f.telemetry_hz = a.telemetry_hz;
  f.modbus_tcp = a.modbus_tcp;
  f.rtu_tcp = a.rtu_tcp;
  f.http = a.http;
  f.token = a.token;
  f.fast_sim = a.sim_timing == "fast";
  f.state_dir = a.state_dir;
  // The global --alarm-polarity (LEC_ALARM_POLARITY): every axis of the line;
  // a --config gives it per line or axis (`alarm_polarity:`).
  f.alarm_polarity =
      lec::parse_alarm_polarity(g.alarm_polarity).value_or(lec::AlarmPolarity::ActiveHigh);
  f.sim_profile = g.sim_profile;
  auto c = serve::config_from_flags(f);
  if (!a.mqtt.empty()) {
    serve::MqttConfig m;
    m.broker = a.mqtt;
    m.prefix = a.mqtt_prefix;
    try {
      (void)m.url();
    } catch (const std::invalid_argument& e) {
      throw UsageError(fmt::format("--mqtt: {}", e.what()));
    }
    if (const auto why = serve::check_topic_prefix(m.prefix)) {
      throw UsageError(fmt::format("--mqtt-prefix: {}", *why));
    }
    c.mqtt = m;
  }
  apply_sparkplug(a, c);
  auto& line = c.lines.front();
  line.silent_interval = g.silent_interval_k;
  line.delay_ms = to_ms(g.delay_td);
  line.timeout_margin_ms = to_ms(g.reply_margin);
  line.retries = g.retries;
  line.echo = g.echo;
  line.rs485 = {g.rs485, g.rs485_rts_after_send, whole_ms(g.rs485_delay_before),
                whole_ms(g.rs485_delay_after)};
  return c;
}

void run_serve(const GlobalOptions& g, const ServeArgs& a) {
  serve::ServeConfig config;
  try {
    config = make_config(g, a);
  } catch (const serve::ConfigError& e) {
    throw UsageError(e.what());
  }
  if (a.check) {
    fmt::print(
        "{}: OK ({} line{}, {} ax{}{})\n", config.source, config.lines.size(),
        config.lines.size() == 1 ? "" : "s",
        [&] {
          std::size_t n = 0;
          for (const auto& l : config.lines) n += l.axes.size();
          return n;
        }(),
        "es",
        config.cycles.empty() ? std::string()
                              : fmt::format(", {} cycle{}", config.cycles.size(),
                                            config.cycles.size() == 1 ? "" : "s"));
    return;
  }
  // --record FILE: one capture per line (FILE with one line, FILE-<line>.jsonl with more).
  if (const std::string& rec = a.record.empty() ? g.record : a.record; !rec.empty()) {
    const std::filesystem::path path(rec);
    // FILE-<line>.jsonl beside a pipe, a device or /dev/fd/N names nothing
    // the user made: refused before anything starts.
    std::error_code ec;
    const auto kind = std::filesystem::status(path, ec).type();
    if (config.lines.size() > 1 && kind != std::filesystem::file_type::not_found &&
        kind != std::filesystem::file_type::regular)
      throw UsageError(fmt::format(
          "--record {}: the config has {} lines and each gets its own capture, "
          "FILE-<line>{}, but {} is not a regular file (a pipe, a device or /dev/fd/N); give a "
          "file name, or run one lec serve per line",
          rec, config.lines.size(), path.extension().string(), rec));
    for (auto& l : config.lines) {
      l.record = config.lines.size() == 1
                     ? rec
                     : (path.parent_path() /
                        (path.stem().string() + "-" + l.name + path.extension().string()))
                           .string();
    }
  }
  // A --record pipe whose reader left is a write error (logged), not a death.
  std::signal(SIGPIPE, SIG_IGN);
  serve::Daemon daemon(std::move(config), log_line);
  std::string where;
  for (const auto& e : daemon.endpoints()) where += (where.empty() ? "" : ", ") + e;
  fmt::print("lec serve: ready on {}\n", where.empty() ? "(no listener)" : where);
  std::fflush(stdout);
  daemon.run(true);
  log_line(serve::LogLevel::Info, "stopped");
}

}  // namespace

void add_serve_command(CLI::App& app, const GlobalOptions& globals) {
  auto args = std::make_shared<ServeArgs>();
  auto* cmd = app.add_subcommand("serve",
                                 "Own the line(s) and share them: Modbus TCP, RTU over TCP, HTTP "
                                 "API, web dashboard, MQTT (docs/serve.md)");
  cmd->add_option("--config,-c", args->config,
                  "YAML config: lines, axes, listeners (docs/serve.md); or use --port and --ids");
  cmd->add_option("--ids", args->ids, "Controller IDs on the line, e.g. 1-4 or 1,3,5")
      ->capture_default_str();
  cmd->add_option("--telemetry-hz", args->telemetry_hz,
                  "State polling rate per axis (more than the line carries: every axis gets the "
                  "same share, and the start says how much)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1000.0));
  cmd->add_option("--modbus-tcp", args->modbus_tcp,
                  "Modbus TCP listener ADDRESS:PORT (empty: none)")
      ->capture_default_str();
  cmd->add_option("--rtu-tcp", args->rtu_tcp, "RTU-over-TCP listener ADDRESS:PORT (default: none)");
  cmd->add_option("--http", args->http, "HTTP listener ADDRESS:PORT (empty: none)")
      ->capture_default_str();
  cmd->add_option("--token", args->token,
                  "Token that write requests must carry when HTTP listens beyond loopback");
  cmd->add_option("--sim-timing", args->sim_timing, "Timing of the built-in twin (--port sim)")
      ->capture_default_str()
      ->check(CLI::IsMember({"real", "fast"}));
  cmd->add_option("--mqtt", args->mqtt,
                  "Bridge to this MQTT broker, e.g. mqtt://127.0.0.1:1883 or mqtts://host (the "
                  "config's mqtt: section has every setting, docs/mqtt.md)");
  cmd->add_option("--mqtt-prefix", args->mqtt_prefix, "Topic prefix of the bridge (with --mqtt)")
      ->capture_default_str();
  cmd->add_option(
         "--sparkplug", args->sparkplug,
         "Be a Sparkplug B edge node on this MQTT broker, e.g. mqtt://127.0.0.1:1883: each "
         "axis a device (the config's sparkplug: section has every setting, "
         "docs/sparkplug.md)")
      ->type_name("BROKER");
  cmd->add_option("--sparkplug-group", args->sparkplug_group,
                  "Sparkplug group id (with --sparkplug)")
      ->capture_default_str();
  cmd->add_option("--sparkplug-node", args->sparkplug_node,
                  "Sparkplug edge node id (with --sparkplug; default: the host name)");
  cmd->add_option(
      "--sparkplug-host", args->sparkplug_host,
      "Primary host application id: births wait for its STATE online (with --sparkplug)");
  cmd->add_option("--state-dir", args->state_dir,
                  "Keep the move history, odometer and drift warnings in DIR/history.db "
                  "(docs/history.md; the config's history: section has every setting). "
                  "Default: $STATE_DIRECTORY, else $XDG_STATE_HOME/lec6, else "
                  "~/.local/state/lec6")
      ->type_name("DIR");
  cmd->add_option("--cycles", args->cycles,
                  "Machine cycles to offer (POST /api/cycles/NAME/run): a cycle file or a "
                  "directory of them, beside the config's cycles: (docs/cycles.md)")
      ->type_name("PATH");
  cmd->add_flag("--no-history", args->no_history,
                "Keep no move history, odometer or drift warnings (they are on by default)");
  cmd->add_flag("--check", args->check, "Check the config and exit");
  cmd->add_option("--record", args->record,
                  "Write every frame of the line, both directions, with timestamps, to FILE (a "
                  "capture, docs/capture-format.md; with several lines FILE-<line>.jsonl each); "
                  "recording costs a transaction no time")
      ->type_name("FILE");
  cmd->callback([&globals, args] { run_serve(globals, *args); });
}

}  // namespace lec6::cli
