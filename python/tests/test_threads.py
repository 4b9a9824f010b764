"""One bus from several threads: requests take turns, transaction by
transaction; waits release the GIL."""

import threading
import time

import lec6
from conftest import wait_for


def test_status_polls_interleave_with_a_move(ready):
    seen = []
    done = threading.Event()

    def poll():
        while not done.is_set():
            seen.append(ready.status())

    t = threading.Thread(target=poll)
    t.start()
    try:
        r = ready.move(to=100.0, speed=400)
    finally:
        done.set()
        t.join()
    assert r.in_position and r.position_mm == 100.0
    moving = [s for s in seen if s.busy]
    assert len(moving) > 10, len(seen)  # the poller got turns while the move ran
    positions = [s.position_mm for s in moving]
    # BUSY rises at the start, before the carriage has moved: the first may read 0.00.
    assert positions == sorted(positions) and 0 <= positions[0] < positions[-1] <= 100.0


def test_many_threads_many_axes(twin_factory):
    t = twin_factory(ids=[1, 2, 3, 4])
    errors, counts = [], {}
    with t.connect() as bus:
        def work(axis_id):
            a = bus.axis(axis_id)
            try:
                for _ in range(200):
                    s = a.status()
                    assert not s.alarm and s.position_mm == 0.0
                    counts[axis_id] = counts.get(axis_id, 0) + 1
            except Exception as e:  # noqa: BLE001 - reported below
                errors.append(e)

        threads = [threading.Thread(target=work, args=(i,)) for i in (1, 2, 3, 4) * 2]
        for th in threads:
            th.start()
        for th in threads:
            th.join()
        stats = bus.stats()
    assert errors == [] and counts == {1: 400, 2: 400, 3: 400, 4: 400}
    assert stats["transactions"] == 2 * 8 * 200 and stats["retries"] == 0


def test_a_wait_releases_the_gil(ready):
    """Python code keeps running in another thread while a move waits."""
    ticks = []
    done = threading.Event()

    def count():
        while not done.is_set():
            ticks.append(time.monotonic())

    th = threading.Thread(target=count)
    th.start()
    try:
        ready.move(to=60.0, speed=300)
    finally:
        done.set()
        th.join()
    assert len(ticks) > 1000


def test_cancel_a_move_from_another_thread(ready):
    stop = threading.Event()
    th = threading.Thread(target=lambda: (wait_for(lambda: ready.status().position_mm > 5),
                                          stop.set()))
    th.start()
    try:
        ready.move(to=300.0, speed=200, cancel=stop.is_set)
        raise AssertionError("the move was not cancelled")
    except lec6.Cancelled:
        pass
    finally:
        th.join()
    s = wait_for(lambda: (lambda s: s if s.speed_mm_s == 0 else None)(ready.status()))
    assert s.position_mm < 290
