// ping, scan, decode, raw, ports, bench: the line itself.

#include <algorithm>
#include <cmath>
#include <thread>

#include "cli/app.hpp"
#include "cli/duration_option.hpp"
#include "lec6/lec/explain.hpp"
#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"
#include "lec6/transport/port_spec.hpp"

namespace lec6::cli {
namespace {

using modbus::Bytes;

Bytes parse_hex_args(const std::vector<std::string>& words) {
  std::string text;
  for (const auto& w : words) text += w + " ";
  auto bytes = modbus::from_hex(text);
  if (!bytes) throw UsageError(bytes.error());
  if (bytes->empty()) throw UsageError("no bytes given: e.g. lec decode 01 05 00 19 FF 00 5D FD");
  return *bytes;
}

void run_decode(const Session& s, const std::vector<std::string>& words, bool as_reply) {
  const Bytes bytes = parse_hex_args(words);
  const bool request_ok = modbus::decode_request(bytes).has_value();
  const bool reply_ok = modbus::decode_response(bytes).has_value();
  const bool reply = as_reply || (!request_ok && reply_ok);
  const std::string text =
      lec::explain_bytes(bytes, reply ? lec::FrameRole::Reply : lec::FrameRole::Request);
  if (s.json()) {
    print_json({{"hex", modbus::to_hex(bytes)},
                {"kind", reply ? "reply" : "query"},
                {"explanation", text},
                {"valid", reply ? reply_ok : request_ok}});
  } else {
    fmt::print("{}\n", text);
  }
  if (!(reply ? reply_ok : request_ok)) throw CommandFailed(kUsage, "the frame does not decode");
}

// Sends the bytes as they are on an RTU link and collects whatever comes back
// within the reply window.
Bytes exchange_bytes(client::Client& c, client::Link& link, const Bytes& frame,
                     Duration reply_margin) {
  link.discard_input();
  link.write(frame);
  const TimePoint deadline =
      c.clock().now() + c.timing().response_time(modbus::kMaxAdu) + reply_margin;
  Bytes reply;
  std::array<uint8_t, 512> buf{};
  while (c.clock().now() < deadline) {
    const std::size_t n = link.read_some(buf, deadline);
    reply.insert(reply.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(n));
    const auto len = modbus::response_length(reply);
    if (len.status == modbus::FrameLength::Status::Known && reply.size() >= len.bytes) break;
  }
  return reply;
}

// A master that carries requests rather than bytes (Modbus TCP): the frame
// must decode; the reply comes back as the RTU frame the controller sent.
Bytes exchange_request(client::Client& c, const Bytes& frame, std::string_view port) {
  const auto request = modbus::decode_request(frame);
  if (!request) {
    throw UsageError(fmt::format(
        "{} carries Modbus requests, not raw bytes, and this frame does not decode ({}): send "
        "malformed frames on a serial port, rtu+tcp:// or sim",
        port, request.error().message));
  }
  try {
    return modbus::encode_response(c.transact_raw(*request));
  } catch (const client::TransportError& e) {
    if (e.kind() != client::TransportErrorKind::Timeout) throw;
    return {};
  }
}

void run_raw(Session& s, const std::vector<std::string>& words, bool as_is) {
  Bytes frame = parse_hex_args(words);
  if (!as_is && !modbus::crc_ok(frame)) modbus::append_crc(frame);
  auto& c = s.client();
  const TimePoint start = c.clock().now();
  client::Link* link = c.master().link();
  const Bytes reply = link ? exchange_bytes(c, *link, frame, s.options().reply_margin)
                           : exchange_request(c, frame, s.port_description());
  const double ms = to_ms(c.clock().now() - start);
  const std::string sent_text = lec::explain_bytes(frame, lec::FrameRole::Request);
  std::string reply_text = "no reply";
  if (!reply.empty()) {
    // Explain the reply with the query's addresses when the query decodes.
    const auto query = modbus::decode_request(frame);
    const auto answer = modbus::decode_response(reply);
    reply_text = answer && query ? lec::explain_response(*answer, &*query)
                                 : lec::explain_bytes(reply, lec::FrameRole::Reply);
  }
  if (s.json()) {
    print_json({{"sent", modbus::to_hex(frame)},
                {"sent_explanation", sent_text},
                {"reply", modbus::to_hex(reply)},
                {"reply_explanation", reply_text},
                {"time_ms", ms}});
  } else {
    fmt::print("-> {}  | {}\n<- {}  | {} ({:.2f} ms)\n", modbus::to_hex(frame), sent_text,
               reply.empty() ? "(nothing)" : modbus::to_hex(reply), reply_text, ms);
  }
  if (reply.empty() && frame[0] != 0)
    throw client::TransportError(client::TransportErrorKind::Timeout, "no reply");
  if (reply.size() >= 2 && (reply[1] & modbus::kExceptionFlag)) {
    throw CommandFailed(kException, "the controller answered with an exception");
  }
}

struct PingArgs {
  int count = 4;
  Duration interval = std::chrono::seconds(1);
};

void run_ping(Session& s, const PingArgs& a) {
  auto& c = s.client();
  std::vector<double> rtts;
  int sent = 0;
  for (int seq = 0; (a.count == 0 || seq < a.count) && !g_interrupted; ++seq) {
    ++sent;
    try {
      c.transact_raw({static_cast<uint8_t>(s.options().id),
                      modbus::EchoRequest{0, static_cast<uint16_t>(seq)}});
      rtts.push_back(to_ms(c.last_round_trip()));
      if (!s.json())
        fmt::print("echo reply from ID {}: seq={} time={:.2f} ms\n", s.options().id, seq,
                   rtts.back());
    } catch (const client::TransportError& e) {
      if (!s.json()) fmt::print("ID {}: seq={} {}\n", s.options().id, seq, e.what());
    } catch (const client::Cancelled&) {  // Ctrl-C during an echo: end with the statistics
      --sent;
      break;
    }
    if (seq + 1 != a.count && a.interval > Duration::zero()) {
      const TimePoint next = c.clock().now() + a.interval;
      while (c.clock().now() < next && !g_interrupted)
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  g_interrupted = false;
  const double loss = sent ? 100.0 * (sent - static_cast<int>(rtts.size())) / sent : 0;
  double mn = 0, mx = 0, avg = 0, mdev = 0;
  if (!rtts.empty()) {
    mn = *std::min_element(rtts.begin(), rtts.end());
    mx = *std::max_element(rtts.begin(), rtts.end());
    for (double r : rtts) avg += r / static_cast<double>(rtts.size());
    for (double r : rtts) mdev += std::abs(r - avg) / static_cast<double>(rtts.size());
  }
  if (s.json()) {
    print_json({{"sent", sent},
                {"received", rtts.size()},
                {"loss_pct", loss},
                {"rtt_ms", {{"min", mn}, {"avg", avg}, {"max", mx}, {"mdev", mdev}}}});
  } else {
    fmt::print("--- ID {} echo statistics ---\n{} sent, {} received, {:.1f}% loss\n",
               s.options().id, sent, rtts.size(), loss);
    if (!rtts.empty())
      fmt::print("rtt min/avg/max/mdev = {:.3f}/{:.3f}/{:.3f}/{:.3f} ms\n", mn, avg, mx, mdev);
  }
  if (rtts.empty())
    throw client::TransportError(client::TransportErrorKind::Timeout, "no echo replies");
}

std::vector<int> parse_id_range(const std::string& text) {
  std::vector<int> ids;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string part = text.substr(pos, comma - pos);
    const size_t dash = part.find('-');
    try {
      const int lo = std::stoi(part.substr(0, dash));
      const int hi = dash == std::string::npos ? lo : std::stoi(part.substr(dash + 1));
      if (lo < 1 || hi > 255 || lo > hi) throw std::out_of_range("ids");
      for (int i = lo; i <= hi; ++i) ids.push_back(i);
    } catch (const std::exception&) {
      throw UsageError(fmt::format("--ids '{}': expected IDs 1-255 like 1-32 or 1,3,5", text));
    }
    pos = comma + 1;
  }
  return ids;
}

struct ScanResult {
  int id;
  std::string name;
  std::string problem;  // CRC/framing trouble instead of an answer
};

std::vector<ScanResult> scan_ids(Session& s, const std::vector<int>& ids) {
  auto& c = s.client();
  std::vector<ScanResult> found;
  for (int id : ids) {
    if (g_interrupted) break;
    try {
      c.transact_raw({static_cast<uint8_t>(id), modbus::EchoRequest{0, 0x5AA5}});
      std::string name;
      try {
        const auto regs = c.transact(
            modbus::ReadRegistersRequest{lec::kEquipmentName, lec::kEquipmentNameRegisters},
            client::Retry::Safe, static_cast<uint8_t>(id));
        name =
            lec::EquipmentName::from_registers(std::get<modbus::ReadRegistersResponse>(regs).values)
                .text;
      } catch (const std::exception&) {
      }
      found.push_back({id, name, ""});
    } catch (const client::TransportError& e) {
      if (e.kind() == client::TransportErrorKind::Crc ||
          e.kind() == client::TransportErrorKind::Framing) {
        found.push_back({id, "", e.what()});
      }
    } catch (const client::Cancelled&) {  // Ctrl-C: report what was found so far
      break;
    }
  }
  return found;
}

void run_scan(Session& s, const std::string& id_text, bool all_bauds) {
  const auto ids = parse_id_range(id_text);
  auto found = scan_ids(s, ids);
  const std::string port = s.port_description();
  const bool garbled = std::any_of(found.begin(), found.end(),
                                   [](const ScanResult& r) { return !r.problem.empty(); });
  const bool answered = std::any_of(found.begin(), found.end(),
                                    [](const ScanResult& r) { return r.problem.empty(); });
  std::optional<uint32_t> better_baud;
  if (!answered && all_bauds) {
    s.close();  // each other baud rate opens the port again
    for (uint32_t baud : modbus::kBaudRates) {
      if (baud == s.options().baud) continue;
      GlobalOptions o = s.options();
      o.baud = baud;
      o.retries = 0;
      Session other(o);
      auto r = scan_ids(other, ids);
      if (std::any_of(r.begin(), r.end(), [](const ScanResult& x) { return x.problem.empty(); })) {
        better_baud = baud;
        break;
      }
    }
  }
  if (s.json()) {
    nlohmann::json j = nlohmann::json::array();
    for (const auto& r : found) {
      j.push_back({{"id", r.id}, {"name", r.name}, {"problem", r.problem}});
    }
    print_json({{"found", j},
                {"baud", s.options().baud},
                {"suggested_baud", better_baud ? nlohmann::json(*better_baud) : nlohmann::json()}});
  } else {
    // The link's description may carry the baud already ("/dev/ttyUSB0 @ 38400"): say it once.
    const bool says_baud = port.find(fmt::format("@ {}", s.options().baud)) != std::string::npos;
    if (says_baud)
      fmt::print("Scanned IDs {} on {}\n", id_text, port);
    else
      fmt::print("Scanned IDs {} at {} baud on {}\n", id_text, s.options().baud, port);
    for (const auto& r : found) {
      if (r.problem.empty()) {
        fmt::print("  ID {:3}  answers  {}\n", r.id, r.name.empty() ? "(no name)" : r.name);
      } else {
        fmt::print("  ID {:3}  replies fail: {}\n", r.id, r.problem);
      }
    }
    if (found.empty()) fmt::print("  no controller answered\n");
  }
  const std::string hint = better_baud ? fmt::format(", the controller is at {}? (try --baud {})",
                                                     *better_baud, *better_baud)
                           : all_bauds ? std::string(": no other baud rate answered either")
                                       : std::string(" (`lec scan --all-bauds` tries the others)");
  if (garbled) {
    fmt::print(stderr, "lec: replies fail CRC: check the baud rate{}\n", hint);
  } else if (!answered && better_baud) {
    fmt::print(stderr, "lec: no answer at {} baud{}\n", s.options().baud, hint);
  }
  if (!answered) {
    throw client::TransportError(client::TransportErrorKind::Timeout, "no controller answered");
  }
}

struct BenchArgs {
  std::string op = "read-state";
  int n = 200;
};

void run_bench(Session& s, const BenchArgs& a) {
  auto& c = s.client();
  modbus::Request request;
  if (a.op == "read-state") {
    request = modbus::ReadRegistersRequest{lec::kStateData, lec::kStateDataRegisters};
  } else if (a.op == "read-flags") {
    request = modbus::ReadBitsRequest{modbus::FunctionCode::ReadInputs, lec::kStatusInputs,
                                      lec::kStatusInputCount};
  } else if (a.op == "echo") {
    request = modbus::EchoRequest{0, 0x1234};
  } else {
    throw UsageError(fmt::format("--op '{}': expected read-state, read-flags or echo", a.op));
  }
  const std::size_t query_bytes = modbus::encode_request({1, request})->size();
  const std::size_t reply_bytes = modbus::expected_response_length(request);
  c.transact(request);  // warm-up: opens the line, settles the twin
  std::vector<double> lat;
  lat.reserve(static_cast<std::size_t>(a.n));
  const TimePoint start = c.clock().now();
  try {
    for (int i = 0; i < a.n && !g_interrupted; ++i) {
      c.transact(request);
      lat.push_back(to_ms(c.last_round_trip()));
    }
  } catch (const client::Cancelled&) {  // Ctrl-C mid-transaction: report what was measured
  }
  const double total_s = to_seconds(c.clock().now() - start);
  std::sort(lat.begin(), lat.end());
  auto pct = [&](double p) {
    return lat.empty()
               ? 0.0
               : lat[std::min(lat.size() - 1,
                              static_cast<std::size_t>(p * static_cast<double>(lat.size())))];
  };
  const double limit = to_ms(c.timing().transaction_limit(query_bytes, reply_bytes));
  const double tx_per_s = total_s > 0 ? static_cast<double>(lat.size()) / total_s : 0;
  const double p50 = pct(0.5), p99 = pct(0.99), mx = lat.empty() ? 0 : lat.back();
  if (s.json()) {
    print_json({{"op", a.op},
                {"n", lat.size()},
                {"baud", c.timing().baud},
                {"tx_per_s", tx_per_s},
                {"latency_ms", {{"p50", p50}, {"p99", p99}, {"max", mx}}},
                {"limit_ms", limit},
                {"ratio", limit > 0 ? p50 / limit : 0},
                {"retries", c.stats().retries}});
  } else {
    fmt::print("{} x {} on {}\n", lat.size(), a.op, s.port_description());
    fmt::print("  {:.1f} transactions/s\n  latency p50 {:.3f} ms  p99 {:.3f} ms  max {:.3f} ms\n",
               tx_per_s, p50, p99, mx);
    fmt::print(
        "  limit {:.3f} ms (query wire + Ts + 4 ms + Td + reply wire)  ratio p50/limit {:.3f}\n",
        limit, limit > 0 ? p50 / limit : 0);
  }
}

}  // namespace

void add_line_commands(CLI::App& app, Session& session) {
  auto ping_args = std::make_shared<PingArgs>();
  auto* ping = app.add_subcommand("ping", "Echo test (FC08) with round-trip times and statistics");
  ping->add_option("-c,--count", ping_args->count, "How many echoes (0: until Ctrl-C)")
      ->capture_default_str();
  add_duration_option(ping, "-i,--interval", ping_args->interval, "Pause between echoes",
                      {Duration::zero(), std::chrono::hours(1)}, BareNumber::Seconds);
  ping->callback([&session, ping_args] { run_ping(session, *ping_args); });

  auto ids = std::make_shared<std::string>("1-32");
  auto all_bauds = std::make_shared<bool>(false);
  auto* scan =
      app.add_subcommand("scan", "Which controller IDs answer on the bus, with their names");
  scan->add_option("--ids", *ids, "IDs to try, e.g. 1-32 or 1,3,5")->capture_default_str();
  scan->add_flag("--all-bauds", *all_bauds,
                 "When replies fail, try the other baud rates to find the controller's");
  scan->callback([&session, ids, all_bauds] { run_scan(session, *ids, *all_bauds); });

  auto words = std::make_shared<std::vector<std::string>>();
  auto as_reply = std::make_shared<bool>(false);
  auto* decode = app.add_subcommand("decode", "Explain a frame in LEC terms (no port needed)");
  decode->add_option("hex", *words, "The frame, e.g. 01 05 00 19 FF 00 5D FD")->required();
  decode->add_flag("--reply", *as_reply, "Read it as a controller's reply");
  decode->callback([&session, words, as_reply] { run_decode(session, *words, *as_reply); });

  auto as_is = std::make_shared<bool>(false);
  auto* raw = app.add_subcommand(
      "raw", "Send a frame as given (CRC appended unless present) and show the reply");
  raw->add_option("hex", *words, "The frame, e.g. 01 03 90 00 00 07")->required();
  raw->add_flag("--as-is", *as_is, "Send the bytes exactly as given (no CRC added)");
  raw->callback([&session, words, as_is] { run_raw(session, *words, *as_is); });

  app.add_subcommand("ports", "List the serial ports of this machine")->callback([&session] {
    const auto ports = transport::list_serial_ports();
    if (session.json()) {
      nlohmann::json j = nlohmann::json::array();
      for (const auto& p : ports) j.push_back({{"path", p.path}, {"description", p.description}});
      print_json(j);
      return;
    }
    if (ports.empty()) fmt::print("No serial ports found.\n");
    for (const auto& p : ports) fmt::print("{}  {}\n", p.path, p.description);
  });

  auto bench_args = std::make_shared<BenchArgs>();
  auto* bench =
      app.add_subcommand("bench", "Measure transactions/s and latency against the wire limit");
  bench->add_option("--op", bench_args->op, "read-state (D9000x7), read-flags (X40x16) or echo")
      ->capture_default_str();
  bench->add_option("-n", bench_args->n, "Transactions")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000000));
  bench->callback([&session, bench_args] { run_bench(session, *bench_args); });
}

}  // namespace lec6::cli
