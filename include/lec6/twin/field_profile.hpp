#pragma once
// A field profile: the twin's settings in a YAML (or JSON) file, so that a
// twin can be made as unkind as a real controller (issue 12) and the same
// twin can be named in `lec sim --profile`, a `lec serve` sim line, or the
// Python Twin. The shipped one is profiles/field-quirks.yaml.
//
//   name: field-quirks
//   description: what a real LECP6 does that the digest's twin does not
//   actuator:               # sim::ActuatorConfig
//     busy_delay_ms: 15
//     busy_min_ms: 60
//     target_update_late: true
//   line:                   # sim::LineConfig, and idle-line noise
//     noise_rate: 2         # bytes/s
//   faults:                 # sim::FaultConfig
//     seed: 7
//
// Every key is optional; a missing one keeps the value of `defaults`. Errors
// (ProfileError) name the file, the line and the rule: "f.yaml:4:
// actuator.busy_delay_ms: -5 is outside 0 to 10000 ms".
//
// Thread safety: the functions keep no state and may be called from any
// thread; a FieldProfile is a plain value (no references to the file or text
// it came from).

#include <filesystem>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>

#include "lec6/error.hpp"
#include "lec6/sim/behaviour.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::twin {

struct FieldProfile {
  std::string name;  // `name:`, else the file's stem
  std::string description;
  sim::ActuatorConfig actuator;
  sim::LineConfig line;
  sim::FaultConfig faults;
  // The keys the file set, as "section.key" (e.g. "actuator.busy_delay_ms"),
  // so a front end knows what came from the profile.
  std::set<std::string> given;
};

// A profile the twin cannot use (the message names the file, line and rule):
// an InvalidArgument, so one catch (const lec6::Error&) catches it too.
class ProfileError : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

// The default twin (sim::default_config(): the field's evidence where it is
// strong enough, docs/protocol-decisions.md "The default twin"), named
// "default"; and the manual's ideal (sim::ideal_config(), `lec sim --ideal`),
// named "ideal". A profile file is read over one of them.
FieldProfile default_profile();
FieldProfile ideal_profile();

// A twin named as a user names it (`lec --sim-profile`, a serve sim line's
// `profile:`): "default", "ideal", or a profile file read over the default.
// Throws ProfileError.
FieldProfile named_profile(const std::string& name);

// Reads and checks a profile file. Throws ProfileError.
FieldProfile load_field_profile(const std::filesystem::path& path,
                                const FieldProfile& defaults = {});
// The same from text; `source` names it in messages.
FieldProfile parse_field_profile(std::string_view text, const std::string& source,
                                 const FieldProfile& defaults = {});

// The keys a profile may hold, per section ("actuator", "line", "faults"),
// for help texts.
std::string field_profile_keys();

}  // namespace lec6::twin
