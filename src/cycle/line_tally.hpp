#pragma once
// What each line of a cycle carried during a run (runner.cpp, private):
// its counters when the cycle began against now. Axes on one master share a
// line.

#include <algorithm>
#include <string>
#include <vector>

#include "lec6/client/master.hpp"
#include "lec6/cycle/runner.hpp"

namespace lec6::cycle::detail {

class LineTally {
 public:
  void add(const std::string& axis, client::Master& m) {
    auto it =
        std::find_if(lines_.begin(), lines_.end(), [&](const Line& l) { return l.master == &m; });
    if (it == lines_.end()) {
      lines_.push_back({&m, m.stats(), {m.describe(), {}, 0, 0, {}}});
      it = std::prev(lines_.end());
    }
    it->use.axes.push_back(axis);
  }

  std::vector<LineUse> since_added() const {
    std::vector<LineUse> out;
    for (const auto& l : lines_) {
      const client::LinkStats now = l.master->stats();
      LineUse u = l.use;
      u.transactions = now.transactions - l.at_start.transactions;
      u.timeouts = now.timeouts - l.at_start.timeouts;
      u.busy = now.busy - l.at_start.busy;
      out.push_back(std::move(u));
    }
    return out;
  }

 private:
  struct Line {
    client::Master* master = nullptr;
    client::LinkStats at_start;
    LineUse use;
  };
  std::vector<Line> lines_;
};

}  // namespace lec6::cycle::detail
