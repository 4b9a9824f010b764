#pragma once
// A listen-only observer of an RTU line (`lec sniff`), sans-I/O: fed the
// bytes a second adapter receives, with the time each chunk arrived, it
// delimits frames, tells queries from replies, pairs each reply with its
// query, checks the line timing of the manual (§8.2–8.4) and counts per ID.
//
// Framing does not trust gaps (a USB adapter's latency timer erases them):
//   - a query's length follows from its function code (length.hpp), a
//     reply's from the query it answers; the CRC confirms a frame;
//   - while a query waits for its reply, the bytes are read as that reply
//     first, then as a new query; otherwise as a query first, then as a reply
//     nobody asked for;
//   - a function code no table sizes (neither the LEC's nor the standard
//     Modbus ones: e.g. 0x2B from a SCADA scan) is framed by its CRC: the
//     shortest CRC-valid run of 4 to 256 bytes from an ID and a function code
//     (01h–7Fh) that ends where its chunk ends or where a confirmed frame
//     begins is a frame of unknown kind (kSniffUnknownFunction), a query, or
//     the reply of the query waiting with that ID and code; its exception
//     reply pairs with it. Split over chunks with bytes behind it, it stays noise;
//   - bytes that no reading confirms are dropped one at a time into a noise
//     burst (resynchronisation), which is reported with its bytes;
//   - a silence of `idle_gap` (a hint only) settles bytes that wait for more:
//     nothing after such a silence can complete them.
// Timing is judged only where it can be measured: a frame delivered in a
// chunk of its own. When frames keep arriving in shared chunks (an adapter
// with a latency timer: over 10 % of the last ~50 frames) timing checks stop
// until that falls below 2 %, and stats().lumpy says so.
//
// Thread safety: one thread at a time.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::modbus {

struct SnifferOptions {
  // The line and the controllers' settings (baud, Silent INT k, Min Resp delay Td).
  LineTiming timing;
  // Slack on the measured response time before a reply is called late
  // (the adapter's own delivery latency).
  Duration tolerance = std::chrono::milliseconds(1);
  // A query whose reply has not begun this long after the query is counted
  // as unanswered (a timeout).
  Duration reply_wait = std::chrono::milliseconds(1000);
  // A silence this long settles buffered bytes (see above). Longer than the
  // longest USB latency timer (FTDI: 255 ms), which may split a frame.
  Duration idle_gap = std::chrono::milliseconds(300);
  // Judge timing at all (off: no timing flags, no response times).
  bool check_timing = true;
};

enum class SniffKind : uint8_t {
  Query,    // master → controller, CRC confirmed
  Reply,    // controller → master, CRC confirmed
  Noise,    // bytes no frame confirms, in arrival order
  NoReply,  // a unicast query got no reply (bytes: the query)
};

// Flags on an event (a bit set).
enum SniffFlag : uint32_t {
  kSniffShortSilence = 1u << 0,  // Query: began less than Ts after the previous frame
  kSniffLate = 1u << 1,          // Reply: ended later than Tx after its query
  kSniffUnsolicited = 1u << 2,   // Reply: no query waited for it (or not this one)
  kSniffSecondMaster = 1u << 3,  // Query: came while another waited for its reply, within Tx
  kSniffBadCrc = 1u << 4,        // Noise: began as a frame of the right shape, CRC failed
  kSniffBroadcast = 1u << 5,     // Query: to ID 0 (no reply expected)
  // Query/Reply: a function code no table sizes, framed by its CRC (above).
  kSniffUnknownFunction = 1u << 6,
};

struct SniffEvent {
  SniffKind kind = SniffKind::Noise;
  Bytes bytes;
  TimePoint first_byte{};     // arrival of the chunk holding the first byte
  TimePoint last_byte{};      // arrival of the chunk holding the last byte
  uint64_t query_number = 0;  // Query: its number (1, 2, ...); Reply/NoReply: the query's; 0: none
  Bytes query;                // Reply: the query it answers (empty if unsolicited)
  // Only when measurable (see the header). Query: the silence since the
  // previous frame ended (for the previous exchange, its gap to this next
  // query); Reply: end of query → end of reply.
  std::optional<Duration> silence;
  std::optional<Duration> response;
  Duration limit{};  // Query: Ts; Reply: Tx for its length
  uint32_t flags = 0;
  bool has(SniffFlag f) const noexcept { return (flags & f) != 0; }
};

struct SniffIdStats {
  uint64_t queries = 0;
  uint64_t exchanges = 0;   // replies paired with their query
  uint64_t exceptions = 0;  // exception replies
  uint64_t timeouts = 0;    // unicast queries without a reply
  uint64_t crc_errors = 0;  // frame-shaped bytes from/to this ID whose CRC failed
  uint64_t late = 0;        // replies later than Tx
  uint64_t unsolicited = 0;
  std::vector<uint32_t> response_us;  // measured response times, µs
};

struct SniffStats {
  std::map<uint8_t, SniffIdStats> ids;
  uint64_t frames = 0;
  uint64_t noise_bursts = 0;
  uint64_t noise_bytes = 0;
  uint64_t short_silences = 0;     // queries that did not keep Ts
  uint64_t second_master = 0;      // queries over another's transaction
  uint64_t untimed = 0;            // frames whose timing could not be measured
  uint64_t unknown_functions = 0;  // frames of a function code no table sizes
  bool lumpy = false;              // the adapter delivers frames in lumps: timing not judged
};

// p in [0, 1] of the measured response times (zero when none).
Duration response_percentile(const SniffIdStats& s, double p);

class Sniffer {
 public:
  explicit Sniffer(const SnifferOptions& options = {});

  // Bytes that arrived at `arrival` (one chunk, as a read returned them).
  void feed(std::span<const uint8_t> bytes, TimePoint arrival);
  // Time passes: queries whose reply wait ran out, bytes after a silence.
  void advance(TimePoint now);
  // End of input: settles everything buffered and every waiting query.
  void finish(TimePoint now);

  // The events found so far, in line order; taken once.
  std::vector<SniffEvent> take();

  // When advance() must next run (nullopt: nothing waits on time).
  std::optional<TimePoint> deadline() const;

  const SniffStats& stats() const noexcept { return stats_; }
  const SnifferOptions& options() const noexcept { return options_; }

  // How the bytes at the head read as one frame (sniffer.cpp's read_frame).
  enum class Reading : uint8_t { Confirmed, Incomplete, BadCrc, Failed };

 private:
  struct Pending {
    Bytes query;
    uint64_t number = 0;
    TimePoint end{};     // the query's last byte
    bool timed = false;  // its end was measured
    std::size_t reply_length = 8;
  };

  void scan(bool settle);
  bool resent_query(std::size_t length) const;
  enum class Resend : uint8_t { Yes, No, Undecided };
  Resend judge_resend(std::span<const uint8_t> head, std::size_t length, bool settle) const;
  Reading try_query(std::span<const uint8_t> head, std::size_t& length) const;
  Reading try_reply(std::span<const uint8_t> head, std::size_t& length) const;
  bool matches_pending(std::span<const uint8_t> frame) const;
  // `offset`: where `head` begins after head_; `followed`: whether an unknown
  // frame after this one may confirm where it ends (one level deep).
  std::optional<std::size_t> unknown_frame(std::span<const uint8_t> head, bool settle,
                                           std::size_t offset = 0, bool followed = true) const;
  void emit_query(std::size_t length, uint32_t flags = 0);
  void emit_reply(std::size_t length, bool paired, uint32_t flags = 0);
  void emit_no_reply();
  void flush_noise();
  void note_frame_boundary(std::size_t first);
  bool timed_frame(std::size_t first, std::size_t length) const;
  SniffEvent make_event(SniffKind kind, std::size_t first, std::size_t length) const;
  void compact();
  bool unresolved() const noexcept { return head_ < buf_.size(); }

  SnifferOptions options_;
  // Unresolved bytes: [head_, buf_.size()), each with its chunk's arrival
  // and whether it began / ended its chunk.
  Bytes buf_;
  std::vector<TimePoint> times_;
  std::vector<uint8_t> marks_;
  std::size_t head_ = 0;
  std::size_t noise_length_ = 0;  // the noise run: [head_ - noise_length_, head_)
  bool noise_bad_crc_ = false;
  TimePoint last_arrival_{};
  bool have_arrival_ = false;
  std::optional<Pending> pending_;
  uint64_t queries_ = 0;
  // The previous frame's end, for the silence before the next query.
  std::optional<TimePoint> previous_end_;
  bool previous_timed_ = false;
  double merged_ratio_ = 0.0;  // recent share of frames not starting their own chunk
  bool lumpy_now_ = false;
  std::deque<SniffEvent> events_;
  SniffStats stats_;
  // Per ID, the longest response of a timed reply that differs from its
  // query (a read, an exception): how slow this device's replies are.
  std::map<uint8_t, Duration> longest_reply_;
};

}  // namespace lec6::modbus
