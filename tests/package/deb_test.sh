#!/usr/bin/env bash
# Builds the Debian package of this build (CPack; `make deb` builds the same
# configuration: package.deb_flags), unpacks it into a temporary root (dpkg
# -x) and runs the `lec` in it (--version, demo); checks the package holds
# the library, headers, CMake config, pkg-config file, man page, bash
# completion, the systemd unit, the dashboard (without source maps) and
# /usr/share/doc/lec6, and that its control fields say what it is and what
# it needs.
set -euo pipefail
: "${LEC6_BUILD_DIR:?}" "${LEC6_VERSION:?}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

if ! cpack --config "$LEC6_BUILD_DIR/CPackConfig.cmake" -G DEB -B "$tmp/out" >"$tmp/cpack.log" 2>&1; then
  cat "$tmp/cpack.log"
  exit 1
fi
debs=("$tmp"/out/*.deb)
[[ ${#debs[@]} -eq 1 && -f ${debs[0]} ]] || { echo "FAIL: expected one .deb, got: ${debs[*]}"; exit 1; }
deb=${debs[0]}

fail=0
bad() { echo "FAIL: $*"; fail=1; }

[[ $(dpkg-deb -f "$deb" Package) == lec6 ]] || bad "package name $(dpkg-deb -f "$deb" Package)"
[[ $(dpkg-deb -f "$deb" Version) == "$LEC6_VERSION" ]] || bad "package version $(dpkg-deb -f "$deb" Version)"

dpkg -x "$deb" "$tmp/root"
version=$("$tmp/root/usr/bin/lec" --version)
[[ $version == "lec $LEC6_VERSION" ]] || bad "lec --version printed '$version', expected 'lec $LEC6_VERSION'"

for f in usr/bin/lec \
  usr/lib/liblec6_modbus.a usr/lib/liblec6_lec.a usr/lib/liblec6_client.a \
  usr/lib/liblec6_transport.a usr/lib/liblec6_sim.a usr/lib/liblec6_twin.a \
  usr/include/lec6/version.hpp usr/include/lec6/client/client.hpp \
  usr/lib/cmake/lec6/lec6Config.cmake usr/lib/cmake/lec6/lec6ConfigVersion.cmake \
  usr/lib/cmake/lec6/lec6Targets.cmake usr/lib/pkgconfig/lec6.pc \
  usr/share/man/man1/lec.1.gz usr/share/bash-completion/completions/lec \
  usr/lib/systemd/system/lec-serve.service usr/share/lec6/web/index.html \
  usr/share/doc/lec6/copyright usr/share/doc/lec6/changelog.gz; do
  [[ -f $tmp/root/$f ]] || bad "$f is not in the package"
done

# The man page is lec's help: its options are in it.
if [[ -f $tmp/root/usr/share/man/man1/lec.1.gz ]]; then
  man=$(gzip -dc "$tmp/root/usr/share/man/man1/lec.1.gz")
  for want in '\-\-port' 'status' "$LEC6_VERSION" 'LEC□6'; do
    grep -qF -- "$want" <<<"$man" || bad "the man page lacks $want"
  done
fi
maps=$(cd "$tmp/root" && find . -name '*.map')
[[ -z $maps ]] || bad "the package ships source maps: $maps"
if [[ -f $tmp/root/usr/share/doc/lec6/changelog.gz ]]; then
  head=$(gzip -dc "$tmp/root/usr/share/doc/lec6/changelog.gz" | head -1)
  [[ $head == "lec6 ($LEC6_VERSION) "* ]] ||
    bad "the changelog's first entry is '$head', not version $LEC6_VERSION (cmake/deb/changelog)"
fi
description=$(dpkg-deb -f "$deb" Description)
for want in 'lec serve' dashboard 'Modbus TCP' MQTT liblec6; do
  grep -qF -- "$want" <<<"$description" || bad "the description does not mention $want"
done
# lec6.pc says Requires: fmt: fmt's development files are a hard dependency.
depends=$(dpkg-deb -f "$deb" Depends)
grep -qE '(^|, )libfmt-dev($|[ ,])' <<<"$depends" || bad "Depends lacks libfmt-dev: '$depends'"
grep -q '^Requires: fmt' "$tmp/root/usr/lib/pkgconfig/lec6.pc" || bad "lec6.pc no longer requires fmt"
# The packaged lec does real work: the manual's four examples on its twin.
if ! timeout 120 "$tmp/root/usr/bin/lec" demo >"$tmp/demo.log" 2>&1; then
  bad "the packaged lec demo failed: $(tail -5 "$tmp/demo.log")"
fi
grep -q '^ExecStart=/usr/bin/lec serve' "$tmp/root/usr/lib/systemd/system/lec-serve.service" ||
  bad "the unit does not run lec serve"
# The move history is on by default: the unit gives it /var/lib/lec6 ($STATE_DIRECTORY).
grep -q '^StateDirectory=lec6$' "$tmp/root/usr/lib/systemd/system/lec-serve.service" ||
  bad "the unit has no StateDirectory=lec6 (the move history would not be kept)"

[[ $fail -eq 0 ]] && echo "deb: $(basename "$deb") holds everything; its lec runs: $version"
exit $fail
