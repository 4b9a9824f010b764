#!/usr/bin/python3
"""Modbus TCP clients for serve_test.sh: real sockets against a running `lec serve`.

    serve_clients.py pymodbus-steps PORT UNIT   write a step with Debian's pymodbus, read it back
    serve_clients.py poll PORT CLIENTS SECONDS  CLIENTS connections polling D9000x7 of units 1-4
    serve_clients.py echo PORT CLIENTS SECONDS UNIT
                                                CLIENTS connections sending FC08 to UNIT back to
                                                back (they fill the line); "ready", then JSON
    serve_clients.py bad-mbap PORT              a broken MBAP frame closes that connection only
    serve_clients.py pipeline PORT N            N writes pipelined on one connection, answers by tid
    serve_clients.py hold PORT N                N reads sent, then wait to be killed (SIGKILL test)

Each prints one JSON line with what it saw; the shell script checks it.
"""
import json
import socket
import struct
import sys
import threading
import time

STATE = (0x9000, 7)


def mbap(tid, unit, pdu):
    return struct.pack(">HHHB", tid, 0, len(pdu) + 1, unit) + pdu


def read_regs_pdu(start, count):
    return struct.pack(">BHH", 3, start, count)


def recv_exact(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionError("closed")
        data += chunk
    return data


def recv_adu(sock):
    head = recv_exact(sock, 7)
    tid, proto, length, unit = struct.unpack(">HHHB", head)
    return tid, unit, recv_exact(sock, length - 1)


def connect(port):
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


def pymodbus_steps(port, unit):
    from pymodbus.client import ModbusTcpClient

    c = ModbusTcpClient("127.0.0.1", port=port, timeout=5)
    if not c.connect():
        print(json.dumps({"error": "cannot connect"}))
        return 1
    # Step 5: ABS 500 mm/s to 123.45 mm, 5000/5000 mm/s2, moving force 100 %, in position 0.50 mm.
    step = [1, 500, 0, 12345, 5000, 5000, 0, 0, 20, 100, 0, 0, 0, 0, 0, 50]
    w = c.write_registers(0x0400 + 0x10 * 5, step, slave=unit)
    r = c.read_holding_registers(0x0400 + 0x10 * 5, 16, slave=unit)
    out = {"write_error": w.isError(), "read_error": r.isError(),
           "equal": (not r.isError()) and list(r.registers) == step}
    c.close()
    print(json.dumps(out))
    return 0


def poll(port, clients, seconds, pdu=read_regs_pdu(*STATE), expect=b"\x03\x0e", unit_of=None,
         ready=None):
    """CLIENTS connections sending `pdu` back to back for SECONDS; an answer
    counts when it starts with `expect`. `ready` (a barrier) is met once every
    client has its first answer."""
    counts = [0] * clients
    errors = [0] * clients
    bad = [0] * clients
    unit_of = unit_of or (lambda i: 1 + i % 4)

    def run(i):
        unit = unit_of(i)
        try:
            s = connect(port)
            end = None
            tid = 0
            while end is None or time.monotonic() < end:
                tid = (tid + 1) & 0xFFFF
                s.sendall(mbap(tid, unit, pdu))
                rtid, runit, answer = recv_adu(s)
                if rtid != tid or runit != unit:
                    bad[i] += 1
                elif answer.startswith(expect):
                    counts[i] += 1
                else:
                    errors[i] += 1
                if end is None:
                    if ready:
                        ready.wait()
                    end = time.monotonic() + seconds
            s.close()
        except Exception:
            errors[i] += 1
            if ready:
                ready.abort()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(clients)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    print(json.dumps({"min_answers": min(counts), "total": sum(counts),
                      "errors": sum(errors), "mismatched": sum(bad)}))
    return 0


def echo(port, clients, seconds, unit):
    """CLIENTS connections sending FC08 (never cached) to UNIT back to back:
    they fill the line. Prints "ready" once each has its first answer."""
    pdu = struct.pack(">BHH", 8, 0, 0x1234)
    ready = threading.Barrier(clients + 1)
    done = threading.Thread(target=poll, args=(port, clients, seconds, pdu, pdu, lambda i: unit, ready))
    done.start()
    try:
        ready.wait(timeout=30)
        print("ready", flush=True)
    except threading.BrokenBarrierError:
        print("not ready", flush=True)
    done.join()
    return 0


def bad_mbap(port):
    good = connect(port)
    broken = connect(port)
    broken.sendall(struct.pack(">HHHB", 1, 7, 6, 1) + read_regs_pdu(*STATE))  # protocol id 7
    broken.settimeout(5)
    try:
        closed = broken.recv(16) == b""
    except ConnectionError:
        closed = True
    good.sendall(mbap(9, 1, read_regs_pdu(*STATE)))
    tid, unit, pdu = recv_adu(good)
    print(json.dumps({"broken_closed": closed, "other_answered": tid == 9 and pdu[0] == 3}))
    return 0


def pipeline(port, n):
    s = connect(port)
    s.settimeout(20)
    # Writes that change nothing (Y30, serial mode, ON), so each one goes to the line.
    for tid in range(1, n + 1):
        s.sendall(mbap(tid, 1, struct.pack(">BHH", 5, 0x30, 0xFF00)))
    print(json.dumps({"sent": n}), flush=True)  # the test stops the daemon now
    seen = {}
    try:
        while len(seen) < n:
            tid, unit, pdu = recv_adu(s)
            seen[tid] = "ok" if pdu[0] == 5 else "exception %02X" % pdu[1]
    except (ConnectionError, socket.timeout):
        pass
    kinds = {}
    for v in seen.values():
        kinds[v] = kinds.get(v, 0) + 1
    print(json.dumps({"answered": len(seen), "kinds": kinds}))
    return 0


def hold(port, n):
    s = connect(port)
    for tid in range(1, n + 1):
        s.sendall(mbap(tid, 1 + tid % 4, struct.pack(">BHH", 5, 0x30, 0xFF00)))
    print(json.dumps({"sent": n}), flush=True)
    time.sleep(60)  # killed by the test long before
    return 0


def main():
    what = sys.argv[1]
    port = int(sys.argv[2])
    if what == "pymodbus-steps":
        return pymodbus_steps(port, int(sys.argv[3]))
    if what == "poll":
        return poll(port, int(sys.argv[3]), float(sys.argv[4]))
    if what == "echo":
        return echo(port, int(sys.argv[3]), float(sys.argv[4]), int(sys.argv[5]))
    if what == "bad-mbap":
        return bad_mbap(port)
    if what == "pipeline":
        return pipeline(port, int(sys.argv[3]))
    if what == "hold":
        return hold(port, int(sys.argv[3]))
    print("unknown", what, file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
