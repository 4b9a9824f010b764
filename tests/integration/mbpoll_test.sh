#!/usr/bin/env bash
# mbpoll (Debian's mbpoll, on libmodbus) against `lec sim` on a real
# pseudo-terminal. mbpoll numbers references from 1 unless given -0; every
# call here uses -0, so -r is the PDU address (X40 = 64, Y30 = 48, D9000 =
# 36864). The twin's --trace shows which function code mbpoll really sent.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --program mbpoll

PORT=$TMP/lec0
# The manual's replies exactly, right after each write: the manual's ideal twin.
start_twin mbpoll --pty "$PORT" --trace --ideal || {
  fail "twin did not start"
  finish
  exit 1
}
TRACE=$TMP/mbpoll.err

# mbpoll ARGS...: one poll of slave 1 at 38400 8N1, PDU addressing; output in
# $OUT (stdout and stderr), status in $RC.
mb() {
  RC=0
  OUT=$(timeout 20 mbpoll -m rtu -a 1 -b 38400 -P none -0 -1 -o 1 "$@" 2>&1) || RC=$?
}
has() { grep -qF -- "$1" <<<"$OUT"; }
traced() { grep -qF -- "$1" "$TRACE"; }

mb -t 1 -r 64 -c 16 "$PORT"
zeros=$(grep -cE '^\[(6[4-9]|7[0-9])\]:[[:space:]]+0$' <<<"$OUT")
check "FC02 X40 x16 at power-on: 16 inputs, all 0" [ "$RC" = 0 -a "$zeros" = 16 ]
check "  mbpoll sent 01 02 00 40 00 10 (the manual's 4.1.3 query)" traced "<- 01 02 00 40 00 10 78 12"

mb -t 0 -r 48 "$PORT" 1
check "write Y30 = 1 (coil 48)" [ "$RC" = 0 ]
check "  as FC05 FF00: 01 05 00 30 FF 00 8C 35 (manual 4.1.1)" traced "<- 01 05 00 30 FF 00 8C 35"
mb -t 0 -r 48 -c 1 "$PORT"
check "FC01 reads Y30 = 1 back" has "[48]: 	1"

mb -t 0 -r 25 "$PORT" 1
check "write Y19 SVON = 1" [ "$RC" = 0 ]
# SVRE rises 50 ms after SVON: poll X40-X4F until X49 (reference 73) is 1, at most 20 times.
svre=no
for _ in $(seq 1 20); do
  mb -t 1 -r 64 -c 16 "$PORT"
  if has "[73]: 	1"; then
    svre=yes
    break
  fi
done
check "X49 SVRE = 1 after servo on" [ "$svre" = yes ]

mb -t 4 -r 36864 -c 2 "$PORT"
check "FC03 D9000 x2 (holding registers 36864-36865) = 0 0" \
  [ "$RC" = 0 -a "$(grep -cE '^\[3686[45]\]:[[:space:]]+0$' <<<"$OUT")" = 2 ]
check "  mbpoll sent 01 03 90 00 00 02 E9 0B (the manual's example 3 query)" traced "<- 01 03 90 00 00 02 E9 0B"

mb -t 4 -r 1058 "$PORT" 7
check "a single register write (FC06) fails" [ "$RC" != 0 ]
check "  with exception 01, 'Illegal function'" has "Illegal function"
check "  mbpoll really sent FC06" traced "<- 01 06 04 22 00 07"
check "  and the twin answered 01 86 01" traced "-> 01 86 01"

mb -t 4 -r 1058 "$PORT" 0 15000
check_sh "two registers (FC10) at D0422-D0423 = 0, 15000 (step 2 position 150.00)" \
  '[ "$RC" = 0 ] && has "Written 2 references"' 
check "  the manual's example 2 frame shape: 01 10 04 22 00 02 04 00 00 3A 98" \
  traced "<- 01 10 04 22 00 02 04 00 00 3A 98"
mb -t 4:int -B -r 1058 -c 1 "$PORT"
check "32-bit read of D0422 (big-endian words) = 15000" has "[1058]: 	15000"

mb -t 4:hex -r 14 -c 2 "$PORT"
check_sh "D000E-D000F hold the name's first characters 'LEC6' (0x4C45 0x4336)" \
  'has "[14]: 	0x4C45" && has "[15]: 	0x4336"' 

mb -t 4 -r 0 -c 1 "$PORT"
check_sh "read D0000 (outside every area) -> 'Illegal data address' (02)" \
  '[ "$RC" != 0 ] && has "Illegal data address"' 

mb -t 3 -r 36864 -c 2 "$PORT"
check_sh "FC04 input registers -> 'Illegal function' (01)" '[ "$RC" != 0 ] && has "Illegal function"' 

stop_twin "$TWIN_PID"
check "twin ends with status 0 on SIGTERM" [ "$STATUS" = 0 ]
finish
