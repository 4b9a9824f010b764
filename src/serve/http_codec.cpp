// HTTP/1.x bytes <-> values with Boost.Beast's parser and serialiser. This is
// the only file that includes Beast (it is slow to compile), and it uses Beast
// on memory buffers only: sockets are standalone Asio in http_server.cpp.

#include "lec6/serve/http_codec.hpp"

// Beast's string_view is std::string_view, like ours. Safe because no other
// file of the program includes Beast.
#define BOOST_BEAST_USE_STD_STRING_VIEW
#include <algorithm>
#include <boost/beast/core/buffers_to_string.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/http/write.hpp>
#include <cctype>
#include <sstream>

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

// CR or LF in a field would end it and start another (response splitting).
std::string field_safe(std::string_view text) {
  std::string out(text);
  for (char& c : out) {
    if (c == '\r' || c == '\n' || c == '\0') c = ' ';
  }
  return out;
}

bool framing_field(std::string_view name) {
  return iequals(name, "Content-Length") || iequals(name, "Transfer-Encoding") ||
         iequals(name, "Connection");
}

template <class Message>
std::string serialise(const Message& m, bool header_only) {
  std::ostringstream out;
  if (header_only) {
    out << m.base();
  } else {
    out << m;
  }
  return out.str();
}

}  // namespace

struct HttpRequestReader::Parser {
  explicit Parser(const HttpLimits& limits) {
    p.header_limit(static_cast<std::uint32_t>(limits.header_bytes));
    p.body_limit(limits.body_bytes);
    p.eager(true);
  }
  http::request_parser<http::string_body> p;
  std::optional<SplitTarget> target;  // once the header is done
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
}

HttpRequestReader::Status HttpRequestReader::fail(int status, std::string reason) {
  status_ = Status::Error;
  error_ = {status, std::move(reason)};
  continue_pending_ = false;
  return status_;
}

// Beast reports a lone LF, or a well-formed version other than 1.x, as
// "bad version": tell the client what is really wrong.
HttpRequestReader::Status HttpRequestReader::refuse(const boost::system::error_code& ec) {
  const std::string_view first_line =
      std::string_view(buffer_).substr(0, std::min(buffer_.find('\n'), buffer_.size()));
  if (!parser_->p.is_header_done() && buffer_.find('\n') != std::string::npos &&
      (first_line.empty() || first_line.back() != '\r'))
    return fail(400, parse_error_text(http::error::bad_line_ending));
  if (ec == http::error::bad_version) {
    const auto v = first_line.rfind(" HTTP/");
    const std::string_view version =
        v == std::string_view::npos ? std::string_view() : first_line.substr(v + 6);
    if (version.size() == 4 && std::isdigit(static_cast<unsigned char>(version[0])) &&
        version[1] == '.' && std::isdigit(static_cast<unsigned char>(version[2])) &&
        version[3] == '\r')
      return fail(505, "HTTP/" + std::string(version.substr(0, 3)) +
                           " is not supported (lec serve speaks HTTP/1.0 and 1.1)");
  }
  return fail(400, parse_error_text(ec));
}

HttpRequestReader::Status HttpRequestReader::feed(std::string_view bytes) {
  buffer_.append(bytes);
  if (status_ != Status::NeedMore) return status_;
  auto& p = parser_->p;
  while (!p.is_done() && !buffer_.empty()) {
    const bool had_header = p.is_header_done();
    boost::system::error_code ec;
    const std::size_t used = p.put(boost::asio::buffer(buffer_.data(), buffer_.size()), ec);
    buffer_.erase(0, used);
    if (ec == http::error::header_limit)
      return fail(431, "the request's header is larger than " + size_text(limits_.header_bytes));
    if (ec == http::error::body_limit)
      return fail(413, "the request's body is larger than " + size_text(limits_.body_bytes));
    if (ec && ec != http::error::need_more) return refuse(ec);
    if (!had_header && p.is_header_done()) {
      const auto& m = p.get();
      if (m.version() != 10 && m.version() != 11) {
        return fail(505, "HTTP/" + std::to_string(m.version() / 10) + "." +
                             std::to_string(m.version() % 10) +
                             " is not supported (lec serve speaks HTTP/1.0 and 1.1)");
      }
      if (m.version() == 11 && m.find(http::field::host) == m.end())
        return fail(400, "an HTTP/1.1 request needs a Host field");
      parser_->target = split_target(std::string_view(m.target().data(), m.target().size()));
      if (!parser_->target)
        return fail(400, "the request target is not a path, or has a bad %-escape");
      const auto expect = m.find(http::field::expect);
      if (expect != m.end() && m.version() == 11 && !p.is_done() && !continue_sent_ &&
          iequals(std::string_view(expect->value().data(), expect->value().size()), "100-continue"))
        continue_pending_ = true;
    }
    if (ec == http::error::need_more || used == 0) break;
  }
  if (p.is_done()) status_ = Status::Complete;
  return status_;
}

HttpRequestReader::Status HttpRequestReader::end_of_input() {
  if (status_ != Status::NeedMore || !in_request()) return status_;
  // Bytes still buffered are an unfinished header or body.
  boost::system::error_code ec;
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

std::string encode_response(const HttpResponse& response, ResponseFraming framing) {
  http::response<http::string_body> m;
  m.version(framing.version == 10 ? 10 : 11);
  m.result(static_cast<unsigned>(response.status));
  m.reason(reason_phrase(response.status));
  if (!response.content_type.empty())
    m.set(http::field::content_type, field_safe(response.content_type));
  for (const auto& [name, value] : response.headers.fields()) {
    if (!framing_field(name)) m.insert(field_safe(name), field_safe(value));
  }
  if (!response.headers.has("X-Content-Type-Options")) m.set("X-Content-Type-Options", "nosniff");
  m.keep_alive(framing.keep_alive);
  const int s = response.status;
  const bool no_body = (s >= 100 && s < 200) || s == 204 || s == 304;
  if (!no_body) {
    m.body() = response.body;
    m.content_length(response.body.size());
  }
  return serialise(m, framing.head || no_body);
}

std::string encode_request(const HttpRequest& request) {
  http::request<http::string_body> m;
  m.method_string(request.method);
  m.target(request.target);
  m.version(request.version == 10 ? 10 : 11);
  for (const auto& [name, value] : request.headers.fields()) {
    if (!iequals(name, "Content-Length") && !iequals(name, "Transfer-Encoding"))
      m.insert(field_safe(name), field_safe(value));
  }
  m.body() = request.body;
  if (!request.body.empty() || !is_read_method(request.method))
    m.content_length(request.body.size());
  return serialise(m, false);
}

std::string encode_event_stream_head() {
  http::response<http::empty_body> m{http::status::ok, 11};
  m.set(http::field::content_type, "text/event-stream; charset=utf-8");
  m.set(http::field::cache_control, "no-store");
  m.set("X-Accel-Buffering", "no");  // nginx and friends: pass events through at once
  m.set("X-Content-Type-Options", "nosniff");
  return serialise(m, true);
}

std::string encode_event(std::string_view event, std::string_view data,
                         std::optional<std::string_view> id) {
  std::string out;
  out.reserve(event.size() + data.size() + 32);
  if (id) out.append("id: ").append(field_safe(*id)).append("\n");
  if (!event.empty()) out.append("event: ").append(field_safe(event)).append("\n");
  std::size_t at = 0;
  while (true) {
    const auto end = data.find_first_of("\r\n", at);
    out.append("data: ").append(data.substr(at, end - at)).append("\n");
    if (end == std::string_view::npos) break;
    at = end + ((data[end] == '\r' && end + 1 < data.size() && data[end + 1] == '\n') ? 2 : 1);
  }
  out.append("\n");
  return out;
}

std::string encode_event_comment(std::string_view text) {
  return ": " + field_safe(text) + "\n\n";
}

}  // namespace lec6::serve
