#pragma once
// The session a master had with a controller, read from a capture's exchanges
// for the calibration (calibrate.cpp, calibrate_sequences.cpp): starts, flag
// polls and reads, dated as the twin samples them (query end + Ts). Private to twin/.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>
#include <vector>

#include "lec6/modbus/pdu.hpp"
#include "lec6/twin/calibrate.hpp"
#include "lec6/twin/replay.hpp"

namespace lec6::twin {

using modbus::FunctionCode;

inline constexpr uint16_t kBusyInput = 0x48;
inline constexpr uint16_t kSetonInput = 0x4A;
inline constexpr uint16_t kDriveCoil = 0x1A;
inline constexpr uint16_t kSetupCoil = 0x1C;

enum class StartKind { Direct, Step, Home };

struct Start {
  StartKind kind = StartKind::Direct;
  int64_t act_us = 0;  // the controller acted on the start: end of query + Ts
  std::size_t line = 0;
  std::optional<double> speed, accel, decel;  // commanded (direct moves)
  std::optional<double> target_mm;            // commanded ABS target (direct moves)
};

template <typename T>
struct Sampled {
  int64_t t_us = 0;
  T value{};
};

// What the master learnt from the line, dated as the twin samples (query end + Ts).
struct Session {
  std::vector<Start> starts;
  std::vector<Sampled<int32_t>> positions;  // D9000, 0.01 mm
  std::vector<Sampled<int>> speeds;         // D9002, mm/s
  std::vector<Sampled<int>> thrusts;        // D9003, %
  std::vector<Sampled<bool>> busy;          // X48
  std::vector<Sampled<bool>> seton;         // X4A
};

inline Session read_session(std::span<const Exchange> exchanges, int64_t ts_us) {
  Session s;
  std::array<uint16_t, 16> direct{};  // D9102–D9111 as written
  bool drive = false, setup = false;
  for (const auto& e : exchanges) {
    if (!e.reply) continue;
    auto q = modbus::decode_request(e.query);
    auto r = modbus::decode_response(*e.reply);
    if (!q || !r || std::holds_alternative<modbus::ExceptionResponse>(r->pdu)) continue;
    const int64_t at = e.query_end_us + ts_us;
    auto coil = [&](uint16_t address, bool on) {
      bool& level = address == kDriveCoil ? drive : setup;
      if (on && !level) {
        s.starts.push_back({address == kDriveCoil ? StartKind::Step : StartKind::Home, at, e.line,
                            std::nullopt, std::nullopt, std::nullopt, std::nullopt});
      }
      level = on;
    };
    std::visit(
        [&](const auto& req) {
          using T = std::decay_t<decltype(req)>;
          if constexpr (std::is_same_v<T, modbus::ReadBitsRequest>) {
            auto* rb = std::get_if<modbus::ReadBitsResponse>(&r->pdu);
            if (!rb || req.function != FunctionCode::ReadInputs) return;
            for (uint16_t i = 0; i < req.count; ++i) {
              const unsigned a = req.start + i;
              if (a == kBusyInput) s.busy.push_back({at, rb->bit(i)});
              if (a == kSetonInput) s.seton.push_back({at, rb->bit(i)});
            }
          } else if constexpr (std::is_same_v<T, modbus::ReadRegistersRequest>) {
            auto* rr = std::get_if<modbus::ReadRegistersResponse>(&r->pdu);
            if (!rr) return;
            for (std::size_t i = 0; i < rr->values.size(); ++i) {
              const unsigned a = req.start + static_cast<unsigned>(i);
              if (a == 0x9000 && i + 1 < rr->values.size()) {
                s.positions.push_back({at, static_cast<int32_t>((uint32_t{rr->values[i]} << 16) |
                                                                rr->values[i + 1])});
              }
              if (a == 0x9002) s.speeds.push_back({at, rr->values[i]});
              if (a == 0x9003) s.thrusts.push_back({at, rr->values[i]});
            }
          } else if constexpr (std::is_same_v<T, modbus::WriteCoilRequest>) {
            if (req.coil == kDriveCoil || req.coil == kSetupCoil) coil(req.coil, req.on());
          } else if constexpr (std::is_same_v<T, modbus::WriteCoilsRequest>) {
            for (uint16_t i = 0; i < req.count; ++i) {
              const uint16_t a = static_cast<uint16_t>(req.start + i);
              if (a == kDriveCoil || a == kSetupCoil) coil(a, req.bit(i));
            }
          } else if constexpr (std::is_same_v<T, modbus::WriteRegistersRequest>) {
            const auto values = req.values();
            bool start = false;
            for (std::size_t i = 0; i < values.size(); ++i) {
              const unsigned a = req.start + static_cast<unsigned>(i);
              if (a >= 0x9102 && a <= 0x9111) direct[a - 0x9102] = values[i];
              if (a == 0x9100 && values[i] != 0) start = true;
            }
            if (start) {
              s.starts.push_back({StartKind::Direct, at, e.line, double(direct[1]),
                                  double(direct[4]), double(direct[5]), std::nullopt});
              if (direct[0] == 1) {  // ABS: the target, for retargets (issue 33)
                s.starts.back().target_mm =
                    static_cast<int32_t>((uint32_t{direct[2]} << 16) | direct[3]) / 100.0;
              }
            }
          }
        },
        q->pdu);
  }
  return s;
}

template <typename T>
inline std::vector<Sampled<T>> between(const std::vector<Sampled<T>>& v, int64_t from, int64_t to) {
  std::vector<Sampled<T>> out;
  for (const auto& x : v)
    if (x.t_us >= from && x.t_us < to) out.push_back(x);
  return out;
}

template <typename T>
inline std::optional<Sampled<T>> last_before(const std::vector<Sampled<T>>& v, int64_t t) {
  std::optional<Sampled<T>> out;
  for (const auto& x : v)
    if (x.t_us < t) out = x;
  return out;
}

// Homing speed and direction, SETON on a re-home and the retarget behaviour
// from the sequences of the session (calibrate_sequences.cpp), into `c`.
void fit_sequences(const Session& s, Calibration& c);

}  // namespace lec6::twin
