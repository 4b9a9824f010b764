#pragma once
// A machine cycle lec serve runs on its own axes (issue 34; docs/cycles.md,
// "Through lec serve"): the cycle as read from its file, and where each of
// its axes is among lec serve's. Made when the config is read
// (cycles_config.cpp), so a cycle naming an axis lec serve does not have
// stops lec serve from starting at all.
//
// How a cycle's axis finds lec serve's: by line and controller ID. Its
// `line:` names one of lec serve's lines (its name or its port); without
// one, lec serve must have one line. The ID must be an axis of that line.
// The axis keeps the cycle's name in the cycle and its reports; refusals and
// the axes' status use lec serve's name.
//
// Thread safety: plain values, unchanged once read.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "lec6/cycle/cycle.hpp"

namespace lec6::serve {

struct ServedCycle {
  cycle::Cycle cycle;  // soft limits: the cycle's within lec serve's for the axis
  std::filesystem::path file;
  struct Axis {
    std::string line;        // lec serve's line name
    uint8_t id = 1;          // the controller ID
    std::string serve_name;  // lec serve's name of the axis
  };
  std::map<std::string, Axis> axes;  // by the cycle's axis name
  const std::string& name() const { return cycle.name; }
};

}  // namespace lec6::serve
