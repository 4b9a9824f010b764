#pragma once
// Clears a coil when leaving scope, whatever happened (SETUP after homing,
// DRIVE after a step, JOG after a jog: the manual asks for it and field
// drivers always do it). Private to client/actuator*.cpp.

#include "lec6/client/client.hpp"

namespace lec6::client::detail {

class CoilReset {
 public:
  CoilReset(Client& c, lec::Coil coil) : client_(c), coil_(coil) {}
  ~CoilReset() {
    try {
      client_.write_coil(coil_, false);  // a release: Ctrl-C on the line lets it through
    } catch (...) {                      // the primary error is already on its way
    }
  }
  CoilReset(const CoilReset&) = delete;
  CoilReset& operator=(const CoilReset&) = delete;

 private:
  Client& client_;
  lec::Coil coil_;
};

}  // namespace lec6::client::detail
