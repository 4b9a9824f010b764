#!/usr/bin/python3
"""A busy pymodbus master for the `lec sniff` tests: N reads of D9000 x2 (and
every tenth a write of Y19 SVON), as fast as pymodbus goes.

    sniff_master.py PORT BAUD N        over a serial port (the twin's pty)
    sniff_master.py tcp://H:P N        RTU frames over TCP (a second master)

Prints "N done, E errors"; exit status 0 (errors are the twin's business here:
a second master's collisions make some). SNIFF_MASTER_TIMEOUT (s, default 1):
how long a request waits for its reply (each collision costs that much).
"""

import logging
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import lec6_preflight  # noqa: E402

lec6_preflight.require(modules=["pymodbus.client", "pymodbus.framer.rtu_framer"])

from pymodbus.client import ModbusSerialClient, ModbusTcpClient  # noqa: E402
from pymodbus.framer.rtu_framer import ModbusRtuFramer  # noqa: E402

logging.basicConfig(level=logging.CRITICAL)


def main():
    timeout = float(os.environ.get("SNIFF_MASTER_TIMEOUT", "1"))
    if sys.argv[1].startswith("tcp://"):
        host, port = sys.argv[1][len("tcp://"):].rsplit(":", 1)
        client = ModbusTcpClient(host, port=int(port), framer=ModbusRtuFramer, timeout=timeout,
                                 retries=0, retry_on_empty=False)
        n = int(sys.argv[2])
    else:
        client = ModbusSerialClient(port=sys.argv[1], baudrate=int(sys.argv[2]), timeout=timeout,
                                    retries=0, retry_on_empty=False)
        n = int(sys.argv[3])
    if not client.connect():
        raise SystemExit(f"cannot open {sys.argv[1]}")
    errors = 0
    for i in range(n):
        try:
            if i % 10 == 9:
                r = client.write_coil(0x19, True, slave=1)
            else:
                r = client.read_holding_registers(0x9000, 2, slave=1)
            errors += r.isError()
        except Exception:  # noqa: BLE001 - a collision's garbage; counted
            errors += 1
    client.close()
    print(f"{n} done, {errors} errors")


main()
