#!/usr/bin/env bash
# The client's cost per transaction, counted, not timed (wall time on a shared
# machine swings ±20 %; BENCHMARKS.md, "Fast mode"): `lec bench` reads D9000
# x7 from a `lec sim --timing fast` twin on a pty, once with N1 and once with
# N2 transactions; the difference over N2 - N1 is what one transaction costs,
# without the program's start and the port's opening:
#  - instructions (valgrind's cachegrind counts every instruction `lec` runs
#    in user space): at most MAX_INSTR per transaction;
#  - system calls (strace -c counts them): at most MAX_SYSCALLS.
# It fails when a change makes the read path do more work or more calls than
# the budget (the figures it measured are in its output and BENCHMARKS.md).
# Not under the sanitizers (valgrind cannot run an ASan binary, and their
# counts are not the shipped code's): there it reports a skip.
# Needs: LEC, valgrind, strace.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --program valgrind --program strace

if [[ -n ${LEC6_SANITIZED:-} ]]; then
  echo "skipped: the sanitizer tree's lec cannot run under valgrind"
  exit 77
fi

N1=100
N2=600
# Budgets: what the optimised tree measured on 2026-11-27 (3 020 instructions,
# 4.00 system calls: a look at the line, the query's write, the wait, the
# reply's read) plus headroom for a compiler or library update; one more
# system call per transaction fails. The instruction budget holds for an
# optimised build only (LEC6_CXX_FLAGS from CMake: -O2 or -O3); an -O0 tree
# spends ten times as many and checks only the system calls.
MAX_INSTR=${LEC6_MAX_INSTR_PER_TX:-4000}
MAX_SYSCALLS=${LEC6_MAX_SYSCALLS_PER_TX:-4.5}
optimised() { [[ " ${LEC6_CXX_FLAGS:-} " =~ \ -O[23s]\  ]]; }

PORT=$TMP/cost
start_twin cost --pty "$PORT" --timing fast --ids 1 || { finish; exit 1; }
# --reply-spin 0: the spin's looks for a reply are timing, not the read path's work
# (they count as many calls as the reply takes microseconds).
BENCH=("$LEC" --port "$PORT" --baud 38400 --no-silence-wait --reply-spin 0 --json bench --op read-state)

# instructions N: the instructions `lec bench -n N` ran (cachegrind, no cache simulation).
instructions() {
  local out=$TMP/cg.$1
  timeout 120 valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file=/dev/null \
    "${BENCH[@]}" -n "$1" >"$out.json" 2>"$out.err" || { cat "$out.err" >&2; return 1; }
  # "==123== I   refs:      4,118,377"
  sed -n 's/.*I *refs: *//p' "$out.err" | tr -d ','
}
# syscalls N: the system calls `lec bench -n N` made (strace -c's total).
syscalls() {
  local out=$TMP/st.$1
  timeout 120 strace -f -c -o "$out.txt" "${BENCH[@]}" -n "$1" >"$out.json" 2>"$out.err" ||
    { cat "$out.err" >&2; return 1; }
  awk '$NF == "total" { print ($4 ~ /^[0-9]+$/) ? $4 : $3 }' "$out.txt"
}

i1=$(instructions $N1) && i2=$(instructions $N2)
check "cachegrind counted both runs ($i1, $i2)" test -n "$i1" -a -n "$i2"
per_instr=$(((i2 - i1) / (N2 - N1)))
echo "    instructions per transaction: $per_instr (budget $MAX_INSTR; compiled with: ${LEC6_CXX_FLAGS:-?})"
if optimised; then
  check "at most $MAX_INSTR instructions per transaction ($per_instr)" test "$per_instr" -le "$MAX_INSTR"
else
  echo "    (not an optimised build: the instruction budget is not judged)"
fi

s1=$(syscalls $N1) && s2=$(syscalls $N2)
check "strace counted both runs ($s1, $s2)" test -n "$s1" -a -n "$s2"
per_call=$(awk -v a="$s1" -v b="$s2" -v n=$((N2 - N1)) 'BEGIN { printf "%.2f", (b - a) / n }')
echo "    system calls per transaction: $per_call (budget $MAX_SYSCALLS)"
sed 's/^/    /' "$TMP/st.$N2.txt" | head -20
check "at most $MAX_SYSCALLS system calls per transaction ($per_call)" \
  awk -v v="$per_call" -v m="$MAX_SYSCALLS" 'BEGIN { exit !(v <= m) }'
finish
