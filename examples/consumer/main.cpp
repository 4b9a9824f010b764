// A program using liblec6 through find_package(lec6): lec6::lec6 only, no twin.
#include <iostream>

#include "lec6/lec/explain.hpp"
#include "lec6/version.hpp"

int main() {
  const uint8_t frame[] = {0x01, 0x05, 0x00, 0x19, 0xFF, 0x00, 0x5D, 0xFD};  // the manual's SVON
  std::cout << "liblec6 " << lec6::kVersion << ": "
            << lec6::lec::explain_bytes(frame, lec6::lec::FrameRole::Request) << '\n';
}
