#!/usr/bin/python3
"""The `lec bench` workload on Debian's python3-pymodbus (3.0) sync RTU client.

    /usr/bin/python3 bench/pymodbus_bench.py PORT BAUD read-state|read-flags N [ID]

One warm-up transaction, then N timed ones back to back. Latency: the call to
read_holding_registers / read_discrete_inputs until it returns. Prints one
JSON object with the keys `lec bench --json` uses; exit status 1 if any
transaction failed.

pymodbus's RTU framer sleeps its own silent interval (3.5 chars, but a fixed
1.75 ms above 19200 baud) before a query when the previous frame ended less
than that ago; that is part of what is measured.
"""
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
import lec6_preflight  # noqa: E402

# Name the Debian package, not a traceback, when pymodbus or what it loads is missing.
lec6_preflight.require(modules=["pymodbus.client"])

import pymodbus
from pymodbus.client import ModbusSerialClient


def main():
    if len(sys.argv) < 5:
        print(__doc__, file=sys.stderr)
        return 2
    port, baud, op, n = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
    unit = int(sys.argv[5]) if len(sys.argv) > 5 else 1
    if op not in ("read-state", "read-flags"):
        print(f"op {op!r}: expected read-state or read-flags", file=sys.stderr)
        return 2
    client = ModbusSerialClient(method="rtu", port=port, baudrate=baud, timeout=1)  # whole seconds: 3.0 truncates
    if not client.connect():
        print(f"cannot open {port}", file=sys.stderr)
        return 1
    if op == "read-state":
        call = lambda: client.read_holding_registers(0x9000, 7, slave=unit)  # noqa: E731
    else:
        call = lambda: client.read_discrete_inputs(0x40, 16, slave=unit)  # noqa: E731
    errors = 0
    if call().isError():  # warm-up
        errors += 1
    lat = []
    clock = time.perf_counter
    start = clock()
    for _ in range(n):
        t0 = clock()
        r = call()
        t1 = clock()
        if r.isError():
            errors += 1
            continue
        lat.append((t1 - t0) * 1e3)
    total = clock() - start
    client.close()
    lat.sort()

    def pct(p):
        return lat[min(len(lat) - 1, int(p * len(lat)))] if lat else 0.0

    print(json.dumps({
        "stack": f"pymodbus {pymodbus.__version__}", "op": op, "n": len(lat), "errors": errors,
        "baud": baud, "tx_per_s": len(lat) / total if total > 0 else 0.0,
        "latency_ms": {"p50": pct(0.5), "p99": pct(0.99), "max": lat[-1] if lat else 0.0},
    }))
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
