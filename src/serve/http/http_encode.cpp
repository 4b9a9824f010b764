// HTTP/1.x responses, requests (tests, the fuzz harness) and Server-Sent
// Events as bytes, with Boost.Beast's serialiser. Beast is used on memory
// buffers only, as in http_codec.cpp (the reader).

#include "http/http_codec.hpp"

// Beast's string_view is std::string_view, like ours; the same in every file
// that includes Beast (http_codec.cpp, this one).
#define BOOST_BEAST_USE_STD_STRING_VIEW
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/http/write.hpp>
#include <sstream>

namespace lec6::serve {

namespace http = boost::beast::http;

namespace {

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
