// HTTP/1.x requests from bytes, with Boost.Beast's parser (responses and SSE:
// http_encode.cpp). Beast is used on memory buffers only: sockets are
// standalone Asio in http_connection.cpp (why: the comment at its top).

#include "http/http_codec.hpp"

// Beast's string_view is std::string_view, like ours; the same in every file
// that includes Beast (this one, http_encode.cpp).
#define BOOST_BEAST_USE_STD_STRING_VIEW
#include <algorithm>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>
#include <cctype>
#include <cstdint>
#include <functional>

namespace lec6::serve {

namespace http = boost::beast::http;

namespace {

std::string size_text(std::size_t n) {
  if (n >= 1024 * 1024 && n % (1024 * 1024) == 0) return std::to_string(n / (1024 * 1024)) + " MiB";
  if (n >= 1024 && n % 1024 == 0) return std::to_string(n / 1024) + " KiB";
  return std::to_string(n) + " bytes";
}

// Beast's error, in the client's terms.
std::string parse_error_text(const boost::system::error_code& ec) {
  using E = http::error;
  if (ec == E::bad_line_ending) return "bad line ending (HTTP lines end in CR LF)";
  if (ec == E::bad_method) return "malformed request line: bad method";
  if (ec == E::bad_target) return "malformed request line: bad request target";
  if (ec == E::bad_version) return "malformed request line: bad HTTP version";
  if (ec == E::bad_field) return "malformed header field name";
  if (ec == E::bad_value) return "malformed header field value";
  if (ec == E::bad_content_length) return "bad Content-Length";
  if (ec == E::bad_transfer_encoding) return "bad Transfer-Encoding (chunked is understood)";
  if (ec == E::bad_chunk || ec == E::bad_chunk_extension) return "malformed chunked body";
  if (ec == E::partial_message) return "the request was cut short";
  return "malformed HTTP request: " + ec.message();
}

}  // namespace

struct HttpRequestReader::Parser {
  explicit Parser(const HttpLimits& limits) {
    p.header_limit(static_cast<std::uint32_t>(limits.header_bytes));
    p.body_limit(limits.body_bytes);
    p.eager(true);
    p.on_chunk_header(on_chunk);
  }
  http::request_parser<http::string_body> p;
  std::optional<SplitTarget> target;  // once the header is done

  // Where a chunked body is: Beast is given one chunk line at a time, and
  // the data of a chunk only (see chunked_piece).
  std::uint64_t chunk_left = 0;   // data bytes of the current chunk still to come
  std::uint64_t chunk_total = 0;  // data bytes of the chunks so far
  bool first_chunk = true;        // no CRLF ends a previous chunk's data
  bool last_chunk = false;        // the last chunk's line is in: the trailer is Beast's
  std::function<void(std::uint64_t, std::string_view, boost::system::error_code&)> on_chunk =
      [this](std::uint64_t size, std::string_view, boost::system::error_code&) {
        chunk_left = size;
        chunk_total += size;
        first_chunk = false;
      };
};

HttpRequestReader::HttpRequestReader(HttpLimits limits)
    : limits_(limits), parser_(std::make_unique<Parser>(limits_)) {}
HttpRequestReader::~HttpRequestReader() = default;
HttpRequestReader::HttpRequestReader(HttpRequestReader&&) noexcept = default;
HttpRequestReader& HttpRequestReader::operator=(HttpRequestReader&&) noexcept = default;

void HttpRequestReader::restart() {
  parser_ = std::make_unique<Parser>(limits_);
  status_ = Status::NeedMore;
  continue_pending_ = continue_sent_ = false;
  header_seen_.clear();
}

HttpRequestReader::Status HttpRequestReader::fail(int status, std::string reason) {
  status_ = Status::Error;
  error_ = {status, std::move(reason)};
  continue_pending_ = false;
  return status_;
}

namespace {

// "GET / HTTP/2.0\r": a request line in good form, whatever its version.
// "GET / HTTP/2.0": a request line in good form up to a version other than
// 1.x (Beast stops there, before the line's end); the version, or empty.
std::string_view other_version(std::string_view request) {
  const auto s1 = request.find(' ');
  if (s1 == 0 || s1 == std::string_view::npos) return {};
  const auto s2 = request.find(' ', s1 + 1);
  if (s2 == std::string_view::npos || s2 == s1 + 1) return {};
  if (request.substr(0, s2).find_first_of("\r\n") != std::string_view::npos) return {};
  const std::string_view v = request.substr(s2 + 1, 8);
  const bool in_form = v.size() == 8 && v.starts_with("HTTP/") &&
                       std::isdigit(static_cast<unsigned char>(v[5])) && v[6] == '.' &&
                       std::isdigit(static_cast<unsigned char>(v[7]));
  if (!in_form || v == "HTTP/1.0" || v == "HTTP/1.1") return {};
  return v.substr(5);
}

}  // namespace

// Beast tries to parse a header as soon as bytes come, then (once it needed
// more) waits for the whole header or the limit. So a syntax error inside
// the limit may show fed whole, and only the limit fed in pieces. The answer
// must not depend on how the bytes were cut: the first `header_bytes` of the
// header, parsed in one go, decide.
HttpRequestReader::Status HttpRequestReader::refuse_header_limit() {
  const std::string head = (header_seen_ + buffer_).substr(0, limits_.header_bytes);
  Parser probe(limits_);
  boost::system::error_code ec;
  probe.p.put(boost::asio::buffer(head.data(), head.size()), ec);
  if (ec && ec != http::error::need_more && ec != http::error::header_limit)
    return refuse(ec, head);
  return fail(431, "the request's header is larger than " + size_text(limits_.header_bytes));
}

// Beast's errors in the client's terms: a lone LF and a version other than
// 1.x both come as "bad version". `request`: the request's bytes from its start.
HttpRequestReader::Status HttpRequestReader::refuse(const boost::system::error_code& ec,
                                                    std::string_view request) {
  const auto nl = request.find('\n');
  if (nl != std::string_view::npos && (nl == 0 || request[nl - 1] != '\r'))
    return fail(400, parse_error_text(http::error::bad_line_ending));
  if (ec == http::error::bad_version) {
    if (const auto v = other_version(request); !v.empty())
      return fail(
          505, "HTTP/" + std::string(v) + " is not supported (lec serve speaks HTTP/1.0 and 1.1)");
  }
  return fail(400, parse_error_text(ec));
}

// Beast parses the start line on its first put, then waits for the end of
// the header before it looks again, and counts its header limit from where
// its last put stopped. Fed in pieces, a bad start line was refused at once
// (505 for "HTTP/2.1"); fed whole with the header unfinished, the same bytes
// ended "cut short" (fuzz finding http-505-or-cut-short). So Beast gets a
// header in one piece, once it is whole within the limit; the limit, a lone
// LF and the end of input are decided here. Then the answer depends on the
// bytes only, never on how the network cut them.
HttpRequestReader::HeaderCut HttpRequestReader::header_cut() const {
  const std::string_view head =
      std::string_view(buffer_).substr(0, std::min(buffer_.size(), limits_.header_bytes));
  const auto eom = head.find("\r\n\r\n");
  const std::string_view header = eom == std::string_view::npos ? head : head.substr(0, eom + 4);
  for (auto nl = header.find('\n'); nl != std::string_view::npos; nl = header.find('\n', nl + 1)) {
    if (nl == 0 || header[nl - 1] != '\r') return HeaderCut::LoneLf;
  }
  if (eom != std::string_view::npos) return HeaderCut::Whole;
  return buffer_.size() >= limits_.header_bytes ? HeaderCut::OverLimit : HeaderCut::Incomplete;
}

// What Beast leaves to us once a header is parsed: the version, Host, the
// target's form, and whether the client waits for a 100 Continue (not if
// body bytes came with the header).
HttpRequestReader::Status HttpRequestReader::check_header() {
  auto& p = parser_->p;
  const auto& m = p.get();
  if (m.version() != 10 && m.version() != 11) {
    return fail(505, "HTTP/" + std::to_string(m.version() / 10) + "." +
                         std::to_string(m.version() % 10) +
                         " is not supported (lec serve speaks HTTP/1.0 and 1.1)");
  }
  if (m.version() == 11 && m.find(http::field::host) == m.end())
    return fail(400, "an HTTP/1.1 request needs a Host field");
  parser_->target = split_target(std::string_view(m.target().data(), m.target().size()));
  if (!parser_->target) return fail(400, "the request target is not a path, or has a bad %-escape");
  const auto expect = m.find(http::field::expect);
  if (expect != m.end() && m.version() == 11 && !p.is_done() && buffer_.empty() &&
      !continue_sent_ &&
      iequals(std::string_view(expect->value().data(), expect->value().size()), "100-continue"))
    continue_pending_ = true;
  return status_;
}

HttpRequestReader::Status HttpRequestReader::refuse_body_limit() {
  return fail(413, "the request's body is larger than " + size_text(limits_.body_bytes));
}

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

// A chunked body is refused for the first rule its bytes break, in stream
// order, however the network cut them (fuzz finding http-crash-90d75756).
// Beast does not manage that alone: it takes a chunk's size off its body
// limit before it parses the chunk's extensions, and again each time an
// unfinished extension makes it wait for more, and a quoted extension value
// runs on past the line's end. Fed byte by byte, `3;x="` and a long line
// crossed a 64-byte limit (413) where the same bytes whole were a malformed
// chunk (400). So each chunk line is checked here, byte by byte in order:
// the CRLF ending the previous chunk's data, the size (over the limit: 413
// at the digit that crosses it), the extensions up to the line's CRLF
// (a CR, LF or control character before it: 400). Beast is then given the
// whole line, which it parses in one go (and checks the extensions' form),
// and afterwards only the chunk's data. Returns how many bytes to give
// Beast: 0 when more must come (or after a refusal).
std::size_t HttpRequestReader::chunked_piece() {
  auto& c = *parser_;
  if (c.last_chunk) return buffer_.size();
  if (c.chunk_left > 0)
    return static_cast<std::size_t>(std::min<std::uint64_t>(c.chunk_left, buffer_.size()));
  const auto malformed = [this] {
    fail(400, parse_error_text(http::error::bad_chunk));
    return std::size_t{0};
  };
  std::size_t i = 0;
  if (!c.first_chunk) {
    for (const char want : {'\r', '\n'}) {
      if (i == buffer_.size()) return 0;
      if (buffer_[i++] != want) return malformed();
    }
  }
  const std::uint64_t room =
      limits_.body_bytes - std::min<std::uint64_t>(c.chunk_total, limits_.body_bytes);
  std::uint64_t size = 0;
  const std::size_t digits = i;
  for (; i < buffer_.size() && hex_digit(buffer_[i]) >= 0; ++i) {
    const bool overflows = size > (UINT64_MAX - 15) / 16;
    size = size * 16 + static_cast<std::uint64_t>(hex_digit(buffer_[i]));
    if (overflows || size > room) {
      refuse_body_limit();
      return 0;
    }
  }
  if (i == buffer_.size()) return 0;
  if (i == digits) return malformed();
  bool quoted = false, escaped = false;
  for (; i < buffer_.size(); ++i) {
    const auto ch = static_cast<unsigned char>(buffer_[i]);
    if (ch == '\r' && !quoted) {
      if (i + 1 == buffer_.size()) return 0;
      if (buffer_[i + 1] != '\n') return malformed();
      c.last_chunk = size == 0;
      return c.last_chunk ? buffer_.size() : i + 2;
    }
    if ((ch < 0x20 && ch != '\t') || ch == 0x7f) return malformed();
    if (escaped) {
      escaped = false;
    } else if (quoted && ch == '\\') {
      escaped = true;
    } else if (ch == '"') {
      quoted = !quoted;
    }
  }
  return 0;
}

HttpRequestReader::Status HttpRequestReader::feed(std::string_view bytes) {
  buffer_.append(bytes);
  if (status_ != Status::NeedMore) return status_;
  auto& p = parser_->p;
  if (!p.got_some()) {
    switch (header_cut()) {
      case HeaderCut::Incomplete:
        return status_;
      case HeaderCut::LoneLf:
        return fail(400, parse_error_text(http::error::bad_line_ending));
      case HeaderCut::OverLimit:
        return refuse_header_limit();
      case HeaderCut::Whole:
        break;
    }
  }
  while (!p.is_done() && !buffer_.empty()) {
    const bool had_header = p.is_header_done();
    boost::system::error_code ec;
    // The header alone first: with the body in the same put Beast would merge
    // a chunked body's trailer fields into the header before we check it.
    const std::size_t eom = had_header ? std::string::npos : buffer_.find("\r\n\r\n");
    std::size_t n = eom == std::string::npos ? buffer_.size() : eom + 4;
    const bool chunk_data = had_header && p.chunked() && parser_->chunk_left > 0;
    if (had_header && p.chunked()) {
      n = chunked_piece();
      if (status_ == Status::Error || n == 0) return status_;
    }
    const std::size_t used = p.put(boost::asio::buffer(buffer_.data(), n), ec);
    if (!p.is_header_done()) header_seen_.append(buffer_, 0, used);
    if (chunk_data) parser_->chunk_left -= used;
    buffer_.erase(0, used);
    if (!had_header && p.is_header_done() && check_header() == Status::Error) return status_;
    if (ec == http::error::header_limit) return refuse_header_limit();
    if (ec == http::error::body_limit) return refuse_body_limit();
    if (ec && ec != http::error::need_more) {
      if (had_header) return fail(400, parse_error_text(ec));
      return refuse(ec, header_seen_ + buffer_);
    }
    if (ec == http::error::need_more || used == 0) break;
  }
  if (p.is_done()) status_ = Status::Complete;
  return status_;
}

HttpRequestReader::Status HttpRequestReader::end_of_input() {
  if (status_ != Status::NeedMore || !in_request()) return status_;
  // A header never handed to Beast gets its one parse now: a bad start line
  // is refused as such, as it would be fed in any other cut.
  boost::system::error_code ec;
  if (!parser_->p.got_some() && !buffer_.empty()) {
    parser_->p.put(boost::asio::buffer(buffer_.data(), buffer_.size()), ec);
    if (ec && ec != http::error::need_more && ec != http::error::header_limit)
      return refuse(ec, buffer_);
  }
  // Bytes still buffered are an unfinished header or body.
  parser_->p.put_eof(ec);
  if (ec || !buffer_.empty() || !parser_->p.is_done())
    return fail(400, "the request was cut short");
  status_ = Status::Complete;
  return status_;
}

bool HttpRequestReader::take_expect_continue() {
  if (!continue_pending_) return false;
  continue_pending_ = false;
  continue_sent_ = true;
  return true;
}

bool HttpRequestReader::in_request() const noexcept {
  return !buffer_.empty() || parser_->p.got_some();
}

HttpRequest HttpRequestReader::take() {
  HttpRequest r;
  if (status_ != Status::Complete) return r;
  auto m = parser_->p.release();
  r.method = std::string(m.method_string());
  r.target = std::string(m.target());
  r.path = std::move(parser_->target->path);
  r.query = std::move(parser_->target->query);
  r.version = m.version();
  r.keep_alive = m.keep_alive();
  for (const auto& f : m) r.headers.add(std::string(f.name_string()), std::string(f.value()));
  r.body = std::move(m.body());
  restart();
  return r;
}

}  // namespace lec6::serve
