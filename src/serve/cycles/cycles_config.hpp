#pragma once
// `cycles:` of lec serve's config (private to serve/config/config.cpp): a
// list of cycle files, or one directory (its *.yaml and *.yml), relative to
// the config file's directory. Each is read (docs/cycles.md) and its axes
// matched to the config's (served_cycle.hpp); a mistake is a ConfigError
// naming the config's line and the cycle file's:
//
//   lec6.yaml:30: cycles[0]: cell.yaml:14:3: axes.y: lec serve has no axis with ID 5 on ...

#include <yaml-cpp/yaml.h>

#include "config/config_reader.hpp"
#include "lec6/serve/config.hpp"

namespace lec6::serve {

// Reads `n` (absent: nothing) into config.cycles; config.lines must be read.
void read_cycles(const Reader& r, const YAML::Node& n, ServeConfig& config);

}  // namespace lec6::serve
