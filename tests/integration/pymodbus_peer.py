#!/usr/bin/python3
"""pymodbus (Debian's python3-pymodbus 3.0) as a master of `lec sim`.

Over 450 lines: every function code and exception is checked from pymodbus's side.

Run with /usr/bin/python3 (the interpreter Debian's pymodbus is installed for):

    pymodbus_peer.py PORT examples      manual operation examples 1-4
    pymodbus_peer.py PORT exceptions    the exception rows of digest §3
    pymodbus_peer.py PORT broadcast     unit 0 writes: no reply, but they act
    pymodbus_peer.py PORT ids N         IDs 1..N answer their own; N+1 is silent
    pymodbus_peer.py PORT echo-ids A,B C,D   IDs A, B echo; C, D are silent ("-": none)
    pymodbus_peer.py PORT timing BAUD K TD_MS N MIN MAX
                                        N read-state round trips (pyserial, from before
                                        the write to the last reply byte) over the limit
                                        wire(q) + Ts + 4 ms + Td + wire(r): the smallest
                                        ratio in [MIN, MAX], the median <= 4
    pymodbus_peer.py PORT bad-crc       replies arrive whole but with a broken CRC
    pymodbus_peer.py tcp://H:P tcp      RTU over TCP (ModbusTcpClient, RTU framer),
                                        two clients at once
    pymodbus_peer.py PORT write-step [ID]   store step 5 of ID (default 1; restart test)
    pymodbus_peer.py PORT check-step [ID]   step 5 is what write-step stored
    pymodbus_peer.py PORT hammer SECS   rewrite step 6 again and again

Prints one line per check and "N passed, M failed"; exit status 1 on any failure.
Every wait is bounded by a deadline.
"""

import logging
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import lec6_preflight  # noqa: E402

# Name the Debian package, not a traceback, when pymodbus or what it loads is missing.
lec6_preflight.require(modules=["pymodbus.client", "pymodbus.framer.rtu_framer"])

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.framer.rtu_framer import ModbusRtuFramer
from pymodbus.diag_message import ReturnQueryDataRequest
from pymodbus.pdu import ExceptionResponse

logging.basicConfig(level=logging.CRITICAL)  # pymodbus logs timeouts we provoke on purpose

BAUD = 38400
SVRE, SETON, INP, BUSY = 9, 10, 11, 8  # bit numbers in X40-X4F
STATE_AREA = 0x9000
DIRECT_DATA = 0x9102
DIRECT_START = 0x9100


def step_address(n):
    return 0x0400 + 0x10 * n


def crc16(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return bytes([crc & 0xFF, crc >> 8])


def with_crc(body):
    body = bytes(body)
    return body + crc16(body)


def s32(value):
    """A 32-bit value as two registers, high word first."""
    value &= 0xFFFFFFFF
    return [value >> 16, value & 0xFFFF]


def record(position_001mm, speed=500, in_position=100):
    """A positioning step / direct-operation record as the manual's example 4."""
    return ([1, speed] + s32(position_001mm) + [5000, 5000, 0, 0, 20, 100] + s32(0) + s32(0)
            + s32(in_position))


class Checks:
    def __init__(self):
        self.passed = 0
        self.failed = 0

    def check(self, ok, what, detail=""):
        if ok:
            self.passed += 1
            print(f"ok   {what}")
        else:
            self.failed += 1
            print(f"FAIL {what} {detail}")
        sys.stdout.flush()
        return ok

    def finish(self):
        print(f"{self.passed} passed, {self.failed} failed")
        return 0 if self.failed == 0 and self.passed > 0 else 1


class Peer:
    def __init__(self, port, timeout=1):
        # pymodbus 3.0 takes whole seconds; no retries, so a silence is seen as one.
        self.client = ModbusSerialClient(port=port, baudrate=BAUD, timeout=timeout, retries=0,
                                         retry_on_empty=False, broadcast_enable=True)
        if not self.client.connect():
            raise SystemExit(f"cannot open {port}")

    def close(self):
        self.client.close()

    # ---- typed helpers (slave=1 unless told: pymodbus's default unit 0 is broadcast) ----
    def coil(self, address, value, slave=1):
        return self.client.write_coil(address, value, slave=slave)

    def inputs(self, slave=1):
        r = self.client.read_discrete_inputs(0x40, 16, slave=slave)
        if r.isError():
            raise RuntimeError(f"read X40-X4F: {r}")
        return r.bits[:16]

    def registers(self, address, count, slave=1):
        r = self.client.read_holding_registers(address, count, slave=slave)
        if r.isError():
            raise RuntimeError(f"read D{address:04X}: {r}")
        return r.registers

    def position(self, slave=1):
        hi, lo = self.registers(STATE_AREA, 2, slave)
        v = (hi << 16) | lo
        return v - (1 << 32) if v & 0x80000000 else v

    def wait_inputs(self, predicate, what, timeout=10.0):
        deadline = time.monotonic() + timeout
        while True:
            bits = self.inputs()
            if predicate(bits):
                return bits
            if time.monotonic() > deadline:
                raise RuntimeError(f"timed out waiting for {what}; X40-X4F = {bits}")

    # ---- raw frames, for what pymodbus will not send ----
    def raw(self, body, reply_length, timeout=0.5):
        return self.raw_bytes(with_crc(body), reply_length, timeout)

    def raw_bytes(self, frame, reply_length, timeout=0.5):
        s = self.client.socket
        s.reset_input_buffer()
        s.write(bytes(frame))
        s.flush()
        s.timeout = timeout
        got = s.read(reply_length)
        return got


def exception_code(response):
    if isinstance(response, ExceptionResponse):
        return response.exception_code
    return None


# ---- operation examples 1-4 -----------------------------------------------------------

def examples(peer, c):
    # Example 1: preparation, return to origin, run a stored step.
    c.check(not peer.coil(0x30, True).isError(), "Y30 <- 1 (serial input mode)")
    c.check(not peer.coil(0x19, True).isError(), "Y19 <- 1 (SVON)")
    bits = peer.wait_inputs(lambda b: b[SVRE], "SVRE")
    c.check(bits == [i == SVRE for i in range(16)], "X40-X4F after servo on is only SVRE "
            "(manual reply 01 02 02 00 02)", str(bits))
    c.check(not peer.coil(0x1C, True).isError(), "Y1C <- 1 (SETUP)")
    bits = peer.wait_inputs(lambda b: b[SETON] and not b[BUSY], "SETON and BUSY 0")
    c.check(bits == [i in (SVRE, SETON, INP) for i in range(16)],
            "X40-X4F after homing is SVRE+SETON+INP (manual reply 01 02 02 00 0E)", str(bits))
    c.check(not peer.coil(0x1C, False).isError(), "Y1C <- 0")
    c.check(peer.position() == 0, "D9000 = 0 after return to origin")

    # Example 2: edit step data (the whole record of step 1, FC10 x16; position 150.00).
    r = peer.client.write_registers(step_address(1), record(15000), slave=1)
    c.check(not r.isError() and r.address == step_address(1) and r.count == 16,
            "FC10 step 1 x16 (position 150.00) answered with start and count", str(r))
    c.check(peer.registers(step_address(1), 16) == record(15000), "step 1 reads back as written")
    # The manual's own example: only the position of step 1.
    r = peer.client.write_registers(step_address(1) + 2, s32(15000), slave=1)
    c.check(not r.isError(), "FC10 D0412 x2 = 15000 (manual example 2)", str(r))

    # Example 1 continued: select step 1 on IN0-IN5 (FC0F Y10 x8) and DRIVE.
    r = peer.client.write_coils(0x10, [True] + [False] * 7, slave=1)
    c.check(not r.isError() and r.address == 0x10 and r.count == 8, "FC0F Y10 x8 = step 1", str(r))
    c.check(not peer.coil(0x1A, True).isError(), "Y1A <- 1 (DRIVE)")
    bits = peer.wait_inputs(lambda b: not b[BUSY], "BUSY to fall")
    c.check(bits[INP], "INP = 1 once BUSY fell", str(bits))
    c.check(bits[0] and not any(bits[1:6]), "OUT0-OUT5 = 1 (the step started)", str(bits))
    c.check(not peer.coil(0x1A, False).isError(), "Y1A <- 0")

    # Example 3: read the position.
    pos = peer.position()
    c.check(pos == 15000, "D9000 x2 = 15000 (150.00 mm)", str(pos))

    # Example 4: direct operation, the manual's frame (FC10 D9102 x16) and D9100 <- 0100h.
    r = peer.client.write_registers(DIRECT_DATA, record(30000), slave=1)
    c.check(not r.isError() and r.count == 16, "FC10 D9102 x16 (position 300.00)", str(r))
    r = peer.client.write_registers(DIRECT_START, [0x0100], slave=1)
    c.check(not r.isError(), "FC10 D9100 <- 0100h (start)", str(r))
    bits = peer.wait_inputs(lambda b: not b[BUSY], "BUSY to fall")
    c.check(bits[INP], "INP = 1 after the direct operation", str(bits))
    pos = peer.position()
    c.check(pos == 30000, "D9000 x2 = 30000 (300.00 mm)", str(pos))
    # The manual's frame 7.3.1 byte for byte, its CRC (72 48) included
    # (the conformance table's transcription, tests/data/manual-frames.tsv).
    frame = bytes.fromhex("01 10 91 02 00 10 20 00 01 01 F4 00 00 75 30 13 88 13 88 00 00 00 00 00 14"
                          " 00 64 00 00 00 00 00 00 00 00 00 00 00 64 72 48")
    got = peer.raw_bytes(frame, 8)
    c.check(got == with_crc(bytes.fromhex("01 10 91 02 00 10")),
            "the manual's frame 7.3.1 (CRC 72 48) is answered 01 10 91 02 00 10", got.hex(" "))


# ---- exceptions (digest §3) ---------------------------------------------------------------

def exceptions(peer, c):
    def expect(code, response, what):
        got = exception_code(response)
        c.check(got == code, f"{what} -> exception {code:02X}", f"got {response}")

    # Still in parallel mode (power-on): Y10-Y1F, D90C1 and D9100 refuse writes.
    expect(2, peer.coil(0x1A, True), "parallel mode: FC05 Y1A DRIVE")
    expect(2, peer.client.write_coils(0x10, [True] * 8, slave=1), "parallel mode: FC0F Y10 x8")
    expect(2, peer.client.write_registers(DIRECT_START, [0x0100], slave=1),
           "parallel mode: FC10 D9100")
    expect(2, peer.client.write_registers(0x90C1, [0], slave=1), "parallel mode: FC10 D90C1")

    expect(1, peer.client.read_input_registers(0x9000, 2, slave=1), "FC04 (no such function)")
    expect(1, peer.client.write_register(0x0410, 1, slave=1), "FC06 (no single-register write)")
    expect(3, peer.client.read_holding_registers(0x9000, 0, slave=1), "FC03 count 0")
    expect(3, peer.client.read_coils(0x10, 0, slave=1), "FC01 count 0")
    expect(3, peer.client.read_holding_registers(0x9000, 126, slave=1), "FC03 count 126 (> 125)")
    expect(2, peer.client.read_holding_registers(0x0000, 1, slave=1), "FC03 start D0000 outside")
    expect(2, peer.client.read_discrete_inputs(0x00, 1, slave=1), "FC02 start X00 outside")
    expect(2, peer.client.read_holding_registers(0x8000, 2, slave=1), "FC03 start D8000 outside")
    expect(3, peer.client.read_holding_registers(0x90F0, 0x20, slave=1),
           "FC03 D90F0 x32 ends beyond the state area")
    expect(3, peer.client.read_discrete_inputs(0x48, 16, slave=1), "FC02 X48 x16 ends beyond X4F")
    expect(3, peer.client.read_holding_registers(0x07F8, 16, slave=1), "FC03 D07F8 x16 ends beyond the steps")
    expect(2, peer.client.write_registers(0x9000, [0, 0], slave=1), "FC10 D9000 (read-only)")
    expect(2, peer.client.write_registers(0x000E, [0x4142], slave=1), "FC10 D000E name (read-only)")
    expect(2, peer.coil(0x31, True), "FC05 Y31 (not permitted)")

    # FC05 with a value other than FF00/0000: pymodbus cannot send it; a raw frame.
    got = peer.raw([1, 0x05, 0x00, 0x30, 0x12, 0x34], 5)
    c.check(got == with_crc([1, 0x85, 0x03]), "FC05 Y30 value 1234h -> exception 03", got.hex(" "))
    # FC08 with test code other than 0000.
    got = peer.raw([1, 0x08, 0x00, 0x01, 0x12, 0x34], 5)
    c.check(got == with_crc([1, 0x88, 0x02]), "FC08 test code 0001 -> exception 02", got.hex(" "))
    # FC08 test code 0000 echoes, through pymodbus's own diagnostic request.
    r = peer.client.execute(ReturnQueryDataRequest(0x1234, unit=1))
    c.check(not r.isError() and list(getattr(r, "message", [])) == [0x1234],
            "FC08 0000 echo through pymodbus", str(vars(r)))
    # FC0F with 257 points (> 256): 03.
    got = peer.raw([1, 0x0F, 0x00, 0x10, 0x01, 0x01, 33] + [0] * 33, 5)
    c.check(got == with_crc([1, 0x8F, 0x03]), "FC0F 257 points -> exception 03", got.hex(" "))
    # FC10 whose byte count disagrees with its count: 03.
    got = peer.raw([1, 0x10, 0x04, 0x10, 0x00, 0x02, 0x02, 0x00, 0x01], 5)
    c.check(got == with_crc([1, 0x90, 0x03]), "FC10 count 2 with byte count 2 -> exception 03",
            got.hex(" "))
    # An undefined function code, raw.
    got = peer.raw([1, 0x2B, 0x0E, 0x01, 0x00], 5)
    c.check(got == with_crc([1, 0xAB, 0x01]), "FC2B -> exception 01", got.hex(" "))
    # A frame with a bad CRC: no reply at all.
    bad = bytearray(with_crc([1, 0x03, 0x90, 0x00, 0x00, 0x02]))
    bad[-1] ^= 0xFF
    s = peer.client.socket
    s.reset_input_buffer()
    s.write(bytes(bad))
    s.timeout = 0.2
    c.check(s.read(1) == b"", "a bad CRC gets silence")
    # Serial mode then makes the parallel-mode refusals go away.
    c.check(not peer.coil(0x30, True).isError(), "Y30 <- 1")
    r = peer.client.write_coils(0x10, [False] * 8, slave=1)
    c.check(not r.isError(), "serial mode: FC0F Y10 x8 accepted", str(r))


# ---- broadcast ----------------------------------------------------------------------------

def broadcast(peer, c):
    bits = peer.client.read_coils(0x30, 1, slave=1)
    c.check(not bits.isError() and not bits.bits[0], "Y30 = 0 at power-on", str(bits))
    t0 = time.monotonic()
    r = peer.coil(0x30, True, slave=0)
    c.check(isinstance(r, (bytes, str)) or not r.isError(), "broadcast FC05 Y30 <- 1 sent", str(r))
    s = peer.client.socket
    s.timeout = 0.2
    c.check(s.read(1) == b"", "no reply to the broadcast")
    bits = peer.client.read_coils(0x30, 1, slave=1)
    c.check(not bits.isError() and bits.bits[0], "Y30 = 1 read back with unit 1", str(bits))
    r = peer.client.write_registers(step_address(3), record(12345), slave=0)
    c.check(s.read(1) == b"", "no reply to a broadcast FC10")
    c.check(peer.registers(step_address(3), 16) == record(12345),
            "the broadcast FC10 stored step 3")
    # A broadcast read is ignored: no reply.
    got = peer.raw([0, 0x03, 0x90, 0x00, 0x00, 0x02], 1, timeout=0.2)
    c.check(got == b"", "a broadcast read is ignored (silence)")
    del t0


# ---- several IDs -----------------------------------------------------------------------------

def ids(peer, c, n):
    for i in range(1, n + 1):
        data = 0x1000 + i
        got = peer.raw([i, 0x08, 0x00, 0x00, data >> 8, data & 0xFF], 8)
        c.check(got == with_crc([i, 0x08, 0x00, 0x00, data >> 8, data & 0xFF]),
                f"ID {i} echoes its own FC08", got.hex(" "))
        r = peer.client.read_holding_registers(0x000E, 8, slave=i)
        c.check(not r.isError() and r.registers[0] == 0x4C45,  # "LE" of LEC6-TWIN
                f"ID {i} reads its own name", str(r))
    # An ID not on the bus: silence, both raw and through pymodbus.
    absent = n + 1
    got = peer.raw([absent, 0x08, 0x00, 0x00, 0xAB, 0xCD], 1, timeout=0.2)
    c.check(got == b"", f"ID {absent} (not on the bus) gets silence")
    t0 = time.monotonic()
    r = peer.client.read_holding_registers(0x9000, 2, slave=absent)
    c.check(r.isError(), f"pymodbus read from ID {absent} times out "
            f"(after {time.monotonic() - t0:.2f} s)", str(r))
    # ... and nobody else spoke meanwhile (pymodbus may have closed the port
    # after its timeout: reopen it).
    peer.client.connect()
    s = peer.client.socket
    s.timeout = 0.2
    c.check(s.read(1) == b"", "the bus stays silent")
    # The IDs still answer after the silence.
    r = peer.client.read_holding_registers(0x9000, 2, slave=n)
    c.check(not r.isError(), f"ID {n} answers after the silence", str(r))


def echo_ids(peer, c, present, absent):
    for i in present:
        body = [i, 0x08, 0x00, 0x00, 0x55, i]
        got = peer.raw(body, 8)
        c.check(got == with_crc(body), f"ID {i} echoes", got.hex(" "))
    for i in absent:
        got = peer.raw([i, 0x08, 0x00, 0x00, 0x55, i], 1, timeout=0.1)
        c.check(got == b"", f"ID {i} is silent", got.hex(" "))


# ---- timing, faults, TCP (used by program_test.sh) ---------------------------------------

def timing(peer, c, baud, k, td_ms, n, min_ratio, max_ratio):
    char_ms = 10 * 1000.0 / baud
    query = with_crc([1, 0x03, 0x90, 0x00, 0x00, 0x07])  # D9000 x7, the state area
    reply_len = 5 + 14
    limit_ms = len(query) * char_ms + k * 3.5 * char_ms + 4.0 + td_ms + reply_len * char_ms
    s = peer.client.socket
    s.timeout = 1.0
    s.baudrate = baud  # the twin answers only at its own baud, as a real line does
    ratios = []
    for _ in range(n):
        s.reset_input_buffer()
        t0 = time.perf_counter()
        s.write(query)
        s.flush()
        got = s.read(reply_len)
        t1 = time.perf_counter()
        if len(got) != reply_len or got[:3] != bytes([1, 3, 14]):
            c.check(False, "read-state reply", got.hex(" "))
            return
        ratios.append((t1 - t0) * 1000.0 / limit_ms)
    ratios.sort()
    median = ratios[len(ratios) // 2]
    summary = (f"limit {limit_ms:.3f} ms; round trip / limit: min {ratios[0]:.4f}, "
               f"median {median:.4f}, max {ratios[-1]:.4f} over {n}")
    # Scheduling (a loaded machine, sanitizers) only ever adds delay, so the
    # best of n round trips shows the twin's own timing; the median only has
    # to show no systematic lateness (a wake-up left to a timeout).
    c.check(ratios[0] >= min_ratio, f"no reply before its time (min ratio >= {min_ratio}); {summary}")
    c.check(ratios[0] <= max_ratio, f"the best round trip within {max_ratio}x the limit; {summary}")
    c.check(median <= 4.0, f"median ratio <= 4 (no systematic lateness); {summary}")


def bad_crc(peer, c):
    body = [1, 0x08, 0x00, 0x00, 0x12, 0x34]
    for _ in range(3):
        got = peer.raw(body, 8)
        c.check(len(got) == 8 and got != with_crc(body) and crc16(got[:-2]) != got[-2:],
                "a whole reply arrives with a broken CRC", got.hex(" "))


def tcp(url, c):
    host, port = url[len("tcp://"):].rsplit(":", 1)
    clients = [ModbusTcpClient(host, port=int(port), framer=ModbusRtuFramer, timeout=1,
                               retries=0, retry_on_empty=False) for _ in range(2)]
    for i, client in enumerate(clients):
        c.check(client.connect(), f"client {i} connects to {url}")
    for round_ in range(3):
        for i, client in enumerate(clients):
            r = client.read_holding_registers(0x000E, 8, slave=1)
            c.check(not r.isError() and r.registers[:2] == [0x4C45, 0x4336],
                    f"round {round_}: client {i} reads the name over TCP", str(r))
    r = clients[0].write_coil(0x30, True, slave=1)
    c.check(not r.isError(), "client 0 writes Y30 = 1", str(r))
    r = clients[1].read_coils(0x30, 1, slave=1)
    c.check(not r.isError() and r.bits[0], "client 1 reads Y30 = 1: one bus", str(r))
    r = clients[1].read_input_registers(0x9000, 1, slave=1)
    c.check(exception_code(r) == 1, "FC04 over TCP -> exception 01", str(r))
    for client in clients:
        client.close()


# ---- persistence (used by program_test.sh) -------------------------------------------------

def write_step(peer, c, slave):
    r = peer.client.write_registers(step_address(5), record(4242, speed=123), slave=slave)
    c.check(not r.isError(), f"step 5 of ID {slave} written", str(r))


def check_step(peer, c, slave):
    got = peer.registers(step_address(5), 16, slave)
    c.check(got == record(4242, speed=123), f"step 5 of ID {slave} survived the restart", str(got))


def hammer(peer, c, seconds):
    deadline = time.monotonic() + seconds
    n = 0
    while time.monotonic() < deadline:
        r = peer.client.write_registers(step_address(6), record(n, speed=1 + n % 1000), slave=1)
        if r.isError():
            c.check(False, "hammer write", str(r))
            return
        n += 1
    c.check(n > 0, f"hammered step 6 with {n} writes")


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 2
    port, what = argv[1], argv[2]
    c = Checks()
    if what == "tcp":
        try:
            tcp(port, c)
        except Exception as e:  # a failure counts, with its reason
            c.check(False, f"tcp: {type(e).__name__}", str(e))
        return c.finish()
    peer = Peer(port)
    try:
        if what == "examples":
            examples(peer, c)
        elif what == "exceptions":
            exceptions(peer, c)
        elif what == "broadcast":
            broadcast(peer, c)
        elif what == "ids":
            ids(peer, c, int(argv[3]))
        elif what == "echo-ids":
            ids_of = lambda arg: [] if arg == "-" else [int(x) for x in arg.split(",")]
            echo_ids(peer, c, ids_of(argv[3]), ids_of(argv[4]))
        elif what == "timing":
            baud, k, td, n = int(argv[3]), int(argv[4]), float(argv[5]), int(argv[6])
            timing(peer, c, baud, k, td, n, float(argv[7]), float(argv[8]))
        elif what == "bad-crc":
            bad_crc(peer, c)
        elif what == "write-step":
            write_step(peer, c, int(argv[3]) if len(argv) > 3 else 1)
        elif what == "check-step":
            check_step(peer, c, int(argv[3]) if len(argv) > 3 else 1)
        elif what == "hammer":
            hammer(peer, c, float(argv[3]))
        else:
            print(__doc__)
            return 2
    except Exception as e:  # a failed wait or read counts as a failure, with its reason
        c.check(False, f"{what}: {type(e).__name__}", str(e))
    finally:
        peer.close()
    return c.finish()


if __name__ == "__main__":
    sys.exit(main(sys.argv))
