#include "lec6/client/master.hpp"

#include <thread>

namespace lec6::client {

void Master::idle_until(TimePoint t) {
  const Duration d = t - clock().now();
  if (d > Duration::zero()) std::this_thread::sleep_for(d);
}

}  // namespace lec6::client
