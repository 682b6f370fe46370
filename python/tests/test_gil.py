"""Long steps release the GIL: other Python threads run meanwhile."""

import threading
import time

import remembrane as rm
from conftest import SCENES


def test_step_releases_the_gil():
    sim = rm.Simulation(rm.Scene.load(SCENES / "red_blood_cell.ron"))
    sim.step(1)
    count = 0
    stop = False

    def spin():
        nonlocal count
        while not stop:
            count += 1

    worker = threading.Thread(target=spin)
    worker.start()
    # The spinning thread's rate while this thread sleeps (GIL free).
    time.sleep(0.05)
    c0, t0 = count, time.perf_counter()
    time.sleep(0.2)
    rate = (count - c0) / (time.perf_counter() - t0)
    # Its rate while this thread steps the engine. Holding the GIL would
    # stall it for the whole call.
    c1, t1 = count, time.perf_counter()
    sim.step(3000)
    elapsed = time.perf_counter() - t1
    during = count - c1
    stop = True
    worker.join()
    assert elapsed > 0.2, "the step was too short to tell"
    assert during > 0.3 * rate * elapsed, (during, rate, elapsed)
