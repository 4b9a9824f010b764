#!/usr/bin/env bash
# `make deb` builds the configuration the tests ran on (issue 27: a Release
# tree nobody built failed on a GCC warning). Asks make for the configure
# commands of the test tree and of the deb tree (`make -n`, nothing runs),
# and checks that they give CMake the same options, save the ones that leave
# out tests, benchmarks and the Python module; and that this tree, the one
# ctest runs, was configured with those flags.
set -euo pipefail
: "${LEC6_SOURCE_DIR:?}" "${LEC6_BUILD_DIR:?}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
make -n -s -C "$LEC6_SOURCE_DIR" BUILD="$tmp/test" DEB_BUILD="$tmp/deb" \
  "$tmp/test/CMakeCache.txt" "$tmp/deb/CMakeCache.txt" >"$tmp/plan"
exec /usr/bin/python3 - "$tmp" "$LEC6_BUILD_DIR/CMakeCache.txt" <<'PY'
import re, shlex, sys
tmp, cache = sys.argv[1], sys.argv[2]
plan = open(f"{tmp}/plan").read()
lines = {}
for line in plan.splitlines():
    if not line.startswith("cmake "):
        continue
    args = shlex.split(line)
    build = args[args.index("-B") + 1]
    name = "test" if build == f"{tmp}/test" else "deb" if build == f"{tmp}/deb" else None
    if name:
        i = args.index("-S")
        lines[name] = args[1:i] + args[i + 4:]  # without -S . -B dir
fail = 0
if set(lines) != {"test", "deb"}:
    print(f"FAIL: make -n printed no configure command for both trees:\n{plan}")
    sys.exit(1)
left_out = {"-DLEC6_TESTS=OFF", "-DLEC6_BENCH=OFF", "-DLEC6_PYTHON=OFF"}
deb = [a for a in lines["deb"] if a not in left_out]
if deb != lines["test"]:
    print(f"FAIL: make deb configures with {deb},\n      the tested tree with {lines['test']}")
    fail = 1
want = dict(a[2:].split("=", 1) for a in lines["deb"] if a.startswith("-D"))
have = {}
for line in open(cache):
    m = re.match(r"([A-Za-z0-9_]+):[A-Z]+=(.*)", line)
    if m:
        have[m.group(1)] = m.group(2)
for key in ("CMAKE_BUILD_TYPE", "CMAKE_CXX_FLAGS_RELWITHDEBINFO"):
    if key in want and have.get(key) != want[key]:
        print(f"FAIL: this tree has {key}={have.get(key)!r}; make deb builds with {want[key]!r}")
        fail = 1
if not fail:
    print("deb flags: make deb builds the tested configuration:", " ".join(deb))
sys.exit(fail)
PY
