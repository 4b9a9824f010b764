// GET /metrics: the Prometheus text exposition format (version 0.0.4) of
// every line's stats. Latency is in seconds, as Prometheus names it.

#include <fmt/format.h>

#include "ops/views.hpp"

namespace lec6::serve {
namespace {

void family(std::string& out, std::string_view name, std::string_view type, std::string_view help) {
  fmt::format_to(std::back_inserter(out), "# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
}

template <typename T>
void sample(std::string& out, std::string_view name, const std::string& labels, T value) {
  fmt::format_to(std::back_inserter(out), "{}{{{}}} {}\n", name, labels, value);
}

}  // namespace

std::string prometheus_metrics(const AxisDirectory& directory) {
  struct Line_ {
    const LineConfig* config;
    LineStatsSnapshot stats;
    bool up;
  };
  std::vector<Line_> lines;
  for (const auto& c : directory.lines()) {
    const Line* l = directory.line(c.name);
    lines.push_back({&c, l->stats(), !l->is_down()});
  }
  std::string out;
  const auto per_line = [&](std::string_view name, std::string_view type, std::string_view help,
                            auto value) {
    family(out, name, type, help);
    for (const auto& l : lines)
      sample(out, name, fmt::format("line=\"{}\"", l.config->name), value(l));
  };
  per_line("lec6_line_up", "gauge", "1 when the line's port is open",
           [](auto& l) { return l.up ? 1 : 0; });
  per_line("lec6_line_transactions_total", "counter", "Exchanges on the wire",
           [](auto& l) { return l.stats.transactions; });
  per_line("lec6_line_transactions_per_second", "gauge", "Exchanges per second (10 s window)",
           [](auto& l) { return l.stats.transactions_per_s; });
  per_line("lec6_line_utilisation_ratio", "gauge",
           "Sum of the line limit of each exchange / elapsed time (10 s window)",
           [](auto& l) { return l.stats.utilisation; });
  per_line("lec6_line_busy_ratio", "gauge", "Share of time the line was in an exchange",
           [](auto& l) { return l.stats.busy; });
  per_line("lec6_line_cache_hits_total", "counter", "Reads answered from the telemetry cache",
           [](auto& l) { return l.stats.cache_hits; });

  family(out, "lec6_line_queue_depth", "gauge", "Requests waiting, by priority");
  for (const auto& l : lines) {
    for (std::size_t p = 0; p < kPriorities; ++p) {
      sample(out, "lec6_line_queue_depth",
             fmt::format("line=\"{}\",priority=\"{}\"", l.config->name,
                         priority_name(static_cast<Priority>(p))),
             l.stats.queue_depth[p]);
    }
  }
  family(out, "lec6_request_latency_seconds", "histogram",
         "Submit to answer, by priority (cache answers count as 0)");
  for (const auto& l : lines) {
    for (std::size_t p = 0; p < kPriorities; ++p) {
      const auto& lat = l.stats.latency[p];
      const std::string base = fmt::format("line=\"{}\",priority=\"{}\"", l.config->name,
                                           priority_name(static_cast<Priority>(p)));
      for (std::size_t b = 0; b < kLatencyBucketsMs.size(); ++b) {
        sample(out, "lec6_request_latency_seconds_bucket",
               fmt::format("{},le=\"{}\"", base, kLatencyBucketsMs[b] / 1000.0), lat.buckets[b]);
      }
      sample(out, "lec6_request_latency_seconds_bucket", base + ",le=\"+Inf\"", lat.count);
      sample(out, "lec6_request_latency_seconds_sum", base, lat.sum_ms / 1000.0);
      sample(out, "lec6_request_latency_seconds_count", base, lat.count);
    }
  }
  const auto per_device = [&](std::string_view name, std::string_view help, auto value) {
    family(out, name, "counter", help);
    for (const auto& l : lines) {
      for (const auto& [id, d] : l.stats.devices) {
        std::string axis;
        for (const auto& a : l.config->axes) {
          if (a.id == id) axis = a.name;
        }
        sample(out, name,
               fmt::format("line=\"{}\",id=\"{}\",axis=\"{}\"", l.config->name, id, axis),
               value(d));
      }
    }
  };
  per_device("lec6_device_transactions_total", "Exchanges with the controller",
             [](auto& d) { return d.transactions; });
  per_device("lec6_device_timeouts_total", "Exchanges without a reply",
             [](auto& d) { return d.timeouts; });
  per_device("lec6_device_crc_errors_total", "Replies that failed the CRC",
             [](auto& d) { return d.crc_errors; });
  per_device("lec6_device_framing_errors_total", "Stray bytes instead of a reply",
             [](auto& d) { return d.framing_errors; });
  per_device("lec6_device_exceptions_total", "Exception replies",
             [](auto& d) { return d.exceptions; });
  per_device("lec6_device_superseded_total",
             "Writes that would start motion, refused because a stop to the controller came first",
             [](auto& d) { return d.superseded; });
  family(out, "lec6_device_online", "gauge", "0 while the controller is backed off");
  for (const auto& a : directory.axes()) {
    sample(out, "lec6_device_online",
           fmt::format("line=\"{}\",id=\"{}\",axis=\"{}\"", a.line_config->name, a.id, a.name),
           a.line->health(a.id).offline ? 0 : 1);
  }
  return out;
}

}  // namespace lec6::serve
