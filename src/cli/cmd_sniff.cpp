// `lec sniff`: listen to an RTU line through a second adapter (never
// transmitting), or replay a capture file, through modbus::Sniffer; print
// every frame decoded in the manual's terms, the timing verdicts and the
// statistics per ID. docs/sniff.md.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <optional>

#include <fmt/color.h>

#include "cli/app.hpp"
#include "cli/cmd_sniff_pcap.hpp"
#include "cli/sniff_output.hpp"
#include "lec6/modbus/sniffer.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/transport/fd.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/version.hpp"

namespace lec6::cli {
namespace {

using modbus::CaptureDir;
using modbus::SniffEvent;
using modbus::SniffKind;

struct SniffArgs {
  std::string read;
  std::string capture;
  std::string filter;
  std::string pcap;
  bool no_timing = false;
};

std::atomic<bool> g_stats_wanted{false};

void on_usr1(int) {
  g_stats_wanted = true;
}

// The port, opened read-only: this program never transmits on the line.
transport::UniqueFd open_listen_only(const std::string& path, uint32_t baud) {
  transport::UniqueFd fd(::open(path.c_str(), O_RDONLY | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
  if (!fd) {
    throw CommandFailed(kTransport, fmt::format("cannot open {}: {}", path, std::strerror(errno)));
  }
  // Listen-only (issue 33): RTS and DTR low, so an RS485 adapter whose driver
  // enable follows RTS (or DTR) never drives the bus. The kernel raises both
  // on open: lowered first thing, before the port is configured, to keep that
  // window as short as a program can (and again below, once configured). A
  // pty has no modem lines: the ioctl fails there and nothing is lost.
  const int modem_lines = TIOCM_RTS | TIOCM_DTR;
  (void)::ioctl(fd.get(), TIOCMBIC, &modem_lines);
  termios tio{};
  if (::tcgetattr(fd.get(), &tio) != 0) {
    throw CommandFailed(kTransport,
                        fmt::format("{} is not a serial port: {}", path, std::strerror(errno)));
  }
  ::cfmakeraw(&tio);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  ::cfsetispeed(&tio, transport::termios_speed(baud));
  ::cfsetospeed(&tio, transport::termios_speed(baud));
  if (::tcsetattr(fd.get(), TCSANOW, &tio) != 0) {
    throw CommandFailed(kTransport,
                        fmt::format("cannot configure {}: {}", path, std::strerror(errno)));
  }
  // HUPCL off keeps a later close from toggling RTS and DTR.
  tio.c_cflag &= ~static_cast<tcflag_t>(HUPCL);
  (void)::tcsetattr(fd.get(), TCSANOW, &tio);
  (void)::ioctl(fd.get(), TIOCMBIC, &modem_lines);
  // What the driver (or a pty: the twin's tap) held before we listened is no
  // part of this session: its times are lost, and it would be shown as now.
  ::tcflush(fd.get(), TCIFLUSH);
  return fd;
}

// Everything an event passes through: the filter, the printer, the capture.
class Sink {
 public:
  Sink(SniffPrinter& printer, const SniffFilter& filter,
       std::optional<transport::CaptureWriter>& capture, std::optional<PcapWriter>& pcap,
       TimePoint origin, std::chrono::system_clock::time_point wall_origin)
      : printer_(printer),
        filter_(filter),
        capture_(capture),
        pcap_(pcap),
        origin_(origin),
        wall_origin_(wall_origin) {}

  void take(modbus::Sniffer& sniffer) {
    for (const SniffEvent& e : sniffer.take()) {
      if (capture_ && e.kind != SniffKind::NoReply) capture_->write(record(e));
      if (pcap_ && (e.kind == SniffKind::Query || e.kind == SniffKind::Reply)) {
        pcap_->write(e.bytes,
                     wall_origin_ + std::chrono::duration_cast<std::chrono::system_clock::duration>(
                                        e.last_byte - origin_));
      }
      if (filter_.passes(e)) printer_.event(e);
    }
  }

 private:
  modbus::CaptureRecord record(const SniffEvent& e) const {
    modbus::CaptureRecord r;
    r.t_us = std::chrono::duration_cast<std::chrono::microseconds>(e.first_byte - origin_).count();
    r.end_us = std::chrono::duration_cast<std::chrono::microseconds>(e.last_byte - origin_).count();
    r.t_us = std::max<int64_t>(0, std::min(r.t_us, r.end_us));
    r.dir = e.kind == SniffKind::Query   ? CaptureDir::Query
            : e.kind == SniffKind::Reply ? CaptureDir::Reply
                                         : CaptureDir::Noise;
    r.bytes = e.bytes;
    r.note = flag_words(e);
    return r;
  }

  SniffPrinter& printer_;
  const SniffFilter& filter_;
  std::optional<transport::CaptureWriter>& capture_;
  std::optional<PcapWriter>& pcap_;
  TimePoint origin_;
  std::chrono::system_clock::time_point wall_origin_;
};

modbus::CaptureHeader header_for(const std::string& port, uint32_t baud) {
  modbus::CaptureHeader h;
  h.source = "sniff";
  h.started_utc = modbus::format_capture_utc(std::chrono::system_clock::now());
  h.line = {baud, 'N', 8, 1};
  h.port = port;
  h.tool = std::string("lec ") + LEC6_VERSION_STRING;
  return h;
}

void run_read(const SniffArgs& a, modbus::SnifferOptions options, bool json) {
  const modbus::Capture capture = transport::read_capture_file(a.read);
  options.timing.baud = capture.header.line.baud;
  modbus::Sniffer sniffer(options);
  const TimePoint origin{};
  SniffPrinter printer(json, origin, options.timing);
  const SniffFilter filter = SniffFilter::parse(a.filter);
  std::optional<transport::CaptureWriter> out;
  if (!a.capture.empty()) {
    modbus::CaptureHeader h = capture.header;
    h.source = "sniff";
    keep_earlier_capture_said(a.capture);
    out.emplace(a.capture, h);
  }
  std::optional<PcapWriter> pcap;
  if (!a.pcap.empty()) pcap.emplace(a.pcap);
  std::chrono::system_clock::time_point wall{};
  {
    std::tm tm{};  // started_utc, when the capture has a usable one
    unsigned year = 0, mon = 0, day = 0, h = 0, m = 0, sec = 0, us = 0;
    if (std::sscanf(capture.header.started_utc.c_str(), "%4u-%2u-%2uT%2u:%2u:%2u.%6u", &year, &mon,
                    &day, &h, &m, &sec, &us) >= 6) {
      tm.tm_year = static_cast<int>(year) - 1900;
      tm.tm_mon = static_cast<int>(mon) - 1;
      tm.tm_mday = static_cast<int>(day);
      tm.tm_hour = static_cast<int>(h);
      tm.tm_min = static_cast<int>(m);
      tm.tm_sec = static_cast<int>(sec);
      wall = std::chrono::system_clock::from_time_t(::timegm(&tm)) + std::chrono::microseconds(us);
    }
  }
  Sink sink(printer, filter, out, pcap, origin, wall);
  if (!json) {
    printer.notice(fmt::format("reading {}: {} records, {} baud, recorded {} by {}", a.read,
                               capture.records.size(), capture.header.line.baud,
                               capture.header.started_utc, capture.header.tool));
  }
  // Records that end at the same instant came in one read (a lumping
  // adapter's): they are fed as one chunk, so the sniffer sees the lumps as
  // it did live and does not judge timing on lump times.
  TimePoint last = origin;
  modbus::Bytes chunk;
  const auto& records = capture.records;
  for (std::size_t i = 0; i < records.size(); ++i) {
    chunk.insert(chunk.end(), records[i].bytes.begin(), records[i].bytes.end());
    if (i + 1 < records.size() && records[i + 1].end_us == records[i].end_us) continue;
    last = origin + std::chrono::microseconds(records[i].end_us);
    sniffer.feed(chunk, last);
    chunk.clear();
    sink.take(sniffer);
  }
  sniffer.finish(last + options.reply_wait + options.idle_gap);
  sink.take(sniffer);
  if (out) out->close();
  if (pcap) pcap->close();
  printer.stats(sniffer.stats(), sniffer.options());
}

void run_port(const SniffArgs& a, const GlobalOptions& g, modbus::SnifferOptions options) {
  if (g.port.empty()) {
    throw UsageError("sniff: give --port PATH (the second adapter on the line) or --read FILE");
  }
  transport::UniqueFd fd = open_listen_only(g.port, g.baud);
  SteadyClock clock;
  const TimePoint origin = clock.now();
  modbus::Sniffer sniffer(options);
  SniffPrinter printer(g.json, origin, options.timing);
  const SniffFilter filter = SniffFilter::parse(a.filter);
  std::optional<transport::CaptureWriter> out;
  const modbus::CaptureHeader header = header_for(g.port, g.baud);
  const auto wall_origin = std::chrono::system_clock::now();
  if (!a.capture.empty()) {
    keep_earlier_capture_said(a.capture);
    out.emplace(a.capture, header);
  }
  std::optional<PcapWriter> pcap;
  if (!a.pcap.empty()) pcap.emplace(a.pcap);
  Sink sink(printer, filter, out, pcap, origin, wall_origin);

  struct sigaction sa {};
  sa.sa_handler = on_usr1;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGUSR1, &sa, nullptr);
  const bool keys = ::isatty(STDIN_FILENO) == 1;
  termios saved{};
  if (keys) {
    ::tcgetattr(STDIN_FILENO, &saved);
    termios raw = saved;
    raw.c_lflag &= ~static_cast<tcflag_t>(ICANON | ECHO);
    ::tcsetattr(STDIN_FILENO, TCSANOW, &raw);
  }
  struct Restore {
    bool on;
    termios t;
    ~Restore() {
      if (on) ::tcsetattr(STDIN_FILENO, TCSANOW, &t);
    }
  } restore{keys, saved};

  printer.notice(fmt::format(
      "listening on {} at {} baud, listen-only: lec sniff never transmits{}", g.port, g.baud,
      keys ? " (s: statistics, Ctrl-C: stop)" : " (SIGUSR1: statistics, Ctrl-C: stop)"));
  std::array<uint8_t, 4096> buf{};
  while (!g_interrupted) {
    pollfd fds[2] = {{fd.get(), POLLIN, 0}, {STDIN_FILENO, POLLIN, 0}};
    int timeout_ms = -1;
    if (auto d = sniffer.deadline()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(*d - clock.now());
      timeout_ms = static_cast<int>(std::max<int64_t>(0, left.count() + 1));
    }
    if (printer.dirty()) {  // lines waiting: out within flush_within()
      const auto within =
          std::chrono::duration_cast<std::chrono::milliseconds>(SniffPrinter::flush_within());
      timeout_ms = timeout_ms < 0 ? static_cast<int>(within.count())
                                  : std::min(timeout_ms, static_cast<int>(within.count()));
    }
    const int r = ::poll(fds, keys ? 2 : 1, timeout_ms);
    if (r < 0 && errno != EINTR) throw SystemError(errno, "poll");
    if (r > 0 && (fds[0].revents & POLLIN)) {
      for (;;) {
        const ssize_t n = ::read(fd.get(), buf.data(), buf.size());
        if (n > 0) {
          sniffer.feed(std::span<const uint8_t>(buf.data(), static_cast<std::size_t>(n)),
                       clock.now());
          // A short read took all there was: no second read just for EAGAIN.
          if (static_cast<std::size_t>(n) < buf.size()) break;
          continue;
        }
        if (n < 0 && (errno == EAGAIN || errno == EINTR)) break;
        throw CommandFailed(kTransport, fmt::format("{}: the port went away ({})", g.port,
                                                    n < 0 ? std::strerror(errno) : "hang-up"));
      }
    } else if (r > 0 && (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL))) {
      throw CommandFailed(kTransport, fmt::format("{}: the port went away", g.port));
    }
    if (r > 0 && keys && (fds[1].revents & POLLIN)) {
      char c = 0;
      if (::read(STDIN_FILENO, &c, 1) == 1 && (c == 's' || c == 'S')) g_stats_wanted = true;
    }
    sniffer.advance(clock.now());
    sink.take(sniffer);
    printer.flush_if_due(clock.now());
    if (g_stats_wanted.exchange(false)) printer.stats(sniffer.stats(), sniffer.options());
  }
  sniffer.finish(clock.now());
  sink.take(sniffer);
  if (out) out->close();
  if (pcap) pcap->close();
  printer.stats(sniffer.stats(), sniffer.options());
}

}  // namespace

void add_sniff_command(CLI::App& app, const GlobalOptions& globals) {
  auto a = std::make_shared<SniffArgs>();
  auto* sniff = app.add_subcommand(
      "sniff",
      "Listen to an RS485 line through a second adapter (never transmits): every frame decoded, "
      "paired and timed, statistics per ID");
  sniff->footer(
      "Examples:\n"
      "  lec sniff --port /dev/ttyUSB1 --baud 115200\n"
      "  lec sniff --port /dev/ttyUSB1 --capture line.jsonl --json\n"
      "  lec sniff --read line.jsonl --filter 'id=1,2 fn=3 addr=9000-9010'\n"
      "--port, --baud, --json, --silent-interval and --td (the controllers' Silent INT and Min "
      "Resp delay, for Ts and Tx) are lec's global options.\n"
      "Frames are found by length and CRC, not by gaps, so USB adapters' latency timers do not "
      "split or merge them; bytes no frame confirms are shown as noise. Timing (Ts before each "
      "query, the controller's response time against Tx) is judged when frames arrive in chunks "
      "of their own (set the adapter's latency timer to 1 ms). Statistics print at the end, on "
      "SIGUSR1 and on the key s. See docs/sniff.md.");
  sniff
      ->add_option("--read", a->read,
                   "Replay a capture file (docs/capture-format.md) instead of a port")
      ->type_name("FILE");
  sniff
      ->add_option("--capture", a->capture,
                   "Also write every frame and noise burst to FILE in the capture format")
      ->type_name("FILE");
  sniff
      ->add_option("--pcap", a->pcap,
                   "Also write the frames (not the noise) to FILE as pcap, link type 147 "
                   "(DLT_USER0): tshark -o 'uat:user_dlts:\"User 0 "
                   "(DLT=147)\",\"mbrtu\",\"0\",\"\",\"0\",\"\"' "
                   "-r FILE (docs/sniff.md)")
      ->type_name("FILE");
  sniff
      ->add_option("--filter", a->filter,
                   "Show only frames matching all terms: id=LIST (1,2 or 1-4), fn=LIST "
                   "(function codes, e.g. 3,16), addr=FROM-TO (register/bit addresses in hex, "
                   "as the manual writes them, e.g. 9000-9010); noise is always shown")
      ->type_name("TERMS");
  sniff->add_flag("--no-timing", a->no_timing, "Do not judge timing (no Ts/Tx verdicts)");
  sniff->callback([a, &globals] {
    modbus::SnifferOptions options;
    options.timing.baud = globals.baud;
    options.timing.silent_interval_k = globals.silent_interval_k;
    options.timing.delay_td = globals.delay_td;
    options.check_timing = !a->no_timing;
    SniffFilter::parse(a->filter);  // refuse a bad filter before opening anything
    if (!a->read.empty()) {
      if (!globals.port.empty()) throw UsageError("sniff: give --port or --read, not both");
      try {
        run_read(*a, options, globals.json);
      } catch (const InvalidArgument& e) {
        throw CommandFailed(kFailure, e.what());
      }
      return;
    }
    run_port(*a, globals, options);
  });
}

}  // namespace lec6::cli
