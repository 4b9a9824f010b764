// `lec history` and `lec health`: a running `lec serve`'s move history,
// odometer and drift warnings (docs/history.md), read over its HTTP API.
// The daemon is --daemon URL, else $LEC_DAEMON, else the host of a
// `--port tcp://HOST:PORT` (lec serve's Modbus TCP) on port 8080, else
// http://127.0.0.1:8080.

#include <asio.hpp>

#include <cstdlib>

#include "cli/app.hpp"
#include "lec6/transport/port_spec.hpp"

namespace lec6::cli {
namespace {

struct DaemonArgs {
  std::string daemon;
  std::string axis;
};

struct HistoryArgs : DaemonArgs {
  std::string since, until, kind, outcome, source;
  int step = -1;
  int limit = 20;
  int64_t before = 0;
  bool csv = false;
};

struct Url {
  std::string host, port, base_path;
};

Url daemon_url(const GlobalOptions& g, const std::string& given) {
  std::string text = given;
  if (text.empty()) {
    if (const char* env = std::getenv("LEC_DAEMON"); env && *env) text = env;
  }
  if (text.empty()) {
    std::string port = g.port;
    if (port.empty()) {
      if (const char* env = std::getenv("LEC_PORT"); env && *env) port = env;
    }
    text = "http://127.0.0.1:8080";
    if (port.rfind("tcp://", 0) == 0) {
      try {
        const auto spec = transport::parse_port_spec(port);
        if (spec.kind == transport::PortKind::Tcp) text = fmt::format("http://{}:8080", spec.host);
      } catch (const std::exception&) {
      }
    }
  }
  if (text.rfind("http://", 0) != 0) {
    throw UsageError(
        fmt::format("--daemon: '{}' is not http://HOST:PORT (lec serve's --http)", text));
  }
  std::string rest = text.substr(7);
  Url u;
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    u.base_path = rest.substr(slash);
    rest.resize(slash);
    while (!u.base_path.empty() && u.base_path.back() == '/') u.base_path.pop_back();
  }
  const auto colon = rest.rfind(':');
  if (colon == std::string::npos || rest.back() == ']') {
    u.host = rest;
    u.port = "80";
  } else {
    u.host = rest.substr(0, colon);
    u.port = rest.substr(colon + 1);
  }
  if (u.host.size() > 1 && u.host.front() == '[') u.host = u.host.substr(1, u.host.size() - 2);
  if (u.host.empty()) throw UsageError(fmt::format("--daemon: '{}' has no host", text));
  return u;
}

std::string encode(const std::string& s) {
  std::string out;
  for (unsigned char c : s) {
    if (std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '~' || c == ':') {
      out += static_cast<char>(c);
    } else {
      out += fmt::format("%{:02X}", c);
    }
  }
  return out;
}

struct Reply {
  int status = 0;
  std::string body;
};

// One GET over HTTP/1.1 with Connection: close; the body is what follows
// the headers (lec serve answers with Content-Length, never chunked here).
Reply get(const Url& u, const std::string& target) {
  asio::io_context io;
  asio::ip::tcp::resolver resolver(io);
  asio::ip::tcp::socket socket(io);
  asio::error_code ec;
  const auto endpoints = resolver.resolve(u.host, u.port, ec);
  if (!ec) asio::connect(socket, endpoints, ec);
  if (ec) {
    throw CommandFailed(kTransport, fmt::format("lec serve at http://{}:{} does not answer: {} "
                                                "(is it running, with --http?)",
                                                u.host, u.port, ec.message()));
  }
  const std::string request =
      fmt::format("GET {}{} HTTP/1.1\r\nHost: {}:{}\r\nConnection: close\r\nAccept: */*\r\n\r\n",
                  u.base_path, target, u.host, u.port);
  asio::write(socket, asio::buffer(request), ec);
  std::string data;
  std::array<char, 65536> buf{};
  for (;;) {
    const std::size_t n = socket.read_some(asio::buffer(buf), ec);
    data.append(buf.data(), n);
    if (ec) break;
  }
  const auto end = data.find("\r\n\r\n");
  if (data.rfind("HTTP/1.", 0) != 0 || end == std::string::npos) {
    throw CommandFailed(kTransport,
                        fmt::format("http://{}:{} did not answer in HTTP", u.host, u.port));
  }
  Reply r;
  r.status = std::atoi(data.c_str() + 9);
  r.body = data.substr(end + 4);
  return r;
}

nlohmann::json get_json(const Url& u, const std::string& target) {
  const Reply r = get(u, target);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(r.body);
  } catch (const nlohmann::json::exception&) {
    throw CommandFailed(kFailure, fmt::format("lec serve answered {} without JSON", r.status));
  }
  if (r.status == 400) throw UsageError(j.value("error", "bad request"));
  if (r.status != 200)
    throw CommandFailed(kFailure, j.value("error", fmt::format("HTTP {}", r.status)));
  return j;
}

std::string num(const nlohmann::json& j, const char* key, const char* fmt_spec = "{:.2f}") {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return "-";
  return fmt::format(fmt::runtime(fmt_spec), it->get<double>());
}

void run_history(const GlobalOptions& g, const HistoryArgs& a) {
  const Url u = daemon_url(g, a.daemon);
  std::string q = fmt::format("limit={}", a.limit);
  if (!a.since.empty()) q += "&since=" + encode(a.since);
  if (!a.until.empty()) q += "&until=" + encode(a.until);
  if (!a.kind.empty()) q += "&kind=" + encode(a.kind);
  if (!a.outcome.empty()) q += "&outcome=" + encode(a.outcome);
  if (!a.source.empty()) q += "&source=" + encode(a.source);
  if (a.step >= 0) q += fmt::format("&step={}", a.step);
  if (a.before > 0) q += fmt::format("&before={}", a.before);
  const std::string target = fmt::format("/api/axes/{}/history?{}", encode(a.axis), q);
  if (a.csv) {
    const Reply r = get(u, target + "&format=csv");
    if (r.status != 200) {
      std::string msg = r.body;
      try {
        msg = nlohmann::json::parse(r.body).value("error", r.body);
      } catch (const nlohmann::json::exception&) {
      }
      if (r.status == 400) throw UsageError(msg);
      throw CommandFailed(kFailure, msg);
    }
    fmt::print("{}", r.body);
    return;
  }
  const auto j = get_json(u, target);
  if (g.json) return print_json(j);
  fmt::print("{:>7}  {:<24} {:<9} {:<8} {:>9} {:>8} {:>8} {:>8} {:>7}  {}\n", "id", "start (UTC)",
             "kind", "outcome", "target_mm", "time_s", "settle_s", "thrust%", "err_mm", "source");
  for (const auto& r : j["records"]) {
    std::string start = r.value("start", "");
    if (start.size() > 23) start.resize(23);
    fmt::print("{:>7}  {:<24} {:<9} {:<8} {:>9} {:>8} {:>8} {:>8} {:>7}  {}\n",
               r.value("id", int64_t{0}), start, r.value("kind", ""), r.value("outcome", ""),
               num(r, "target_mm"), num(r, "duration_s", "{:.3f}"), num(r, "settle_s", "{:.3f}"),
               num(r, "peak_thrust_pct", "{:.0f}"), num(r, "final_error_mm"),
               r.value("source", ""));
  }
  if (j["records"].empty()) fmt::print("(no motions recorded for {} with these filters)\n", a.axis);
  if (j["next_before"].is_number()) {
    fmt::print("(older ones: the same with --before {})\n", j["next_before"].get<int64_t>());
  }
}

void run_health(const GlobalOptions& g, const DaemonArgs& a) {
  const Url u = daemon_url(g, a.daemon);
  const auto j = get_json(u, fmt::format("/api/axes/{}/health", encode(a.axis)));
  if (g.json) return print_json(j);
  const auto& o = j["odometer"];
  fmt::print("{}: {}\n", a.axis, j.value("ok", false) ? "healthy" : "needs attention");
  fmt::print("  odometer: {} moves, {:.3f} km, {:.2f} h in motion, {} pushes, {} alarms\n",
             o.value("moves", int64_t{0}), o.value("distance_m", 0.0) / 1000,
             o.value("motion_h", 0.0), o.value("pushes", int64_t{0}),
             o.value("alarms", int64_t{0}));
  for (const auto& s : j["service"]) fmt::print("  service due: {}\n", s.value("message", ""));
  for (const auto& w : j["warnings"]) {
    fmt::print("  drift: {} (moves {})\n", w.value("message", ""), w["moves"].dump());
  }
  fmt::print("  groups: {}\n", j["groups"].size());
  for (const auto& gr : j["groups"]) {
    fmt::print("    #{} {} ({} moves{})\n", gr.value("group_id", 0), gr.value("group", ""),
               gr.value("moves", 0), gr["baseline"].is_null() ? ", learning its baseline" : "");
  }
  if (j["storage"].contains("disabled")) {
    fmt::print("  storage: {}\n", j["storage"]["disabled"].get<std::string>());
  }
}

void add_daemon_options(CLI::App* cmd, DaemonArgs& a) {
  cmd->add_option("axis", a.axis, "The axis' name in lec serve (GET /api/axes lists them)")
      ->required();
  cmd->add_option("--daemon", a.daemon,
                  "lec serve's HTTP API (default: $LEC_DAEMON, else port 8080 on the host of "
                  "--port tcp://HOST:PORT, else http://127.0.0.1:8080)")
      ->type_name("URL");
}

}  // namespace

void add_history_commands(CLI::App& app, const GlobalOptions& globals) {
  auto h = std::make_shared<HistoryArgs>();
  auto* history = app.add_subcommand(
      "history", "The motions lec serve recorded for an axis, newest first (docs/history.md)");
  add_daemon_options(history, *h);
  history->add_option("--since", h->since, "From this UTC time or date (2026-11-24T10:00:00Z)")
      ->type_name("TIME");
  history->add_option("--until", h->until, "Before this UTC time or date")->type_name("TIME");
  history->add_option("--kind", h->kind, "home, move, run-step or jog")
      ->check(CLI::IsMember({"home", "move", "run-step", "jog"}));
  history->add_option(
      "--outcome", h->outcome,
      "reached, pushed, push_missed, stopped, alarm, deadline, not_started or refused");
  history->add_option("--source", h->source,
                      "Who started it: the start of the recorded source (mqtt, http, telemetry)");
  history->add_option("--step", h->step, "Run-step moves of this step")->check(CLI::Range(0, 63));
  history->add_option("--limit", h->limit, "At most this many records")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  history->add_option("--before", h->before, "Only records older than this id (paging)")
      ->type_name("ID")
      ->check(CLI::PositiveNumber);
  history->add_flag("--csv", h->csv, "CSV, one row per motion (every column of the API)");
  history->callback([&globals, h] { run_history(globals, *h); });

  auto d = std::make_shared<DaemonArgs>();
  auto* health = app.add_subcommand(
      "health", "An axis' odometer, service notices and drift warnings from lec serve");
  add_daemon_options(health, *d);
  health->callback([&globals, d] { run_health(globals, *d); });
}

}  // namespace lec6::cli
