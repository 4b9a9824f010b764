#!/usr/bin/python3
"""A third-party Modbus RTU slave (Debian's python3-pymodbus) holding LEC registers.

Serves RTU frames over TCP on 127.0.0.1:PORT for unit 1, with known values, so
the test can check that our typed reads decode what another stack encodes.
Usage: pymodbus_slave.py PORT
"""
import logging
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import lec6_preflight  # noqa: E402

# Name the Debian package, not a traceback, when pymodbus or what it loads is missing.
lec6_preflight.require(modules=["pymodbus.datastore", "pymodbus.server"])

from pymodbus.datastore import ModbusServerContext, ModbusSlaveContext, ModbusSparseDataBlock
from pymodbus.server import StartTcpServer
from pymodbus.transaction import ModbusRtuFramer

logging.basicConfig(level=logging.ERROR)


def words32(v):
    v &= 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


def registers():
    regs = {a: 0 for a in range(0x0000, 0x0016)}
    regs.update({a: 0 for a in range(0x0380, 0x03C0)})
    regs.update({a: 0 for a in range(0x0400, 0x0800)})
    regs.update({a: 0 for a in range(0x9000, 0x9100)})
    regs.update({a: 0 for a in range(0x9100, 0x9112)})
    name = b"PYMODBUS-AX1".ljust(16, b"\0")
    for i in range(8):
        regs[0x000E + i] = (name[2 * i] << 8) | name[2 * i + 1]
    # State: position -123.45 mm, 42 mm/s, thrust 17 %, target 150.00 mm, step 1.
    state = words32(-12345) + [42, 17] + words32(15000) + [1]
    for i, v in enumerate(state):
        regs[0x9000 + i] = v
    # Step 1: the manual's §7.3.1 record at 150.00 mm.
    step = [1, 500] + words32(15000) + [5000, 5000, 0, 0, 20, 100] + words32(0) + words32(0) + words32(100)
    for i, v in enumerate(step):
        regs[0x0410 + i] = v
    # Alarm history group 0: code 51, group 1: code 99.
    regs[0x0380] = 51 << 8
    regs[0x0384] = 99 << 8
    return regs


def main():
    port = int(sys.argv[1])
    coils = {a: 0 for a in range(0x00, 0x40)}
    coils[0x19] = 1  # SVON
    coils[0x30] = 1  # serial mode
    inputs = {a: 0 for a in range(0x40, 0x50)}
    for bit in (0x49, 0x4A, 0x4B, 0x4F):  # SVRE SETON INP ALARM
        inputs[bit] = 1
    store = ModbusSlaveContext(
        co=ModbusSparseDataBlock(coils),
        di=ModbusSparseDataBlock(inputs),
        hr=ModbusSparseDataBlock(registers()),
        ir=ModbusSparseDataBlock({0: 0}),
        zero_mode=True,
    )
    context = ModbusServerContext(slaves={1: store}, single=False)
    print(f"pymodbus slave on 127.0.0.1:{port}", flush=True)
    StartTcpServer(context=context, framer=ModbusRtuFramer, address=("127.0.0.1", port))


if __name__ == "__main__":
    main()
