#!/usr/bin/env bash
# Sixteen controllers on one line (`lec sim --ids 1-16`): each ID answers its
# own echo and read, an ID not on the bus (17) gets silence (raw read and a
# pymodbus timeout), and nobody else speaks meanwhile.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --module pymodbus.client

PORT=$TMP/lec0
if start_twin ids --pty "$PORT" --ids 1-16; then
  check_sh "ready line names the IDs: $READY" '[[ $READY == *"(ids 1-16, timing real, 38400 baud"* ]]'
  run_peer "pymodbus: IDs 1-16 answer, 17 is silent" pymodbus "$PORT" ids 16
  stop_twin "$TWIN_PID"
  check "twin ends with status 0 on SIGTERM" [ "$STATUS" = 0 ]
else
  fail "twin did not start"
fi

# A sparse set: 3, 7-8, 200 answer; 1 does not.
if start_twin sparse --pty "$PORT" --ids 200,7-8,3; then
  check_sh "ready line: $READY" '[[ $READY == *"(ids 3, 7-8, 200,"* ]]'
  run_peer "pymodbus: IDs 3, 7, 8, 200 echo; 1, 2, 9, 201 are silent" \
    pymodbus "$PORT" echo-ids 3,7,8,200 1,2,9,201
  stop_twin "$TWIN_PID"
else
  fail "sparse twin did not start"
fi
finish
