#!/usr/bin/env bash
# The Wireshark dissector (tools/wireshark/lec6.lua) in Debian's tshark: `lec`
# drives the twin (serial, servo, home, a move, a step written, a read the
# controller refuses), `lec sniff --pcap` hears it on the twin's tap, and
# tshark with the dissector names every frame in the manual's terms: every
# reply paired with its query, nothing unpaired, the registers, coils and flags
# named with their values in units. And the dissector's tables are what the
# memory map says (tools/wireshark/update-tables --check).

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --program tshark

SRC=$(cd "$IT_DIR/../.." && pwd)
LUA=$SRC/tools/wireshark/lec6.lua
DLT='uat:user_dlts:"User 0 (DLT=147)","mbrtu","0","","0",""'

"$PY" "$SRC/tools/wireshark/update-tables" "$LEC6_BUILD_DIR" --check >"$TMP/tables.out" 2>&1
rc=$?  # (before the message's $(cat …), which sets $? to cat's)
check "the dissector's tables are the memory map's: $(cat "$TMP/tables.out")" [ $rc = 0 ]

if start_twin t --pty "$TMP/p" --tap "$TMP/tap" --baud 38400; then
  "$LEC" sniff --port "$TMP/tap" --baud 38400 --json --pcap "$TMP/line.pcap" >"$TMP/s.jsonl" 2>"$TMP/s.err" &
  SNIFF_PID=$!
  TWIN_PIDS+=("$SNIFF_PID")
  wait_for 10 "lec sniff listening" -- grep -q "listening on" "$TMP/s.err"
  lec() { "$LEC" --port "$TMP/p" --baud 38400 "$@" >>"$TMP/lec.out" 2>&1; }
  lec serial on && lec servo on && lec home && lec move --to 150 --speed 200 &&
    lec step set 1 mode=abs speed=100 position=25.5 accel=1000 decel=1000 push-speed=20 &&
    lec status
  rc=$?
  check "lec drove the twin (exit $rc): $(tail -n 3 "$TMP/lec.out")" [ $rc = 0 ]
  lec raw 01 03 80 00 00 01  # outside every area: exception 02
  sleep 0.3  # the tap's last bytes
  kill -INT "$SNIFF_PID"
  wait_bounded "$SNIFF_PID" 10
  stop_twin "$TWIN_PID"

  tshark -X lua_script:"$LUA" -o "$DLT" -r "$TMP/line.pcap" -T fields -E separator='|' \
    -e frame.number -e lec6.role -e lec6.request_in -e lec6.text >"$TMP/t.txt" 2>"$TMP/t.err"
  # (tshark warns when it runs as root, as CI does: that line is not the dissector's.)
  grep -v 'Running as user "root"' "$TMP/t.err" >"$TMP/t.err2"
  check "tshark runs the dissector without an error: $(head -c 300 "$TMP/t.err2")" [ ! -s "$TMP/t.err2" ]
  frames=$(grep -c . "$TMP/t.txt")
  ours=$(grep -cE '"dir":"(query|reply)"' "$TMP/s.jsonl")
  check "one line per frame lec sniff heard ($frames in tshark, $ours in lec sniff)" \
    [ "$frames" -gt 50 -a "$frames" = "$ours" ]
  # Roles and pairing: the same as lec sniff's (every query of lec is answered).
  "$PY" - "$TMP/t.txt" "$TMP/s.jsonl" >"$TMP/roles.out" 2>&1 <<'PY'
import json, sys
rows = [l.rstrip("\n").split("|") for l in open(sys.argv[1]) if l.strip()]
ours = [j["dir"] for j in map(json.loads, open(sys.argv[2])) if j.get("dir") in ("query", "reply")]
roles = [r[1] for r in rows]
bad = [r for r in rows if r[1] == "reply" and (not r[2] or rows[int(r[2]) - 1][1] != "query")]
print(len(roles), roles.count("query"), roles.count("reply"), roles.count("unpaired"), len(bad))
sys.exit(0 if roles == ours and not bad else 1)
PY
  rc=$?
  check "every frame's role is lec sniff's, each reply names its query (frames queries replies unpaired bad: $(cat "$TMP/roles.out"))" [ $rc = 0 ]
  has() { grep -qF -- "$2" "$TMP/t.txt" && pass "$1" || fail "$1: '$2' not in $TMP/t.txt: $(head -c 600 "$TMP/t.txt")"; }
  has "a coil write named" "ID 1 write Y19 SVON = ON"
  has "serial mode named" "write Y30"
  has "the state read named" "read D9000–D9006 (current position…) (7 registers)"
  has "the position in mm" "D9000 current position = 150.00 mm"
  has "the speed in mm/s" "D9002 current speed = "
  has "the direct operation's target in mm" "D9104 direct operation position = 150.00 mm"
  has "the direct start" "D9100 direct operation start = 0100h: start direct operation"
  has "a step's fields in their units" "D0412 step 1 position = 25.50 mm"
  has "a step's mode" "D0410 step 1 mode = abs"
  has "the flags word by name" "SVRE"
  has "the exception with its meaning" "ID 1 exception 02 (illegal data address)"
  # The tree view (-O lec6): the items, one per value.
  tshark -X lua_script:"$LUA" -o "$DLT" -r "$TMP/line.pcap" -O lec6 >"$TMP/tree.txt" 2>/dev/null
  check "the tree lists one item per value (Item: D9000 current position = …)" \
    grep -q "Item: D9000 current position = 150.00 mm" "$TMP/tree.txt"
  # docs/sniff.md's display filter.
  tshark -X lua_script:"$LUA" -o "$DLT" -r "$TMP/line.pcap" -Y 'lec6.item contains "SVON"' \
    >"$TMP/svon.txt" 2>/dev/null
  check "a display filter on lec6.item finds the SVON write, nothing else: $(head -n 2 "$TMP/svon.txt")" \
    [ "$(grep -c . "$TMP/svon.txt")" -ge 1 -a "$(grep -c . "$TMP/svon.txt")" = "$(grep -c SVON "$TMP/svon.txt")" ]
  # A capture without the user DLT setting is no Modbus RTU: the dissector stays silent.
  tshark -X lua_script:"$LUA" -r "$TMP/line.pcap" -T fields -e lec6.text >"$TMP/none.txt" 2>"$TMP/none.err"
  check "without Modbus RTU the dissector says nothing, and does not fail" \
    [ -z "$(grep -v 'Running as user "root"' "$TMP/none.err")" -a "$(grep -c . "$TMP/none.txt")" = 0 ]
fi

finish
