#!/usr/bin/env bash
# Proves that tools/check-deps can fail: runs it against copies of
# tools/deps.txt with one entry removed (or a wrong one added) and checks that
# it fails naming the package and the command that installs it. Run by ctest
# (tests/CMakeLists.txt, tests deps.*), one case per test:
#
#   tools/check-deps-test.sh CASE [CMakeCache.txt]
#
#   complete        the list as it is: passes
#   serial-asyncio  without python3-serial-asyncio (issue 11: pymodbus.client
#                   imports serial_asyncio; Debian only Recommends it): fails
#   python-module   without python3-pymodbus (a Python module's package): fails
#   program         without mbpoll (a program's package): fails
#   doc-program     without mosquitto-clients (docs/mqtt.md's ```sh lines run
#                   mosquitto_sub; the README test runs them as pasted): fails
#   redundant       with python3 added (a hard Depends of python3-pymodbus): fails
#   wrong-note      with a [py: ...] note on the wrong package: fails
#   installer       tools/install-deps.sh --dry-run reads entries, comments
#                   and alternatives `a | b` of a list as the check does
set -euo pipefail

tools=$(cd "$(dirname "$0")" && pwd)
case_name=${1:?usage: check-deps-test.sh CASE [CMakeCache.txt]}
cache=()
[[ -n ${2:-} ]] && cache=(--cmake-cache "$2")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
list=$work/deps.txt

# without PACKAGE: the list minus the entry of PACKAGE (and its indented comment lines).
without() {
  grep -q "^$1 " "$tools/deps.txt" || { echo "FAIL: $1 is not in tools/deps.txt" >&2; exit 1; }
  awk -v p="$1" '$1 == p { skip = 1; next } skip && /^[ \t]+#/ { next } { skip = 0; print }' \
    "$tools/deps.txt" >"$list"
}
# expect_fail NEEDLE...: the check exits 1 and its output has every NEEDLE.
expect_fail() {
  local rc=0 n
  "$tools/check-deps" --list "$list" "${cache[@]}" >"$work/out" 2>&1 || rc=$?
  cat "$work/out"
  [[ $rc -eq 1 ]] || { echo "FAIL: check-deps exited $rc, expected 1" >&2; exit 1; }
  for n in "$@"; do
    grep -qF -- "$n" "$work/out" || { echo "FAIL: '$n' not in the check's output" >&2; exit 1; }
  done
  echo "ok: check-deps fails ($case_name) and says: $*"
}

case $case_name in
  complete)
    "$tools/check-deps" "${cache[@]}"
    ;;
  serial-asyncio)
    without python3-serial-asyncio
    # Installed, it is a package missing from the list; not installed (a
    # fresh machine), a module pymodbus.client cannot import: either way the
    # package and the command that installs it are named.
    expect_fail "module serial_asyncio" "import pymodbus.client" "python3-serial-asyncio"
    grep -qE "sudo apt-get install -y --no-install-recommends .*python3-serial-asyncio" "$work/out" ||
      { echo "FAIL: no apt-get command installing python3-serial-asyncio" >&2; exit 1; }
    ;;
  python-module)
    without python3-pymodbus
    expect_fail "python3-pymodbus" "module pymodbus" "apt-get install -y --no-install-recommends"
    ;;
  program)
    without mbpoll
    # (the first script that runs it is named: cycle_test.sh, mbpoll_test.sh, ...)
    expect_fail "mbpoll" "program mbpoll" "needed by tests/integration/" \
      "sudo apt-get install -y --no-install-recommends mbpoll"
    ;;
  doc-program)
    without mosquitto-clients
    expect_fail "mosquitto-clients" "program mosquitto_sub" "docs/mqtt.md" \
      "sudo apt-get install -y --no-install-recommends mosquitto-clients"
    ;;
  redundant)
    cp "$tools/deps.txt" "$list"
    echo "python3                  # redundant on purpose" >>"$list"
    expect_fail "python3 (line" "hard Depends of python3-pymodbus"
    ;;
  wrong-note)
    sed 's/^jq .*/jq  # [py: pymodbus] wrong on purpose/' "$tools/deps.txt" >"$list"
    expect_fail "says it provides module pymodbus"
    ;;
  installer)
    # Installed, an installed second alternative, an indented comment: nothing missing.
    printf '%s\n' "# head" "bash   # why [bin: bash]" "nosuch-lec6-a | coreutils  # alternatives" \
      "                 # goes on" >"$list"
    "$tools/install-deps.sh" --dry-run "$list"
    # Nothing installed of a group: named with its alternatives, exit 1.
    printf '%s\n' "bash" "nosuch-lec6-a | nosuch-lec6-b   # neither exists" >"$list"
    rc=0
    "$tools/install-deps.sh" --dry-run "$list" >"$work/out" 2>&1 || rc=$?
    cat "$work/out"
    [[ $rc -eq 1 ]] || { echo "FAIL: install-deps --dry-run exited $rc, expected 1" >&2; exit 1; }
    grep -qF "missing from $list: nosuch-lec6-a | nosuch-lec6-b" "$work/out" ||
      { echo "FAIL: the missing group is not named" >&2; exit 1; }
    # The real list: after `make deps` nothing of it is missing.
    "$tools/install-deps.sh" --dry-run
    echo "ok: install-deps reads the list's entries, comments and alternatives"
    ;;
  *)
    echo "unknown case $case_name" >&2
    exit 2
    ;;
esac
