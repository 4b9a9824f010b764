#include "history_http.hpp"

#include <fmt/format.h>

#include <charconv>
#include <ctime>
#include <set>

#include <nlohmann/json.hpp>

#include "history.hpp"

namespace lec6::serve::history {
namespace {

using nlohmann::json;

template <typename T>
std::optional<T> whole(std::string_view text) {
  T v{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return v;
}

HttpResponse history_off() {
  return error_response(404,
                        "the move history is off: lec serve was started with --no-history or "
                        "history: false (docs/history.md)");
}

}  // namespace

std::optional<int64_t> parse_time(std::string_view text) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, s = 0, ms = 0;
  auto num = [&](std::size_t at, std::size_t len, int& out) {
    if (text.size() < at + len) return false;
    const auto v = whole<int>(text.substr(at, len));
    if (!v) return false;
    out = *v;
    return true;
  };
  if (!num(0, 4, y) || text.size() < 10 || text[4] != '-' || !num(5, 2, mo) || text[7] != '-' ||
      !num(8, 2, d)) {
    return std::nullopt;
  }
  if (text.size() > 10) {
    if ((text[10] != 'T' && text[10] != ' ') || !num(11, 2, h) || text.size() < 19 ||
        text[13] != ':' || !num(14, 2, mi) || text[16] != ':' || !num(17, 2, s)) {
      return std::nullopt;
    }
    std::string_view rest = text.substr(19);
    if (rest.starts_with(".")) {
      std::size_t n = 1;
      while (n < rest.size() && std::isdigit(static_cast<unsigned char>(rest[n]))) ++n;
      if (n == 1) return std::nullopt;
      std::string frac(rest.substr(1, n - 1));
      frac.resize(3, '0');
      ms = std::stoi(frac.substr(0, 3));
      rest.remove_prefix(n);
    }
    if (rest != "Z" && rest != "") return std::nullopt;
  }
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || s > 60) return std::nullopt;
  std::tm tm{};
  tm.tm_year = y - 1900;
  tm.tm_mon = mo - 1;
  tm.tm_mday = d;
  tm.tm_hour = h;
  tm.tm_min = mi;
  tm.tm_sec = s;
  return static_cast<int64_t>(timegm(&tm)) * 1000 + ms;
}

std::variant<HistoryQuery, QueryError> parse_query(const std::string& axis,
                                                   const std::map<std::string, std::string>& q) {
  static const std::set<std::string> known{"since", "until", "kind",   "outcome", "source",
                                           "step",  "limit", "before", "format"};
  static const std::set<std::string> kinds{"home", "move", "run-step", "jog"};
  static const std::set<std::string> outcomes{"reached", "pushed",   "push_missed", "stopped",
                                              "alarm",   "deadline", "not_started", "refused"};
  HistoryQuery out;
  out.axis = axis;
  for (const auto& [key, value] : q) {
    if (!known.contains(key)) {
      return QueryError{key, fmt::format("{}: not a filter of the history (since, until, kind, "
                                         "outcome, source, step, limit, before, format)",
                                         key)};
    }
    if (key == "since" || key == "until") {
      const auto t = parse_time(value);
      if (!t) {
        return QueryError{key, fmt::format("{}: '{}' is not a UTC time like 2026-11-24T10:00:00Z "
                                           "or a date like 2026-11-24",
                                           key, value)};
      }
      (key == "since" ? out.since_ms : out.until_ms) = *t;
    } else if (key == "kind") {
      if (!kinds.contains(value)) {
        return QueryError{key, fmt::format("kind: '{}' is not home, move, run-step or jog", value)};
      }
      out.kind = value;
    } else if (key == "outcome") {
      if (!outcomes.contains(value)) {
        return QueryError{key, fmt::format("outcome: '{}' is not reached, pushed, push_missed, "
                                           "stopped, alarm, deadline, not_started or refused",
                                           value)};
      }
      out.outcome = value;
    } else if (key == "source") {
      out.source = value;
    } else if (key == "step") {
      const auto n = whole<int>(value);
      if (!n || *n < 0 || *n > 63) {
        return QueryError{key, fmt::format("step: '{}' is not a step (0 to 63)", value)};
      }
      out.step = *n;
    } else if (key == "limit") {
      const auto n = whole<std::size_t>(value);
      if (!n || *n < 1 || *n > 10000) {
        return QueryError{key, fmt::format("limit: '{}' is not 1 to 10000", value)};
      }
      out.limit = *n;
    } else if (key == "before") {
      const auto n = whole<int64_t>(value);
      if (!n || *n < 1) {
        return QueryError{key, fmt::format("before: '{}' is not a record id", value)};
      }
      out.before_id = *n;
    } else if (key == "format" && value != "csv" && value != "json") {
      return QueryError{key, fmt::format("format: '{}' is not json or csv", value)};
    }
  }
  if (out.since_ms && out.until_ms && *out.until_ms <= *out.since_ms) {
    return QueryError{"until", "until: not after since"};
  }
  return out;
}

bool handle_http(History* history, const AxisRef& axis, const std::vector<std::string_view>& rest,
                 const HttpRequest& request, Responder& responder) {
  if (rest.empty() || (rest[0] != "history" && rest[0] != "health")) return false;
  const bool get = request.method == "GET" || request.method == "HEAD";
  if (rest.size() == 1 && rest[0] == "history") {
    if (!get)
      return responder.respond(error_response(405, "method not allowed here (allowed: GET)")), true;
    if (!history) return responder.respond(history_off()), true;
    auto parsed = parse_query(axis.name, request.query);
    if (auto* e = std::get_if<QueryError>(&parsed)) {
      return responder.respond(error_response(400, e->message, e->parameter)), true;
    }
    const HistoryQuery q = std::get<HistoryQuery>(parsed);
    const bool csv = request.query.count("format") && request.query.at("format") == "csv";
    // Off the I/O thread (issue 32): the query and the answer's text are
    // made on the history's query thread; the Responder answers from there.
    auto answer = [q, csv, name = axis.name, responder](std::vector<MotionRecord> records) {
      if (csv) {
        std::string body = csv_header();
        for (const auto& r : records) body += csv_row(r);
        auto out = text_response(200, std::move(body), "text/csv; charset=utf-8");
        out.headers.set("Content-Disposition",
                        fmt::format("attachment; filename=\"{}-history.csv\"", name));
        responder.respond(out);
        return;
      }
      json list = json::array();
      for (const auto& r : records) list.push_back(to_json(r));
      json next = nullptr;
      if (records.size() == q.limit && !records.empty()) next = records.back().id;
      responder.respond(
          json_response(200, {{"axis", name}, {"records", list}, {"next_before", next}}));
    };
    if (!history->query_async(q, std::move(answer))) {
      responder.respond(error_response(503, "too many history queries waiting: try again"));
    }
    return true;
  }
  if (rest.size() == 1 && rest[0] == "health") {
    if (!get)
      return responder.respond(error_response(405, "method not allowed here (allowed: GET)")), true;
    if (!history) return responder.respond(history_off()), true;
    const bool trend = request.query.count("trend") && request.query.at("trend") != "0";
    return responder.respond(json_response(200, history->health(axis.name, trend))), true;
  }
  if (rest.size() == 2 && rest[0] == "health" && rest[1] == "service") {
    if (request.method != "POST") {
      return responder.respond(error_response(405, "method not allowed here (allowed: POST)")),
             true;
    }
    if (!history) return responder.respond(history_off()), true;
    json body;
    try {
      body = request.body.empty() ? json::object() : json::parse(request.body);
    } catch (const json::exception& e) {
      return responder.respond(
                 error_response(400, fmt::format("the body is not valid JSON: {}", e.what()))),
             true;
    }
    const std::string what = body.is_object() ? body.value("what", "") : "";
    if (!history->serviced(axis.name, what)) {
      return responder.respond(error_response(
                 400, fmt::format("what: '{}' is not a service of history.services", what),
                 "what")),
             true;
    }
    return responder.respond(json_response(200, history->health(axis.name))), true;
  }
  return false;
}

}  // namespace lec6::serve::history
