#!/usr/bin/python3
"""CPU that `lec sniff` costs on a full 115200 baud line (BENCHMARKS.md, "lec sniff").

    /usr/bin/python3 bench/sniff_cpu.py --lec build/lec [--seconds 10] [--baud 115200] [--json]

Feeds a pseudo-terminal with back-to-back exchanges (read D9000 x2 and its
reply) at the line's full byte rate, paced in 1 ms slices, while
`lec sniff --port PTY` decodes and prints them (stdout to /dev/null); reports
the child's user+system CPU time over the wall time, as % of one core.
"""

import argparse
import os
import pty
import signal
import struct
import subprocess
import time
import tty


def crc(body):
    c = 0xFFFF
    for x in body:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
    return bytes(body) + struct.pack("<H", c)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lec", required=True)
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--baud", type=int, default=115200)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--extra", default="", help="more lec sniff options, e.g. '--filter id=99'")
    a = ap.parse_args()
    master, slave = pty.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    path = os.ttyname(slave)
    exchange = crc([1, 3, 0x90, 0, 0, 2]) + crc([1, 3, 4, 0, 0, 0x27, 0x10])
    args = [a.lec, "sniff", "--port", path, "--baud", str(a.baud)] + (["--json"] if a.json else []) + a.extra.split()
    child = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(0.5)
    bytes_per_ms = a.baud / 10 / 1000
    start = time.monotonic()
    sent = 0.0
    stream = exchange * 1000
    pos = 0
    while time.monotonic() - start < a.seconds:
        due = (time.monotonic() - start) * 1000 * bytes_per_ms
        n = int(due - sent)
        if n > 0:
            chunk = stream[pos:pos + n]
            if len(chunk) < n:
                pos = 0
                chunk = stream[:n]
            os.write(master, chunk)
            pos = (pos + n) % len(exchange) if pos + n >= len(stream) else pos + n
            sent += n
        time.sleep(0.001)
    wall = time.monotonic() - start
    child.send_signal(signal.SIGINT)
    _, status, usage = os.wait4(child.pid, 0)
    cpu = usage.ru_utime + usage.ru_stime
    frames = sent / len(exchange) * 2
    print(f"{a.baud} baud, {wall:.1f} s, {sent / wall:.0f} bytes/s, {frames / wall:.0f} frames/s, "
          f"output {'json' if a.json else 'text'} {a.extra}: lec sniff used {cpu:.3f} s CPU = "
          f"{100 * cpu / wall:.2f} % of one core (exit {os.waitstatus_to_exitcode(status)})")


main()
