"""Runs the README's code blocks as a user pastes them (issue 27), so that an
example cannot rot: every ```sh line in one bash session, in a scratch
directory whose `build` is this build tree, starting from a PATH without
`lec` (the README's own `export PATH=$PWD/build:$PATH` must put it there);
the ```python block with the module built here.

What a user's machine has and a test's does not is substituted, nothing
else: /dev/ttyUSB0 is a twin on a pseudo-terminal (`lec sim --pty`, fast
timing, a workpiece at 350 mm, IDs 1-4), /dev/ttyUSB1 (a second adapter
on the pair) is that twin's tap, /tmp/lec0 is in the scratch directory, and the daemon's ports 1502 and 8080 are free ports. Lines that
install or open a browser (make, pip, venv, xdg-open) are skipped and
listed. What a line puts in the background (`&`) runs there, and after a
`lec sim` or `lec serve` the next line waits for it to listen; a `lec sniff`
line ends with SIGINT after 3 s, as the user's Ctrl-C ends it; each block ends by stopping them.
Every other line must exit 0 (`lec replay`: 0 or 1, its report of a
difference; `lec doctor`: up to 7, a line that works): the first that does not fails the test, named with its README
line number.

Usage: readme.py README.md LEC_BUILD_DIR"""

import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import tempfile

SKIP = re.compile(r"^(make |xdg-open |/usr/bin/python3 -m venv |~/\.venvs/|\. ~/\.venvs/|sudo )")


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


def shell_script(readme_blocks, env):
    p1, p2 = env["P1"], env["P2"]
    out = ["set -uo pipefail", "cd \"$WORK\"",
           "wait_file() { for _ in $(seq 300); do [[ -e $1 ]] && return 0; sleep 0.1; done; "
           "echo \"FAIL: $1 never appeared\"; return 1; }",
           "wait_port() { for _ in $(seq 300); do (exec 3<>/dev/tcp/127.0.0.1/$1) 2>/dev/null "
           "&& return 0; sleep 0.1; done; echo \"FAIL: nothing listens on $1\"; return 1; }",
           "stop_jobs() { local j; for j in $(jobs -p); do kill $j; wait $j 2>/dev/null; done; "
           "true; }"]
    skipped = []
    for start, lines in readme_blocks:
        for i, raw in enumerate(lines):
            n = start + i
            line = raw.split(" #")[0].rstrip() if not raw.lstrip().startswith("#") else ""
            if not line.strip():
                continue
            if SKIP.match(line):
                skipped.append(f"README:{n}: {line}")
                continue
            line = line.replace("/dev/ttyUSB0", "$TWIN").replace("/dev/ttyUSB1", "$TAP")
            line = line.replace("/tmp/lec0", "$WORK/lec0")
            line = line.replace("127.0.0.1:8080", f"127.0.0.1:{p2}")
            line = re.sub(r"\b1502\b", str(p1), line)
            text = shlex.quote(raw.strip())
            out.append(f"echo \"+ README:{n}: \"{text}")
            # `a & b`: a runs in the background, b in the foreground; a line
            # ending in `&` is all background. A background `lec sim` or `lec
            # serve` is a daemon: the next line waits for it to listen.
            parts = [p.strip() for p in line.split(" & ")]
            background = parts[:-1]
            last = parts[-1]
            # A daemon pasted without `&` runs until Ctrl-C: in the background
            # here, stopped at the block's end.
            if last.endswith("&") or re.match(r"^lec (serve\b|sim\b.*--pty )", last):
                background.append(last.rstrip(" &"))
                last = ""
            for part in background:
                daemon = re.match(r"^lec (sim|serve)\b", part)
                if daemon and daemon.group(1) == "serve":
                    part += f" --modbus-tcp 127.0.0.1:{p1} --http 127.0.0.1:{p2}"
                out.append(part + " >>\"$WORK/daemon.log\" 2>&1 &")
                if daemon and daemon.group(1) == "sim":
                    pty = re.search(r"--pty (\S+)", part).group(1)
                    out.append(f"wait_file {pty} || exit 1")
                elif daemon:
                    out.append(f"wait_port {p2} || {{ cat \"$WORK/daemon.log\"; exit 1; }}")
            if not last:
                continue
            if re.match(r"^lec( --\S+( [^-]\S*)?)* sniff\b", last):
                # A listener runs until Ctrl-C: the user's Ctrl-C after 3 s
                # (SIGINT; lec sniff then prints its statistics and exits 0).
                last = f"timeout --preserve-status -s INT 3 {last}"
            # `lec replay` exits 1 when the replay differs from the capture (its
            # documented answer, a report); 2 and above are errors. `lec doctor`
            # exits 7 for a line that works, degraded (a loaded host delays a
            # twin's reply now and then), 8 for a broken one.
            ok = "0"
            if re.match(r"^lec( --\S+( [^-]\S*)?)* replay\b", last):
                ok = "1"
            elif re.match(r"^lec( --\S+( [^-]\S*)?)* doctor\b", last):
                ok = "7"
            out.append(last)
            out.append(f"rc=$?; if [[ $rc -gt {ok} ]]; then echo \"FAIL: README:{n} exited "
                       f"$rc: \"{text}; exit 1; fi")
        out.append("stop_jobs")
    out.append("echo \"all README shell lines passed\"")
    return "\n".join(out) + "\n", skipped


def main():
    readme, build = sys.argv[1], os.path.abspath(sys.argv[2])
    text = open(readme).read()
    with tempfile.TemporaryDirectory() as work:
        os.symlink(build, os.path.join(work, "build"))
        env = {"PATH": "/usr/local/bin:/usr/bin:/bin", "HOME": work, "WORK": work,
               "TWIN": os.path.join(work, "tty"), "TAP": os.path.join(work, "tap"), "P1": str(free_port()),
               "P2": str(free_port()), "LANG": "C.UTF-8"}
        twin = subprocess.Popen([os.path.join(build, "lec"), "sim", "--pty", env["TWIN"],
                                 "--ids", "1-4", "--workpiece", "350", "--timing", "fast",
                                 "--tap", env["TAP"]],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            for _ in range(300):
                if os.path.exists(env["TWIN"]):
                    break
                subprocess.run(["sleep", "0.1"])
            script, skipped = shell_script(blocks(text, "sh"), env)
            with open(os.path.join(work, "readme.sh"), "w") as f:
                f.write(script)
            print("skipped (install or browser):\n  " + "\n  ".join(skipped), flush=True)
            # Its own process group: a line that hangs (the timeout) must not
            # leave the daemons it started running.
            sh = subprocess.Popen(["bash", os.path.join(work, "readme.sh")], env=env, cwd=work,
                                  start_new_session=True)
            try:
                rc = sh.wait(timeout=400)
            except subprocess.TimeoutExpired:
                print("FAIL: the README's shell lines did not end within 400 s", flush=True)
                rc = 1
            finally:
                try:
                    os.killpg(sh.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
                sh.wait()
            if rc != 0:
                return 1
            # The Python block, with the module of this build.
            import glob
            if not glob.glob(os.path.join(build, "python", "lec6", "_lec6*.so")):
                print("python block skipped: no module in this build tree")
                return 0
            for start, lines in blocks(text, "python"):
                code = "\n".join(lines).replace('"/dev/ttyUSB0"', repr(env["TWIN"]))
                r = subprocess.run(["/usr/bin/python3", "-c", code], cwd=work, timeout=120,
                                   env={**env, "PYTHONPATH": os.path.join(build, "python")},
                                   capture_output=True, text=True)
                print(r.stdout, r.stderr, sep="", end="")
                if r.returncode != 0:
                    print(f"FAIL: the python block at README:{start} exited {r.returncode}")
                    return 1
            print("the README's python block passed")
            return 0
        finally:
            twin.terminate()
            twin.wait(10)


if __name__ == "__main__":
    sys.exit(main())
