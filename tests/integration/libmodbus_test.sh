#!/usr/bin/env bash
# libmodbus (Debian's libmodbus 3.1, the C library most Modbus tools use) against
# `lec sim` on a real pseudo-terminal: tests/integration/libmodbus_peer.c runs
# the manual's examples 1-4, checks final positions, exception codes (errno
# EMBXILFUN/EMBXILADD/EMBXILVAL) and an FC08 echo sent raw.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"

PEER=$LEC6_BUILD_DIR/peers/libmodbus_peer
check "the libmodbus peer was built ($PEER)" [ -x "$PEER" ]

PORT=$TMP/lec0
# The manual's examples reply by reply: the manual's ideal twin (--ideal).
if start_twin libmodbus --pty "$PORT" --ideal; then
  run_peer "libmodbus: examples 1-4, exceptions, echo" timeout 120 "$PEER" "$PORT"
  stop_twin "$TWIN_PID"
  check "twin ends with status 0 on SIGTERM" [ "$STATUS" = 0 ]
else
  fail "twin did not start"
fi
finish
