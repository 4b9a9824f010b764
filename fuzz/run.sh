#!/usr/bin/env bash
# Runs each libFuzzer harness for a while, one at a time (the machine's cores
# are shared), and prints execs/s and coverage for each.
#
#   fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]     (default: all of them)
#
# Corpus: BUILD_DIR/fuzz/corpus/<h> (grows), seeded from BUILD_DIR/fuzz/seeds/<h>
# (golden frames) and tests/fuzz_regressions/<h> (past findings).
# A finding is written to BUILD_DIR/fuzz/artifacts/<h>/ and the script fails:
# copy the input to tests/fuzz_regressions/<h>/ so the regression test keeps it.
set -uo pipefail

build=${1:?usage: fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]}
seconds=${2:?usage: fuzz/run.sh BUILD_DIR SECONDS [HARNESS...]}
shift 2
harnesses=("$@")
((${#harnesses[@]})) || harnesses=(reply request twin steps sniff http mbap)
src=$(cd "$(dirname "$0")/.." && pwd)

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

status=0
summary=()
for h in "${harnesses[@]}"; do
  bin=$build/fuzz/fuzz_$h
  [[ -x $bin ]] || { echo "fuzz/run.sh: $bin is not built" >&2; exit 2; }
  corpus=$build/fuzz/corpus/$h
  artifacts=$build/fuzz/artifacts/$h
  log=$build/fuzz/fuzz_$h.log
  mkdir -p "$corpus" "$artifacts" "$src/tests/fuzz_regressions/$h"
  dict=()
  [[ -f $src/fuzz/$h.dict ]] && dict=(-dict="$src/fuzz/$h.dict")
  echo "== fuzz_$h for ${seconds}s (log: $log)"
  "$bin" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=1024 -print_final_stats=1 \
    "${dict[@]}" -artifact_prefix="$artifacts/" \
    "$corpus" "$build/fuzz/seeds/$h" "$src/tests/fuzz_regressions/$h" >"$log" 2>&1
  rc=$?
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  eps=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9a-zA-Z]*\).*/\1/p' <<<"$last")
  if ((rc != 0)); then
    status=1
    summary+=("$(printf '%-8s FINDING (exit %s) after %s runs: see %s and %s' "$h" "$rc" "${runs:-?}" "$log" "$artifacts")")
    grep -E 'ERROR|property violated|SUMMARY|runtime error' "$log" | head -5 >&2
  else
    summary+=("$(printf '%-8s %8ss %12s runs %8s exec/s  cov %6s  ft %6s  corpus %s' "$h" "$seconds" \
      "${runs:-?}" "${eps:-?}" "${cov:-?}" "${ft:-?}" "${corp:-?}")")
  fi
done
echo
echo "harness  duration         runs     exec/s  coverage (edges, features), corpus"
printf '%s\n' "${summary[@]}"
exit $status
