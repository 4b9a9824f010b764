"""lec6: SMC LEC6 electric-actuator controllers (LECP6, LECA6) from Python.

The C++ engine of the `lec` command line, with a Python face::

    import lec6

    with lec6.connect("/dev/ttyUSB0", baud=38400) as bus:   # or "tcp://host:502", "sim"
        axis = bus.axis(1)
        axis.set_serial_mode(True)
        axis.servo_on()
        axis.home()
        result = axis.move(to=150.0, speed=500)
        print(result.outcome, axis.status())

Values are in the manual's units (mm as float, mm/s, mm/s², %), checked
against the manual's ranges before anything is sent (lec6.InvalidRequest, a
ValueError, names the field and the range). Every error is a lec6.Error.

Threads: a Bus (and its Axis objects) may be used from several threads; their
requests take turns on the line, one transaction at a time, in arrival order.
The GIL is released while waiting on the wire.

Ctrl-C during a wait (move, home, jog, servo_on, restore_steps) stops the axis
(decelerating stop, as `lec` does) and raises KeyboardInterrupt saying so.
Only the main thread receives Ctrl-C; in other threads pass `cancel=`.

For tests, lec6.Twin runs the controller twin in this process; the pytest
fixture `twin` (lec6.pytest_plugin) gives one per test.
"""

import os as _os

from ._lec6 import (  # noqa: F401  (re-exported)
    Alarm,
    AlarmError,
    Axis,
    Bus,
    AxisStand,
    Cancelled,
    Cycle,
    CycleError,
    CycleReport,
    CycleSpan,
    CycleStep,
    MoveNotStarted,
    ControllerException,
    DeadlineError,
    Error,
    Flags,
    InvalidRequest,
    MoveResult,
    RestoreReport,
    State,
    Status,
    Step,
    StepDiff,
    StepFieldDiff,
    StepTable,
    TransportError,
    Twin,
    VerifyError,
    __version__,
    open_bus as _open_bus,
)

__all__ = [
    "Alarm", "AlarmError", "Axis", "AxisStand", "Bus", "Cancelled", "Cycle", "CycleError",
    "CycleReport", "CycleSpan", "CycleStep", "ControllerException", "DeadlineError", "MoveNotStarted",
    "Error", "Flags", "InvalidRequest", "MoveResult", "RestoreReport", "State", "Status", "Step",
    "StepDiff", "StepFieldDiff", "StepTable", "TransportError", "Twin", "VerifyError", "connect",
]


def connect(port, baud=38400, *, retries=2, timeout_margin_ms=50.0, silent_interval=1,
            delay_ms=5.0, silence_wait=True, echo=False, rs485=False, trace=None,
            alarm_polarity="active-high"):
    """Opens a bus and returns it (a lec6.Bus; use bus.axis(id)).

    port: a serial device ("/dev/ttyUSB0"), "tcp://host:502" (Modbus TCP, e.g.
      `lec serve`), "rtu+tcp://host:4001" (RTU over TCP), "sim" (a twin in this
      process, ID 1), or a lec6.Twin (then only `retries` applies).
    baud: the line speed (9600 ... 230400; the controller's setting).
    retries: resends of a request whose reply was lost (reads and absolute writes only).
    timeout_margin_ms: added to the manual's response time Tx.
    silent_interval, delay_ms: the controller's "Silent INT" (k) and "Min Resp delay" (Td).
    silence_wait: keep Ts of silence before each query (leave on for RS485).
    echo: the adapter echoes what it sends (2-wire): verify and discard the echo.
    rs485: switch the port to kernel RS485 mode.
    trace: called with a dict (direction, time_s, bytes, hex, explanation) per frame.
    alarm_polarity: how the controllers report X4F ALARM: "active-high" (the manual:
      1 = alarm) or "active-low" (inverted, as some controllers do; `lec status` says
      when X4F and the alarm code disagree). bus.axis(id, alarm_polarity=...) per axis.
    """
    if isinstance(port, Twin):
        return port.connect(retries=retries, alarm_polarity=alarm_polarity)
    return _open_bus(_os.fspath(port), baud, retries=retries, timeout_margin_ms=timeout_margin_ms,
                     silent_interval=silent_interval, delay_ms=delay_ms,
                     silence_wait=silence_wait, echo=echo, rs485=rs485, trace=trace,
                     alarm_polarity=alarm_polarity)
