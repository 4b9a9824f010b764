"""Runs the README's code blocks, and the ```sh blocks of every docs/*.md,
as a user pastes them (issues 27 and 33), so that an example cannot rot:
every ```sh line of a file in one bash session (a session per file; the
files in three queues side by side: REALTIME_FILES below), in a
scratch directory of its own whose `build` is this build tree, starting from
a PATH without `lec` (the README's own `export PATH=$PWD/build:$PATH` must
put it there; a doc's session starts with it, as the README leaves it); the
README's ```python block with the module built here.

What a user's machine has and a test's does not is substituted, nothing
else: /dev/ttyUSB0 is a twin on a pseudo-terminal (`lec sim --pty`, fast
timing, a workpiece at 350 mm, IDs 1-4; each session its own), /dev/ttyUSB1
(a second adapter on the pair) is that twin's tap, /tmp/lec* are in the
scratch directory, the daemon's ports 1502, 1503 and 8080 and the broker's
1883 are free ports (mosquitto_sub/pub get `-p`), /srv/lec6, /etc/lec6 and
/var/lib/lec6 are in the scratch directory, and the installed dissector
(/usr/share/lec6/wireshark) is the source tree's. Lines that install or
open a browser (make, pip, venv, xdg-open, sudo) are skipped and listed.

What a line puts in the background (`&`) runs there, and after a `lec sim`,
`lec serve` or `mosquitto` the next line waits for it to listen; a `lec
serve` line stops the `lec serve` started before it (a doc's serve lines are
alternatives: a user runs one of them). A line that runs until Ctrl-C (`lec
sniff` on a port, `lec watch` without --for, `curl -N`, `mosquitto_sub`)
ends with SIGINT after 3 s, as the user's Ctrl-C ends it; each block ends by
stopping what it started. Every other line must exit 0 (`lec replay`: 0 or
1, its report of a difference; `lec doctor`: up to 7, a line that works):
the first that does not fails the test, named with its file and line.

A doc's line may presume what the doc itself does not create (a running
`lec serve` for api.md's curl lines, a broker for mqtt.md): CONTEXT below
declares it, each with why, run before the line it serves and printed. A
line that cannot run here is in CANNOT_RUN with its reason, printed too;
no other line is left out.

Usage: readme.py README.md LEC_BUILD_DIR"""

import concurrent.futures
import glob
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import threading
import tempfile

SKIP = re.compile(r"^(make |xdg-open |/usr/bin/python3 -m venv |~/\.venvs/|\. ~/\.venvs/|sudo )")

SERVE = "lec serve --port sim --ids 1-4"
BROKER = "/usr/sbin/mosquitto -p $P3"  # not on a user's PATH
# A file's lines end within this (measured: the longest, docs/replay.md with
# its `watch --for 30s`, 43 s on 2 cores loaded by a full ctest): one that
# hangs fails its file and leaves the others time, inside ctest's TIMEOUT.
SESSION_S = 120
READY = "lec --port /dev/ttyUSB0 serial on && lec --port /dev/ttyUSB0 servo on && lec --port /dev/ttyUSB0 home"
# doc -> [(before, line, why)]: `line` runs (as a doc line would) before
# the doc's first line containing `before` (None: before all of them).
CONTEXT = {
    "api.md": [(None, SERVE, "every curl line asks a running lec serve (api.md's subject)"),
               ("@press.csv", "curl -s \"http://127.0.0.1:8080/api/axes/axis1/steps?format=csv\" > press.csv",
                "press.csv is a backup file the user has: this axis' own steps")],
    "cycles.md": [("lec teach cell.yaml", "cp \"$SRC/examples/cycles/pick-place.yaml\" cell.yaml",
                   "cell.yaml is the user's cycle file: the doc's example (examples/cycles/)"),
                  ("lec cycle run examples/", "ln -sfn \"$SRC/examples\" examples",
                   "the lines run from the repository's root, where examples/ is")],
    "doctor.md": [("tcp://127.0.0.1:1502", SERVE, "the last line goes through a running lec serve")],
    "history.md": [(None, "export LEC_DAEMON=http://127.0.0.1:8080",
                    "the daemon's HTTP API is on a free port, not 8080: the doc's own $LEC_DAEMON names it"),
                   ("lec history axis1 --kind", "lec serve --port sim --ids 1",
                    "lec history and lec health ask a running lec serve (the first block's, still running)")],
    "mqtt.md": [(None, BROKER, "a broker (the doc's mosquitto on 127.0.0.1:1883)"),
                (None, "lec serve --port sim --ids 1 --mqtt mqtt://127.0.0.1:1883",
                 "the bridge the doc is about, on line1/axis1 (the doc's config section, as flags)")],
    "replay.md": [(None, READY,
                   "move --to 150 needs an axis in serial mode, servo on and homed (the README's first steps)"),
                  ("--profile fitted.yaml", "lec sim --calibrate session.jsonl > fitted.yaml",
                   "fitted.yaml is made in the doc's Calibrate section, below the line that uses it")],
    "serve.md": [(None, BROKER, "the doc's config (/etc/lec6/lec6.yaml) has mqtt and sparkplug sections"),
                 (None, "mkdir -p /etc/lec6 && sed -n '/^```yaml/,/^```$/p' \"$SRC/docs/serve.md\" "
                  "| sed '1d;$d' | substitute > /etc/lec6/lec6.yaml && cp /etc/lec6/lec6.yaml lec6.yaml",
                  "/etc/lec6/lec6.yaml and lec6.yaml are the doc's own config example, substituted as a line is"),
                 ("lec --port tcp://127.0.0.1:1502 watch", SERVE,
                  "\"then, from anywhere\": the first block's lec serve, still running"),
                 ("lec --port tcp://127.0.0.1:1502 move", READY.replace("/dev/ttyUSB0", "tcp://127.0.0.1:1502"),
                  "move --to 150 needs axis 1 in serial mode, servo on and homed (the README's first steps)")],
    "sniff.md": [(None, "lec --port /dev/ttyUSB0 watch &",
                  "a master polls the pair, as on the user's line, so the sniffer has frames"),
                 ("-r line.pcap", "lec sniff --read line.jsonl --pcap line.pcap",
                  "line.pcap is the pcap of the doc's capture (`--pcap FILE`, described above it)")],
    "sparkplug.md": [(None, BROKER, "a broker on 127.0.0.1:1883, the one the line names")],
}
# (doc, the line's start) -> why it cannot run here.
CANNOT_RUN = {
    ("api.md", "curl -H \"Authorization: Bearer $TOKEN\""):
        "a daemon on another host (cell7) listening beyond loopback with a token: no such host here",
    ("history.md", "lec --port tcp://10.0.0.7:1502 health"):
        "finds the daemon's HTTP API at port 8080 of --port's host; the test's daemon listens on a free "
        "port (8080 may be taken), and $LEC_DAEMON, which names it, would answer the line instead",
}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def blocks(text, lang):
    """(first line number, [lines]) of each ```lang block."""
    out, cur, start = [], None, 0
    for n, line in enumerate(text.splitlines(), 1):
        if cur is None and line.strip() == f"```{lang}":
            cur, start = [], n + 1
        elif cur is not None and line.strip() == "```":
            out.append((start, cur))
            cur = None
        elif cur is not None:
            cur.append(line)
    return out


def joined(lines, start):
    """(line number, text) of each command: a line ending in `\\` goes on."""
    out, acc, first = [], None, 0
    for i, raw in enumerate(lines):
        if acc is None:
            acc, first = raw, start + i
        else:
            acc = acc[:-1].rstrip() + " " + raw.strip()
        if acc.rstrip().endswith("\\"):
            continue
        out.append((first, acc))
        acc = None
    if acc is not None:
        out.append((first, acc))
    return out


def substitute(line, env):
    """The line with the test's values, literal (a line may quote them)."""
    line = line.replace("/dev/ttyUSB0", env["TWIN"]).replace("/dev/ttyUSB1", env["TAP"])
    line = line.replace("/tmp/lec", env["WORK"] + "/lec")
    line = line.replace("127.0.0.1:8080", "127.0.0.1:" + env["P2"])
    line = line.replace("127.0.0.1:1883", "127.0.0.1:" + env["P3"])
    line = re.sub(r"\b1502\b", env["P1"], line)
    line = re.sub(r"\b1503\b", env["P4"], line)
    for path in ("/srv/lec6", "/etc/lec6", "/var/lib/lec6"):
        line = line.replace(path, env["WORK"] + path)
    line = line.replace("/usr/share/lec6/wireshark/", env["SRC"] + "/tools/wireshark/")
    line = line.replace("10.0.0.7:8081", "127.0.0.1:" + env["P2"])  # a daemon on another host: this one
    line = re.sub(r"^(mosquitto_(sub|pub)) ", r"\1 -p " + env["P3"] + " ", line)
    return line


LEC = r"^lec( --\S+( [^-]\S*)?)* "


def commands(label, n, raw, env, keep=False):
    """The shell lines for one line of a doc (or of its context)."""
    line = raw.split(" #")[0].rstrip()
    line = substitute(line, env)
    text = shlex.quote(raw.strip())
    out = [f"echo \"+ {label}:{n}: \"{text}"]
    # `a & b`: a runs in the background, b in the foreground; a line ending
    # in `&` is all background. A background daemon: the next line waits.
    parts = [p.strip() for p in line.split(" & ")]
    background = parts[:-1]
    last = parts[-1]
    # A daemon pasted without `&` runs until Ctrl-C: in the background here,
    # stopped at the block's end.
    if last.endswith("&") or re.match(r"^(lec (serve\b(?!.*--check)|sim\b.*--pty )|/usr/sbin/mosquitto )", last):
        background.append(last.rstrip(" &"))
        last = ""
    for part in background:
        daemon = re.match(r"^(lec (sim|serve)|/usr/sbin/mosquitto)\b", part)
        kind = daemon and (daemon.group(2) or "mosquitto")
        if kind == "serve":
            out.append("stop_serve")
            if "--config" not in part:
                part += " --modbus-tcp 127.0.0.1:$P1 --http 127.0.0.1:$P2"
        out.append(part + " >>\"$WORK/daemon.log\" 2>&1 &")
        if keep:  # a context's daemon serves the doc's later blocks too
            out.append("KEEP=\"$KEEP $!\"")
        if kind == "serve":
            out.append("SERVE=$!")
            out.append("wait_port $P2 || { cat \"$WORK/daemon.log\"; exit 1; }")
        elif kind == "sim":
            pty = re.search(r"--pty (\S+)", part).group(1)
            out.append(f"wait_file {pty} || exit 1")
        elif kind == "mosquitto":
            out.append("wait_port $P3 || { cat \"$WORK/daemon.log\"; exit 1; }")
    if not last:
        return out
    ok = "0"
    if re.match(LEC + r"?sniff\b(?!.*--read)", last) or re.match(LEC + r"?watch\b(?!.*--for)", last):
        # A listener runs until Ctrl-C: the user's Ctrl-C after 3 s (SIGINT;
        # lec then prints what it has and exits 0).
        last = f"timeout --preserve-status -s INT 3 {last}"
    elif re.match(r"^(curl -\S*N|mosquitto_sub)\b", last):
        # Another program's listener: ended by the Ctrl-C (timeout's 124).
        last = f"timeout -s INT 3 {last}"
        out.append(last)
        out.append(f"rc=$?; if [[ $rc -ne 124 ]]; then echo \"FAIL: {label}:{n} ended by itself "
                   f"($rc) before its Ctrl-C: \"{text}; exit 1; fi")
        return out
    # `lec replay` exits 1 when the replay differs from the capture (its
    # documented answer, a report); 2 and above are errors. `lec doctor`
    # exits 7 for a line that works, degraded (a loaded host delays a twin's
    # reply now and then), 8 for a broken one.
    # A broken verdict gets one more run: the twin shares the host with the
    # other tests, and a -j2 ctest beside it (a pip install compiling) once
    # delayed 39 of its 46 burst replies past their windows (CI, stop 40); a
    # user's idle machine never does, and a real fault fails both runs.
    out.append(last)
    if re.match(LEC + r"?replay\b", last):
        ok = "1"
    elif re.match(LEC + r"?doctor\b", last):
        ok = "7"
        out.append(f"rc=$?; if [[ $rc -eq 8 ]]; then echo \"(broken once: a loaded host? once "
                   f"more)\"; {last}; else (exit $rc); fi")
    out.append(f"rc=$?; if [[ $rc -gt {ok} ]]; then echo \"FAIL: {label}:{n} exited "
               f"$rc: \"{text}; exit 1; fi")
    return out


def shell_script(label, file_blocks, env, doc=None):
    out = ["set -uo pipefail", "cd \"$WORK\"",
           "wait_file() { for _ in $(seq 300); do [[ -e $1 ]] && return 0; sleep 0.1; done; "
           "echo \"FAIL: $1 never appeared\"; return 1; }",
           "wait_port() { for _ in $(seq 300); do (exec 3<>/dev/tcp/127.0.0.1/$1) 2>/dev/null "
           "&& return 0; sleep 0.1; done; echo \"FAIL: nothing listens on $1\"; return 1; }",
           # A file's text substituted as a line is (substitute() below).
           "substitute() { sed -e \"s|/dev/ttyUSB0|$TWIN|g; s|/dev/ttyUSB1|$TAP|g; s|/tmp/lec|$WORK/lec|g; "
           "s|127.0.0.1:8080|127.0.0.1:$P2|g; s|127.0.0.1:1883|127.0.0.1:$P3|g; s|\\b1502\\b|$P1|g; "
           "s|\\b1503\\b|$P4|g; s|/srv/lec6|$WORK/srv/lec6|g; s|/etc/lec6|$WORK/etc/lec6|g; "
           "s|/var/lib/lec6|$WORK/var/lib/lec6|g\"; }",
           "SERVE=",
           "stop_serve() { if [[ -n $SERVE ]]; then kill $SERVE; wait $SERVE 2>/dev/null; SERVE=; fi; true; }",
           "KEEP=",
           "stop_jobs() { local j; for j in $(jobs -p); do [[ \" $KEEP \" == *\" $j \"* ]] && continue; "
           "kill $j; wait $j 2>/dev/null; [[ $j == \"$SERVE\" ]] && SERVE=; done; true; }"]
    if doc is not None:
        out.append("export PATH=$WORK/build:$PATH  # as the README leaves it")
    skipped, notes = [], []
    context = list(CONTEXT.get(doc, []))
    for start, lines in file_blocks:
        for n, raw in joined(lines, start):
            if raw.lstrip().startswith("#") or not raw.split(" #")[0].strip():
                continue
            line = raw.split(" #")[0].rstrip()
            for c in [c for c in context if c[0] is None or c[0] in line]:
                context.remove(c)
                notes.append(f"{label}:{n}: context: {c[1]}  ({c[2]})")
                out += commands(f"{label} context", n, c[1], env, keep=True)
            if SKIP.match(line):
                skipped.append(f"{label}:{n}: {line}")
                continue
            why = [w for (d, s), w in CANNOT_RUN.items() if d == doc and line.startswith(s)]
            if why:
                notes.append(f"{label}:{n}: NOT RUN: {line}  ({why[0]})")
                continue
            out += commands(label, n, raw, env)
        out.append("stop_jobs")
    out.append("KEEP=; stop_jobs")
    if context:
        raise SystemExit(f"{label}: context never placed (no line holds its anchor): {context}")
    out.append(f"echo \"all {label} shell lines passed\"")
    return "\n".join(out) + "\n", skipped, notes


def run_session(label, file_blocks, build, src, doc, out, prio):
    """One file's ```sh lines in one bash session with a twin of its own,
    their output (and ours) into `out`, every process run as `prio` says."""
    with tempfile.TemporaryDirectory() as work:
        os.symlink(build, os.path.join(work, "build"))
        env = {"PATH": "/usr/local/bin:/usr/bin:/bin", "HOME": work, "WORK": work, "SRC": src,
               "TWIN": os.path.join(work, "tty"), "TAP": os.path.join(work, "tap"),
               "P1": str(free_port()), "P2": str(free_port()), "P3": str(free_port()),
               "P4": str(free_port()), "LANG": "C.UTF-8"}
        twin = subprocess.Popen(prio + [os.path.join(build, "lec"), "sim", "--pty", env["TWIN"],
                                 "--ids", "1-4", "--workpiece", "350", "--timing", "fast",
                                 "--tap", env["TAP"]],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(300):
                if os.path.exists(env["TWIN"]):
                    break
                subprocess.run(["sleep", "0.1"])
            script, skipped, notes = shell_script(label, file_blocks, env, doc)
            with open(os.path.join(work, "lines.sh"), "w") as f:
                f.write(script)
            if skipped:
                print("skipped (install or browser):\n  " + "\n  ".join(skipped), file=out, flush=True)
            if notes:
                print("declared context and lines not run:\n  " + "\n  ".join(notes), file=out, flush=True)
            # Its own process group: a line that hangs (the timeout) must not
            # leave the daemons it started running.
            sh = subprocess.Popen(prio + ["bash", os.path.join(work, "lines.sh")], env=env, cwd=work,
                                  start_new_session=True, stdout=out, stderr=subprocess.STDOUT)
            try:
                rc = sh.wait(timeout=SESSION_S)
            except subprocess.TimeoutExpired:
                print(f"\nFAIL: {label}'s shell lines did not end within {SESSION_S} s: the last "
                      "line shown above never ended", file=out, flush=True)
                rc = 1
            finally:
                try:
                    os.killpg(sh.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
                sh.wait()
            return rc, env
        finally:
            twin.terminate()
            twin.wait(10)


def python_blocks(text, build, out):
    """The README's python block, with the module of this build."""
    if not glob.glob(os.path.join(build, "python", "lec6", "_lec6*.so")):
        print("python block skipped: no module in this build tree", file=out)
        return 0
    with tempfile.TemporaryDirectory() as work:
        twin_path = os.path.join(work, "tty")
        twin = subprocess.Popen([os.path.join(build, "lec"), "sim", "--pty", twin_path,
                                 "--ids", "1-4", "--workpiece", "350", "--timing", "fast"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(300):
                if os.path.exists(twin_path):
                    break
                subprocess.run(["sleep", "0.1"])
            for start, lines in blocks(text, "python"):
                code = "\n".join(lines).replace('"/dev/ttyUSB0"', repr(twin_path))
                r = subprocess.run(["/usr/bin/python3", "-c", code], cwd=work, timeout=120,
                                   env={"PATH": "/usr/local/bin:/usr/bin:/bin", "HOME": work,
                                        "LANG": "C.UTF-8", "PYTHONPATH": os.path.join(build, "python")},
                                   capture_output=True, text=True)
                print(r.stdout, r.stderr, sep="", end="", file=out)
                if r.returncode != 0:
                    print(f"FAIL: the python block at README:{start} exited {r.returncode}", file=out)
                    return 1
        finally:
            twin.terminate()
            twin.wait(10)
    print("the README's python block passed", file=out)
    return 0


# Three queues of files, run side by side (issue 36: one after the other they
# took 130 s, most of it waiting on twins, `lec watch --for 30s` and timeouts,
# with 20 s of CPU; side by side ~60 s). The real-time one (ctest runs this test at SCHED_FIFO
# where it can: tests/CMakeLists.txt) holds docs/doctor.md, whose lec doctor
# calls a twin that misses its windows broken, and the README, whose lines a
# loaded host once starved (a move: no reply). The other files' processes run
# at normal priority: beside spinning real-time twins of the same priority a
# second real-time queue could starve the first. docs/replay.md, the longest
# (its `lec watch --for 30s`), has a queue of its own.
REALTIME_FILES = ("docs/doctor.md", "README")
LONG_FILES = ("docs/replay.md",)
NORMAL = ["chrt", "--other", "0"]


PRINTING = threading.Lock()


class Output:
    """A file's output, ours and its lines', in a file opened to append
    (O_APPEND: what we print after a line's output never overwrites it)."""

    def __enter__(self):
        self.dir = tempfile.TemporaryDirectory()
        self.path = os.path.join(self.dir.name, "output")
        self.file = open(self.path, "a+")
        return self.file

    def __exit__(self, *exc):
        self.file.close()
        self.dir.cleanup()


def show(label, rc, out, results):
    """Prints a file's whole output as it ends (a timeout still shows it)."""
    out.flush()
    with PRINTING, open(out.name) as f:
        sys.stdout.write(f.read())
        sys.stdout.flush()
    results.append((label, rc))


def run_queue(files, build, src, prio, python_text=None):
    """Runs `files` one after the other; returns [(label, rc)]."""
    results = []
    for label, path, doc in files:
        with Output() as out:
            print(f"== {label}", file=out, flush=True)
            try:
                rc, _ = run_session(label, blocks(open(path).read(), "sh"), build, src, doc, out,
                                    prio)
            except BaseException as e:  # noqa: BLE001 -- a file's setup that failed fails it, shown
                print(f"FAIL: {label}: the test's own setup failed: {e!r}", file=out, flush=True)
                rc = 1
            show(label, rc, out, results)
    if python_text is not None:
        with Output() as out:
            print("== README (python)", file=out, flush=True)
            rc = python_blocks(python_text, build, out)
            show("README (python)", rc, out, results)
    return results


def main():
    readme, build = sys.argv[1], os.path.abspath(sys.argv[2])
    src = os.path.dirname(os.path.abspath(readme))
    text = open(readme).read()
    only = os.environ.get("LEC6_README_ONLY")  # one file's session (e.g. docs/api.md), to debug
    files = [("README", readme, None)] + [
        (f"docs/{os.path.basename(p)}", p, os.path.basename(p))
        for p in sorted(glob.glob(os.path.join(src, "docs", "*.md")))]
    files = [f for f in files if (not only or only == f[0]) and blocks(open(f[1]).read(), "sh")]
    python_text = text if not only or only == "README" else None
    realtime = [f for f in files if f[0] in REALTIME_FILES]
    realtime.sort(key=lambda f: REALTIME_FILES.index(f[0]))
    long = [f for f in files if f[0] in LONG_FILES]
    other = [f for f in files if f[0] not in REALTIME_FILES + LONG_FILES]
    with concurrent.futures.ThreadPoolExecutor(3) as pool:
        queues = [pool.submit(run_queue, realtime, build, src, [], python_text),
                  pool.submit(run_queue, long, build, src, NORMAL),
                  pool.submit(run_queue, other, build, src, NORMAL)]
        results = [r for q in queues for r in q.result()]
    failed = [label for label, rc in results if rc != 0]
    if failed:
        print("FAIL: " + ", ".join(failed))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
