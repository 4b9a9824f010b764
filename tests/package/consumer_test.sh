#!/usr/bin/env bash
# Installs the build into a temporary prefix, then builds and runs
# examples/consumer against it, once with find_package(lec6) and once with
# pkg-config: the exported package works for a program outside this tree.
set -euo pipefail
: "${LEC6_SOURCE_DIR:?}" "${LEC6_BUILD_DIR:?}" "${LEC6_VERSION:?}" "${CXX:?}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
prefix=$tmp/prefix
flags=${LEC6_CONSUMER_FLAGS:-}

cmake --install "$LEC6_BUILD_DIR" --prefix "$prefix" >"$tmp/install.log"

fail=0
bad() { echo "FAIL: $*"; fail=1; }

# Nothing of our own build flags reaches consumers: no -Werror, no sanitizer.
if grep -rqE -- "-Werror|-fsanitize" "$prefix"/lib/cmake/lec6 "$prefix"/lib/pkgconfig; then
  bad "the installed package forces build flags on consumers:"
  grep -rnE -- "-Werror|-fsanitize" "$prefix"/lib/cmake/lec6 "$prefix"/lib/pkgconfig
fi
# lec6::lec6 does not bring the twin.
core=$(grep -A3 'set_target_properties(lec6::lec6 ' "$prefix"/lib/cmake/lec6/lec6Targets.cmake)
if grep -qE 'twin|sim' <<<"$core"; then bad "lec6::lec6 links the twin: $core"; fi

# ---- find_package(lec6) ----
if ! cmake -S "$LEC6_SOURCE_DIR/examples/consumer" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_CXX_COMPILER="$CXX" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$flags" >"$tmp/configure.log" 2>&1; then
  cat "$tmp/configure.log"
  exit 1
fi
if ! cmake --build "$tmp/build" -j 2 >"$tmp/build.log" 2>&1; then
  cat "$tmp/build.log"
  exit 1
fi
out=$("$tmp/build/explain_frame")
want="liblec6 $LEC6_VERSION: ID 1 write Y19 SVON = ON"
[[ $out == "$want" ]] || bad "explain_frame printed '$out', expected '$want'"
if out=$("$tmp/build/twin_move"); then
  [[ $out == "position 50.00 mm, INP 1, BUSY 0" ]] || bad "twin_move printed '$out'"
else
  bad "twin_move failed: $out"
fi

# ---- pkg-config ----
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
[[ $(pkg-config --modversion lec6) == "$LEC6_VERSION" ]] || bad "pkg-config --modversion lec6"
# shellcheck disable=SC2046,SC2086
if ! "$CXX" -std=c++20 $flags "$LEC6_SOURCE_DIR/examples/consumer/main.cpp" -o "$tmp/pc_explain" \
  $(pkg-config --cflags --libs lec6) 2>"$tmp/pc.log"; then
  cat "$tmp/pc.log"
  bad "building main.cpp with pkg-config lec6"
elif [[ $("$tmp/pc_explain") != "$want" ]]; then
  bad "pkg-config build printed '$("$tmp/pc_explain")'"
fi
# shellcheck disable=SC2046,SC2086
if ! "$CXX" -std=c++20 $flags "$LEC6_SOURCE_DIR/examples/consumer/twin_move.cpp" -o "$tmp/pc_twin" \
  $(pkg-config --cflags --libs lec6-sim) 2>"$tmp/pc.log"; then
  cat "$tmp/pc.log"
  bad "building twin_move.cpp with pkg-config lec6-sim"
elif [[ $("$tmp/pc_twin") != "position 50.00 mm, INP 1, BUSY 0" ]]; then
  bad "pkg-config twin build printed '$("$tmp/pc_twin")'"
fi

[[ $fail -eq 0 ]] && echo "consumer: find_package and pkg-config builds run"
exit $fail
