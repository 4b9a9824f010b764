#pragma once
// Messages in the interface they appear in (issue 27). The library's
// messages name the `lec` command that helps ("run `lec serial on`", "clear
// it with `lec reset`"); an HTTP client or a Python script needs its own
// action instead: the endpoint and method, or the method of lec6.Axis. One
// table, here, rewrites them; the dashboard turns the HTTP words into its
// buttons' names (web/src/results.ts).
//
// Thread safety: pure.

#include <string>
#include <string_view>

namespace lec6::client {

enum class Interface {
  Cli,     // `lec serial on` (the library's own words: unchanged)
  Http,    // `POST /api/axes/AXIS/serial {"on": true}` (also the MQTT op's name and args)
  Python,  // `axis.set_serial_mode(True)`
};

// `message` with every `lec …` action it names in `to`'s words; `axis` is
// the axis' name in the HTTP paths (empty: AXIS).
std::string in_terms_of(std::string message, Interface to, std::string_view axis = {});

}  // namespace lec6::client
