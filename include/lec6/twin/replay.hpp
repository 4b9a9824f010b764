#pragma once
// Replay and its fidelity report (issue 24), sans-I/O: a capture of a line
// becomes a list of exchanges (a master's query and the reply to it); the
// replay sends the captured queries again, keeping their order and spacing,
// and compare() sets each new reply beside the captured one: bytes, decoded
// values, response time. Replies that depend on motion (position, speed,
// thrust) are compared as motion: the values sampled at the same elapsed
// time, within a tolerance the report states. `lec replay` does the I/O.
//
// Thread safety: value types and pure functions.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "lec6/modbus/capture.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::twin {

// One record of a capture, as replay needs it (docs/capture-format.md): who
// sent it, when (µs from the capture's start), the bytes. `line` is its line
// in the capture file (1-based; 0 when not from a file), for messages.
struct LineRecord {
  enum class Kind { Query, Reply, Noise, Unknown };
  Kind kind = Kind::Unknown;
  int64_t t_us = 0;
  int64_t end_us = 0;
  modbus::Bytes bytes;
  std::size_t line = 0;
};

// A query and the reply to it (none: nothing answered before the next query).
struct Exchange {
  std::size_t line = 0;  // the query's line in its capture
  modbus::Bytes query;
  int64_t query_start_us = 0;
  int64_t query_end_us = 0;
  std::optional<modbus::Bytes> reply;
  int64_t reply_start_us = 0;
  int64_t reply_end_us = 0;
  // End of query → end of reply, µs (the manual's response time Tx).
  std::optional<int64_t> response_us() const {
    if (!reply) return std::nullopt;
    return reply_end_us - query_end_us;
  }
};

// A capture's records, numbered by their line in the file (the header is line
// 1, one record per line after it, as every lec6 writer writes them).
std::vector<LineRecord> line_records(const modbus::Capture& capture);

// Checks a capture before anything is sent (`lec replay`): it holds at least
// one query, and every query is a sound Modbus RTU request (CRC, shape).
// Throws lec6::InvalidArgument naming `file_name`, the record's line and
// what is wrong.
void check_replayable(const modbus::Capture& capture, std::string_view file_name);

// Pairs each query with the reply that follows it before the next query.
// Noise is skipped; a record of unknown direction is a reply when it follows
// a query and has a sound CRC, else skipped.
std::vector<Exchange> pair_exchanges(std::span<const LineRecord> records);

// When each captured query is sent again. as-captured: at the captured
// offset from the first query (its order and spacing); fast: as soon as the
// previous exchange is over.
enum class ReplayTiming { AsCaptured, Fast };

struct ReplayTolerance {
  double position_mm = 0.05;     // D9000 and D9004 while moving
  double speed_mm_s = 5.0;       // D9002
  double thrust_pct = 5.0;       // D9003
  double response_ratio = 0.10;  // response time, exchange by exchange (median of the ratios)
  // A discrete value (BUSY, INP, an output bit) that differs only because it
  // changed at a slightly other instant: it matches when the twin shows the
  // captured value at another exchange within this many ms (0: flags must
  // agree exchange by exchange). A capture taken from a twin or a controller
  // polled every 30 ms can see an edge one poll apart without any fault.
  double edge_ms = 0.0;
};

// What one value read was, in the manual's terms.
struct ValueDifference {
  std::size_t exchange = 0;  // index into the captured exchanges
  std::size_t line = 0;      // the query's line in the capture
  int64_t at_us = 0;         // the query's start, µs from the capture's start
  std::string what;          // "D9000 position", "X48 BUSY", "reply bytes", "reply"
  std::string captured;      // shown with its unit: "149.98 mm", "1", "01 03 04 …"
  std::string replayed;
  bool motion = false;  // compared as motion (with a tolerance)
  bool edge = false;    // a discrete value the twin shows within edge_ms of this exchange
  bool within_tolerance = false;
  std::string text()
      const;  // "line 17, 1.234 s: D9000 position: captured 149.98 mm, twin 150.00 mm"
};

struct ResponseStats {
  std::size_t count = 0;
  double p50_ms = 0, p95_ms = 0, max_ms = 0;
};

struct FidelityReport {
  std::string target = "twin";  // what the replay ran against, for the text
  ReplayTiming timing = ReplayTiming::AsCaptured;
  ReplayTolerance tolerance;
  std::size_t exchanges = 0;
  std::size_t identical = 0;         // reply bytes identical (or both silent)
  std::size_t within_tolerance = 0;  // differ only in motion values or flag edges, within tolerance
  std::size_t differing = 0;         // a discrete value, an exception, silence, or motion beyond
  std::vector<ValueDifference>
      differences;  // every value that differs (motion within tolerance too)
  double max_position_delta_mm = 0;
  ResponseStats captured_response, replayed_response;
  // The median, over exchanges answered in both, of twin ÷ captured response
  // time, minus 1 (−0.12: the twin answers 12 % sooner). Paired, so a mix of
  // short and long replies cannot shift it the way it shifts p50.
  double response_paired_change = 0;
  bool response_time_matches = true;  // |response_paired_change| within tolerance.response_ratio

  // Everything matched: no differing exchange, response times within tolerance.
  bool matches() const { return differing == 0 && response_time_matches; }
  std::string text(std::size_t max_lines = 50) const;
  std::string json() const;  // one JSON document
};

// Sets each replayed exchange beside the captured one at the same index
// (`replayed` holds one per captured exchange, same queries).
FidelityReport compare(std::span<const Exchange> captured, std::span<const Exchange> replayed,
                       const ReplayTolerance& tolerance = {});

ResponseStats response_stats(std::span<const Exchange> exchanges);

}  // namespace lec6::twin
