// How many cases a property walks, in the sanitizer tree and elsewhere.
//
// The sanitizer tree (make test's second tree: Debug, ASan and UBSan; the
// layers between modbus/ and serve/ at -O1, the rest at -O0) runs the
// CPU-bound properties many times slower than the optimised tree (2026-11-29,
// all at -O0: SniffLine's 10^5 exchanges 1 s against 50 s, the command turns'
// 300 random plants 3.4 s against 56 s). Its job there is memory and
// undefined-behaviour errors on the paths the cases take, which a fraction of
// the cases reaches; the optimised tree walks every case, and `make soak`
// more. So a property that walks many cases walks `sanitized(all, fewer)`.
#pragma once

namespace lec6::testing {

#if defined(__SANITIZE_ADDRESS__)  // GCC
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)  // clang
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

// `all` in the optimised tree, `fewer` under the sanitizers.
template <typename T>
constexpr T sanitized(T all, T fewer) {
  return kSanitized ? fewer : all;
}

}  // namespace lec6::testing
