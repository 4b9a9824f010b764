#!/usr/bin/env bash
# Machine cycles (issue 34, docs/cycles.md): examples/cycles/pick-place.yaml
# checked, run on the in-process twin in simulated time (with --json and
# --junit), refused when bad (exit 2, file:line:column: field: rule, before
# any port is opened), run unchanged on a twin behind a real pseudo-terminal
# in real time (its push misses there: the no_part branch), and stopped by
# Ctrl-C during a parallel group (exit 130, where each axis stood); where its
# time went and its HTML report; faults acted out by the twin; through lec
# serve beside a SCADA poller, and stopped there by a stop over HTTP.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/lib.sh"
example="$here/../../examples/cycles/pick-place.yaml"
lec() { "$LEC" "$@"; }

# --- the example, checked and run on the twin in simulated time ------------
expect_exit 0 check -- lec cycle check "$example"
contains check "cycle 'pick-place' is valid: 2 axes, 13 steps, 1 branches, 1 interlocks"
expect_exit 0 check_json -- lec --json cycle check "$example"
[[ $(json 'd["valid"], d["axes"], d["steps"], d["interlocks"]') == "(True, 2, 13, 1)" ]] && ok || bad "check json: $out"

start=${EPOCHREALTIME/./}
expect_exit 0 run_sim -- lec cycle run "$example" --port sim --junit "$tmp/junit.xml"
wall_ms=$(((${EPOCHREALTIME/./} - start) / 1000))
contains run_sim "step 6 (2/2)  push z to nest (70.00 mm)"
contains run_sim "pushed: workpiece at 78.00 mm"
contains run_sim "simulated time on the twin), 2 passes"
# ~13 s of machine time in well under its real duration.
cycle_s=$(sed -n 's/^cycle completed in \([0-9.]*\) s.*/\1/p' <<<"$out")
if [[ -n $cycle_s ]] && /usr/bin/python3 -c "import sys; sys.exit(0 if 10 < $cycle_s < 20 and $wall_ms < 5000 else 1)"; then
  ok
else
  bad "simulated time: cycle ${cycle_s:-?} s in ${wall_ms} ms of wall time"
fi
if grep -q 'tests="3" failures="0"' "$tmp/junit.xml"; then ok; else bad "junit: $(cat "$tmp/junit.xml")"; fi

expect_exit 0 json -- lec --json cycle run "$example" --port sim
[[ $(json 'd["completed"], d["passes"], len(d["steps"]), d["steps"][5]["axes"][0]["outcome"]') == "(True, 2, 16, 'pushed')" ]] && ok || bad "json: $out"
# Where the time went (cycle::analyse): the critical path tiles the cycle
# time, the line's utilisation is a fraction, the group's start skew under
# 25 ms; the HTML report draws one bar per activity and outlines the path.
[[ $(json 'round(d["analysis"]["motion_s"] + d["analysis"]["line_s"] + d["analysis"]["program_s"] - d["cycle_time_s"], 6), d["analysis"]["critical_path"][-1]["to_s"] == d["cycle_time_s"], 0 < d["analysis"]["lines"][0]["utilisation"] < 1, d["analysis"]["max_start_skew_s"] < 0.025') == "(0.0, True, True, True)" ]] && ok || bad "analysis: $(json 'd["analysis"]')"
bars=$(json 'sum(len(s["axes"]) for s in d["steps"])')
expect_exit 0 report -- lec cycle run "$example" --port sim --report "$tmp/cycle.html"
contains report "where the time went: motion "
contains report "line in-process twin"
[[ $(grep -c '<rect class="bar ' "$tmp/cycle.html") -eq $bars ]] && ok || bad "report: $(grep -c '<rect class="bar ' "$tmp/cycle.html") bars, $bars activities"
grep -q '<rect class="bar ok critical"' "$tmp/cycle.html" && grep -q 'id="gantt"' "$tmp/cycle.html" && ok || bad "report: no critical path in the Gantt chart"
# A report that cannot be written is refused before anything moves.
expect_exit 2 report_dir -- lec cycle run "$example" --port sim --report "$tmp/no/such/dir/r.html"
contains report_dir "--report $tmp/no/such/dir/r.html: cannot create a file there: No such file or directory"
expect_exit 2 report_is_dir -- lec cycle run "$example" --port sim --report "$tmp" --junit "$tmp/j.xml"
contains report_is_dir "--report $tmp: a directory; give a file name"
expect_exit 2 report_is_cycle -- lec cycle run "$example" --port sim --report "$example"
contains report_is_cycle "that is the file this command reads"
expect_exit 2 report_twice -- lec cycle run "$example" --port sim --report "$tmp/same.out" --junit "$tmp/./same.out"
contains report_twice "--junit $tmp/./same.out: also given to --report: each report needs its own file"
[[ ! -e $tmp/j.xml && ! -e $tmp/same.out ]] && ok || bad "a refused report path left a file"
# Symlinks: one to the other report (dangling yet) is the same file; one to a
# device is refused, and the device stays; one to a file keeps the link.
ln -s r1.html "$tmp/j1.xml"
expect_exit 2 report_link_twice -- lec cycle run "$example" --port sim --report "$tmp/r1.html" --junit "$tmp/j1.xml"
contains report_link_twice "also given to --report: each report needs its own file"
ln -s /dev/null "$tmp/devnull.html"
expect_exit 2 report_to_device -- lec cycle run "$example" --port sim --report "$tmp/devnull.html"
contains report_to_device "/dev/null is not a regular file"
[[ -c /dev/null && -L $tmp/devnull.html && ! -e $tmp/r1.html ]] && ok || bad "a refused link changed a file"
mkdir -p "$tmp/reports" && ln -s reports/latest.html "$tmp/latest.html"
expect_exit 0 report_link -- lec cycle run "$example" --port sim --report "$tmp/latest.html"
[[ -L $tmp/latest.html && -s $tmp/reports/latest.html ]] && ok || bad "--report through a link: $(ls -l "$tmp" "$tmp/reports")"

# The same on a field profile's twin (a calibrated twin: lec sim --calibrate).
expect_exit 0 profile -- lec cycle run "$example" --port sim --profile "$here/../../profiles/field-quirks.yaml"
contains profile "in-process twin @ 38400, profile field-quirks"
contains profile "cycle completed in"
expect_exit 2 profile_not_sim -- lec cycle run "$example" --port /dev/nonexistent --profile "$here/../../profiles/field-quirks.yaml"
contains profile_not_sim "--profile sets up the twin: it goes with --port sim"

# A cycle time over the limit fails the run and its JUnit case.
expect_exit 1 too_slow -- lec cycle run "$example" --port sim --max-cycle-time 5s --junit "$tmp/slow.xml"
if grep -q 'failures="1"' "$tmp/slow.xml" && grep -q 'the cycle took' "$tmp/slow.xml"; then ok; else bad "slow junit: $(cat "$tmp/slow.xml")"; fi

# The three-axis example: every part picked and placed, the three axes of
# its first group started within two start transactions.
expect_exit 0 gantry -- lec --json cycle run "$here/../../examples/cycles/gantry-3-axis.yaml" --port sim
[[ $(json 'd["completed"], d["passes"], sum(1 for s in d["steps"] for a in s["axes"] if a["outcome"] == "pushed"), len(d["analysis"]["axes"]), d["analysis"]["max_start_skew_s"] < 0.045') == "(True, 3, 3, 3, True)" ]] && ok || bad "gantry: $out"

# --- faults acted out by the twin: each failure branch runs before the machine exists
# The 1st part is missing: its push misses and no_part runs; the workpiece
# is back once z has lifted, so the 2nd part is pushed.
expect_exit 0 fault_miss -- lec cycle run "$example" --port sim --fault '{step: 6, push_miss: z}'
contains fault_miss "fault at step 6 (1/2): z's push at step 6 finds no workpiece (injected)"
contains fault_miss "step no_part.1  move z to up"
[[ $(grep -c "branch no_part" <<<"$out") -eq 1 && $(grep -c "pushed: workpiece at 78.00 mm" <<<"$out") -eq 1 ]] &&
  ok || bad "fault_miss: one miss, then the 2nd part pushed: $out"
# (--fault before FILE: one value per --fault, the file stays the file)
expect_exit 1 fault_alarm -- lec cycle run --fault '{step: 2, alarm: z}' "$example" --port sim
contains fault_alarm "fault at step 2 (1/2): alarm 149 on z at step 2 (injected)"
contains fault_alarm "aborted at step 2 (1/2)"
contains fault_alarm "where each axis stood:"
set +e
out=$(lec --json cycle run "$example" --port sim --fault '{step: 5, cut_off: x}' 2>"$tmp/cut.err")
code=$?
set -e
[[ $code -eq 1 ]] && ok || bad "fault_cut: exit $code: $(cat "$tmp/cut.err")"
[[ $(json '"line fault during step 5 (1/2)" in d["ended"], [s["stopped"] for s in d["stood"]], [(f["step"], f["fault"], f["injected"]) for f in d["faults"]], d["stood"][0]["position_mm"], [a["outcome"] for a in d["steps"][-1]["axes"]]') == "(True, [False, True], [('5 (1/2)', 'x cut off the line at step 5', True)], None, ['line_fault', 'line_fault'])" ]] && ok || bad "fault_cut: $out"
expect_exit 2 fault_line -- lec cycle run "$example" --port /dev/nonexistent --fault '{step: 5, cut_off: x}'
contains fault_line "--fault makes the twin act out a fault: it goes with --port sim"
expect_exit 2 fault_bad -- lec cycle run "$example" --port sim --fault '{step: 6, push_miss: x}'
contains fault_bad "fault.push_miss: step 6 (push z to nest (70.00 mm)) has no push of x: a push_miss needs one"

# A re-press that misses: the part goes back only once z has left the side it
# pushed past, so the move up does not run into it (alarm 149).
cat >"$tmp/repress.yaml" <<'YAML'
axes:
  z: {id: 1, points: {up: 5, nest: 70}, twin: {workpiece_mm: 78}}
steps:
  - push: {axis: z, to: nest, force: 50, trigger: 40, push_speed: 20, distance: 15}
  - push: {axis: z, to: 78, force: 60, trigger: 40, distance: 10, on: {push_missed: continue}}
  - move: {axis: z, to: up, timeout: 5s}
  - push: {axis: z, to: nest, force: 50, trigger: 40, push_speed: 20, distance: 15}
YAML
expect_exit 0 repress -- lec --json cycle run "$tmp/repress.yaml" --port sim --fault '{step: 2, push_miss: z}'
[[ $(json '[a["outcome"] for s in d["steps"] for a in s["axes"]]') == "['pushed', 'push_missed', 'reached', 'pushed']" ]] && ok || bad "repress: $out"

# --- bad files: exit 2, the place and the rule, no port opened --------------
sed 's/axis: z, to: nest/axis: y, to: nest/' "$example" >"$tmp/bad-axis.yaml"
expect_exit 2 bad_axis -- lec cycle run "$tmp/bad-axis.yaml" --port /dev/nonexistent
contains bad_axis "bad-axis.yaml:38:18: steps[5].push.axis: unknown axis 'y' (axes: x, z)"
sed 's/- move: {axis: z, to: up}$/- move: {axis: x, to: 10}/' "$example" >"$tmp/twice.yaml"
expect_exit 2 twice -- lec cycle check "$tmp/twice.yaml"
contains twice "steps[0].parallel[1]: axis x is moved twice in this parallel group (also by steps[0].parallel[0])"
sed 's/to: place, speed: 400/to: 450, speed: 400/' "$example" >"$tmp/limits.yaml"
expect_exit 2 limits -- lec cycle check "$tmp/limits.yaml"
contains limits "steps[4].parallel[0].move.to: 450.00 mm is outside axis x's soft limits 0.00 to 400.00 mm"

# --- the same file on a line: a twin behind a pty, real time ---------------
start_twin line --ids 1,2
expect_exit 0 run_line -- lec cycle run "$example" --port "$tmp/line" --prepare
contains run_line "push_missed"               # no part in this twin
contains run_line "branch no_part"
contains run_line "step no_part.1  move z to up"
contains run_line "real time), 2 passes"
contains run_line "exchanges, busy "            # the line's utilisation, from the wire times

# stopped_run NAME PID CODE: the background cycle PID (its output in
# $tmp/NAME.out, then in $out) ends with exit CODE, saying where each axis
# stood: both at rest.
stopped_run() {
  local name=$1 pid=$2 want=$3 code
  set +e
  wait "$pid"
  code=$?
  set -e
  out=$(cat "$tmp/$name.out")
  [[ $code -eq $want ]] && ok || bad "$name: exit $code, expected $want: $out"
  contains "$name" "where each axis stood:"
  [[ $(grep -cE '^  (x|z) +[0-9.]+ mm  stopped at' <<<"$out") -eq 2 ]] && ok || bad "$name: two axes at rest: $out"
}

# --- Ctrl-C during the parallel group of step 5: every axis stops ----------
"$LEC" cycle run "$example" --port "$tmp/line" --prepare >"$tmp/stop.out" 2>&1 &
run_pid=$!
step4_ended() { grep -q "^step 4 (1/2)" "$tmp/stop.out"; }
wait_for 30 "step 4 to end" -- step4_ended || true
kill -INT "$run_pid"
stopped_run stop "$run_pid" 130
contains stop "stopped by request"

# --- teach-in: where x stopped becomes a point, the file otherwise kept -------
cp "$example" "$tmp/cell.yaml"
expect_exit 0 teach -- lec --json teach "$tmp/cell.yaml" x.stopped --port "$tmp/line"
taught=$(json 'd["position_mm"]')
expect_exit 0 status -- lec --json --port "$tmp/line" --id 1 status
stood=$(json 'd["position_mm"]')
[[ $taught == "$stood" ]] && ok || bad "teach wrote $taught mm, x stands at $stood mm"
diff "$example" "$tmp/cell.yaml" >"$tmp/teach.diff" || true
[[ $(grep -c '^[<>]' "$tmp/teach.diff") -eq 2 ]] && grep -q "place: 350, stopped: " "$tmp/teach.diff" &&
  ok || bad "teach changed more than the points line: $(cat "$tmp/teach.diff")"
expect_exit 0 teach_check -- lec cycle check "$tmp/cell.yaml"
cp "$tmp/cell.yaml" "$tmp/cell.before"
expect_exit 2 teach_limits -- lec cycle teach "$tmp/cell.yaml" x.pick --at 401
contains teach_limits "outside the axis's soft limits 0.00 to 400.00 mm; nothing written"
cmp -s "$tmp/cell.yaml" "$tmp/cell.before" && ok || bad "a refused teach changed the file"

# --- through lec serve: the cycle shares the line with a SCADA poller -------
# `--port tcp://` to lec serve's Modbus TCP (unit id = controller ID); mbpoll
# reads both axes all the while. A stop posted over HTTP during a parallel
# group stops that axis; the cycle sees it stopped, ends, and stops every
# axis, saying where each stood.
need --program mbpoll --program curl
start_twin served --ids 1,2
"$LEC" serve --port "$tmp/served" --ids 1,2 --modbus-tcp 127.0.0.1:0 --http 127.0.0.1:0 \
  >"$tmp/serve.out" 2>"$tmp/serve.err" &
twin_pids+=($!)
serve_ready() { grep -q "ready on" "$tmp/serve.out"; }
wait_for 20 "lec serve's ready line" -- serve_ready || bad "lec serve did not start: $(cat "$tmp/serve.err")"
mb=$(grep -o 'tcp://127.0.0.1:[0-9]*' "$tmp/serve.out" | head -1 || true)
http=$(grep -o 'http://[0-9.:]*' "$tmp/serve.out" | head -1 || true)
# One poll of both axes every 0.1 s; each answered poll leaves a line. A
# poll that fails (a timeout behind a busy daemon) is no reason to stop.
( while :; do
  if mbpoll -m tcp -a 1:2 -p "${mb##*:}" -t 4 -r 36864 -c 7 -0 -1 127.0.0.1 >/dev/null 2>&1; then echo ok; fi
  sleep 0.1
done ) >"$tmp/scada.log" 2>&1 &
scada_pid=$!
twin_pids+=("$scada_pid")
cat >"$tmp/served.yaml" <<'YAML'
cycle: served
axes:
  x: {id: 1, soft_limits: [0, 400]}
  z: {id: 2}
steps:
  - parallel:
      - move: {axis: x, to: 40, speed: 300}
      - move: {axis: z, to: 20, speed: 300}
  - parallel:
      - move: {axis: x, to: 300, speed: SPEED}
      - move: {axis: z, to: 300, speed: SPEED}
  - move: {axis: x, to: 10, speed: 400}
YAML
sed 's/SPEED/300/' "$tmp/served.yaml" >"$tmp/served-fast.yaml"
sed 's/SPEED/40/' "$tmp/served.yaml" >"$tmp/served-slow.yaml"
expect_exit 0 via_serve -- lec cycle run "$tmp/served-fast.yaml" --port "$mb" --prepare
contains via_serve "cycle completed in"
contains via_serve "exchanges, busy not known (no wire times)" # Modbus TCP: the wire is lec serve's
"$LEC" cycle run "$tmp/served-slow.yaml" --port "$mb" --prepare >"$tmp/sstop.out" 2>&1 &
run_pid=$!
x_on_its_way() {
  curl -s "$http/api/axes/axis1" | /usr/bin/python3 -c 'import json,sys; d=json.load(sys.stdin); sys.exit(0 if d["position_mm"] > 80 else 1)'
}
wait_for 30 "x past 80 mm in step 2" -- x_on_its_way || bad "x never got past 80 mm: $(cat "$tmp/sstop.out")"
code=$(curl -s -o "$tmp/stop.json" -w '%{http_code}' -XPOST "$http/api/axes/axis1/stop" || true)
[[ $code == 200 ]] && ok || bad "HTTP stop: $code $(cat "$tmp/stop.json")"
stopped_run sstop "$run_pid" 1
contains sstop "aborted at step 2"
z_at=$(sed -n 's/^  z \+\([0-9.]*\) mm  stopped at.*/\1/p' <<<"$out")
[[ -n $z_at ]] && /usr/bin/python3 -c "import sys; sys.exit(0 if float('$z_at') < 295 else 1)" && ok ||
  bad "z went on to its target (300 mm) after the stop: $out"
# The SCADA client polled all along, and still does.
[[ $(grep -c ok "$tmp/scada.log") -ge 5 ]] && kill -0 "$scada_pid" 2>/dev/null && ok ||
  bad "the SCADA poller: $(grep -c ok "$tmp/scada.log") answered polls"

finish
