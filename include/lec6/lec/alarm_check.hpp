#pragma once
// Deciding whether an alarm is present (issue 33): never from X4F alone.
//
// The manual says X4F ALARM is positive logic (§10.3: 1 = alarm present) and
// its §4/§7 example replies agree; its own §9.2 format example (`04 8E`) shows
// X4F = 1 beside SVRE, SETON and INP, and two field drivers read X4F = 1 as
// "no alarm". So X4F is cross-checked with the alarm code the controller
// reports (D0380, group 0: "the latest alarm (being generated)", §10.5) and
// with motion (an alarm stops the operation: BUSY 0), and a disagreement is
// said in the user's words, with the setting that would fix it
// (docs/protocol-decisions.md, "ALARM polarity"; tests/lec/alarm_check_test.cpp).
//
// Thread safety: value types and pure functions.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/lec/alarms.hpp"
#include "lec6/lec/flags.hpp"

namespace lec6::lec {

// How a controller reports X4F: ActiveHigh (the manual: 1 = alarm) or
// ActiveLow (0 = alarm). A per-controller setting (`alarm_polarity:`).
enum class AlarmPolarity { ActiveHigh, ActiveLow };

// "active-high" / "active-low".
std::string_view to_string(AlarmPolarity p) noexcept;
// Parses "active-high" / "active-low"; nullopt for anything else.
std::optional<AlarmPolarity> parse_alarm_polarity(std::string_view text) noexcept;

// X40–X4F as read on the wire, turned into the manual's meaning (X4F = 1:
// alarm present) for a controller of polarity `p`. Every other bit is kept.
StatusFlags normalise_alarm(StatusFlags wire, AlarmPolarity p) noexcept;

struct AlarmJudgement {
  bool active = false;         // an alarm is present (X4F and the code agree)
  std::vector<uint8_t> codes;  // its codes (group 0) when active
  // Empty when X4F, the alarm code and motion agree; otherwise what disagrees
  // and what to do, e.g. "X4F reads ALARM but the alarm history (D0380) holds
  // no code: this controller reports ALARM inverted; set `alarm_polarity:
  // active-low`".
  std::string disagreement;
  // The polarity the evidence points at, when it points away from the configured one.
  std::optional<AlarmPolarity> suggested;
};

// `flags`: already normalised with `configured` (normalise_alarm, or a Client
// with ClientOptions::alarm_polarity). `group0`: D0380–D0383.
AlarmJudgement judge_alarm(const StatusFlags& flags, const AlarmGroup& group0,
                           AlarmPolarity configured);

// What to tell a user whose RESET left alarms `left` active (group 0's codes
// while X4F still reads as an alarm), for a controller configured as
// `configured`; `reset_how` names the front end's reset ("`lec reset`").
// A code RESET does not clear (outside 48-99) needs the servo off or a power
// cycle. A code RESET does clear that survives it means its cause is still
// there, or (the cross-check judge_alarm cannot make: group 0 keeps the old
// code, docs/protocol-decisions.md "ALARM polarity") that the controller
// reports ALARM inverted and is healthy: the message says both and names the
// setting. "alarm still active after RESET: 62 (…); …".
std::string alarm_after_reset(const std::vector<uint8_t>& left, AlarmPolarity configured);

}  // namespace lec6::lec
