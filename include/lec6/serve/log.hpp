#pragma once
// Where lec serve's components say what happened (the daemon prints it with
// a timestamp; tests collect it).

#include <functional>
#include <string_view>

namespace lec6::serve {

enum class LogLevel { Info, Warning, Error };
using Log = std::function<void(LogLevel, std::string_view)>;

}  // namespace lec6::serve
