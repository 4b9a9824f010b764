#pragma once
// HTTP/1.x on bytes, sans-I/O: requests in (HttpRequestReader), responses and
// Server-Sent Events out. Boost.Beast's parser and serialiser do the work
// (http_codec.cpp is the one file that includes Beast); the server feeds
// whatever the socket gave and writes whatever comes back.
//
// Reading, with pipelining:
//   reader.feed(bytes);                         // NeedMore: read again
//   while (reader.status() == Complete) {       // Error: answer error(), close
//     handle(reader.take());                    // then the next buffered one:
//     reader.feed({});
//   }
//
// Thread safety: a reader belongs to one connection; the functions are pure.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "http/http.hpp"

namespace boost::system {
class error_code;
}

namespace lec6::serve {

struct HttpLimits {
  std::size_t header_bytes = 16 * 1024;  // request line and fields; more: 431
  std::size_t body_bytes = 1024 * 1024;  // after de-chunking; more: 413
};

// Why a request was refused: the status to answer (400, 413, 431, 505) and a
// reason in the client's terms. The connection closes after the answer.
struct HttpParseError {
  int status = 400;
  std::string reason;
};

class HttpRequestReader {
 public:
  enum class Status { NeedMore, Complete, Error };

  explicit HttpRequestReader(HttpLimits limits = {});
  ~HttpRequestReader();
  HttpRequestReader(HttpRequestReader&&) noexcept;
  HttpRequestReader& operator=(HttpRequestReader&&) noexcept;

  // Buffers `bytes` and parses as far as one request. While a request is
  // Complete (not yet taken) or after an Error, bytes are only buffered.
  Status feed(std::string_view bytes);
  // The peer closed its side: a request cut short becomes an Error (400).
  Status end_of_input();
  Status status() const noexcept { return status_; }

  // The complete request (status Complete); the reader then waits for the
  // next one. Call feed({}) to parse bytes already buffered (pipelining).
  HttpRequest take();
  const HttpParseError& error() const noexcept { return error_; }

  // True once, when a request's header asked for `Expect: 100-continue` and
  // its body is still to come: the server sends kContinue before reading on.
  bool take_expect_continue();
  // Some bytes of a request have arrived (an idle connection has none).
  bool in_request() const noexcept;
  // Bytes held: not yet parsed, or the part of a body Beast has not taken.
  std::size_t buffered() const noexcept { return buffer_.size(); }

 private:
  struct Parser;
  void restart();
  Status refuse(const boost::system::error_code& ec, std::string_view request);
  Status refuse_header_limit();
  enum class HeaderCut { Incomplete, Whole, OverLimit, LoneLf };
  HeaderCut header_cut() const;
  Status check_header();
  Status refuse_body_limit();
  std::size_t chunked_piece();
  Status fail(int status, std::string reason);

  HttpLimits limits_;
  std::unique_ptr<Parser> parser_;
  std::string buffer_;
  Status status_ = Status::NeedMore;
  HttpParseError error_;
  bool continue_pending_ = false;
  bool continue_sent_ = false;
  std::string header_seen_;  // header bytes the parser took already (at most the limit)
};

inline constexpr std::string_view kContinue = "HTTP/1.1 100 Continue\r\n\r\n";

struct ResponseFraming {
  bool keep_alive = true;  // false: `Connection: close`, and the server closes
  bool head = false;       // a HEAD answer: the fields of the GET, no body
  unsigned version = 11;   // the request's: an HTTP/1.0 client gets 1.0 rules
};

// Status line, Content-Type, Content-Length, the response's extra fields,
// `X-Content-Type-Options: nosniff`, then the body.
std::string encode_response(const HttpResponse& response, ResponseFraming framing = {});

// A request as a client sends it (tests, the fuzz harness's round trip):
// Content-Length from the body unless a Transfer-Encoding field is given.
std::string encode_request(const HttpRequest& request);

// ---- Server-Sent Events (text/event-stream) ---------------------------------
// The head of a response that stays open: no length, ends when the
// connection closes; caches and proxies told not to hold it back.
std::string encode_event_stream_head();
// One event: `id:` (when given), `event:`, one `data:` line per line of
// `data` (any of \n, \r\n, \r ends a line), a blank line. CR and LF in `event`
// and `id` would start a new field, so they become spaces.
std::string encode_event(std::string_view event, std::string_view data,
                         std::optional<std::string_view> id = std::nullopt);
// A comment line (": text"), ignored by browsers: keeps idle streams alive
// through proxies and lets the server notice a browser that went away.
std::string encode_event_comment(std::string_view text);

}  // namespace lec6::serve
