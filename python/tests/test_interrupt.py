"""Ctrl-C (SIGINT) stops a run or a step cleanly."""

import signal
import subprocess
import sys
import textwrap
import time

from conftest import SCENES

RUN = textwrap.dedent(
    """
    import sys, remembrane as rm
    scene = rm.Scene.load(sys.argv[1], iterations=10**7)
    sim = rm.Simulation(scene, threads={threads})
    print("started", flush=True)
    {call}
    """
)


def interrupt(tmp_path, call, threads="None"):
    script = tmp_path / "long.py"
    script.write_text(RUN.format(call=call, threads=threads))
    p = subprocess.Popen(
        [sys.executable, str(script), str(SCENES / "red_blood_cell.ron"), str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # A test run started in the background (`cmd &`, nohup) inherits
        # SIGINT ignored, and Python then installs no KeyboardInterrupt
        # handler: give the child the default disposition, as a terminal has.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert p.stdout.readline().strip() == "started"
    time.sleep(2.0)  # well into the run
    p.send_signal(signal.SIGINT)
    try:
        _, err = p.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        p.kill()
        raise AssertionError("the run did not stop on SIGINT")
    return p.returncode, err


def test_sigint_stops_a_run_and_leaves_it_incomplete(tmp_path):
    code, err = interrupt(tmp_path, "sim.run(out=sys.argv[2], progress=False)")
    assert code != 0
    assert "KeyboardInterrupt" in err
    assert (tmp_path / "out.incomplete" / "frames").is_dir()
    assert not (tmp_path / "out").exists()


def test_sigint_stops_a_run_on_its_own_thread_pool(tmp_path):
    code, err = interrupt(tmp_path, "sim.run(out=sys.argv[2], progress=False)", threads="2")
    assert code != 0 and "KeyboardInterrupt" in err
    assert (tmp_path / "out.incomplete").is_dir() and not (tmp_path / "out").exists()


def test_sigint_stops_step_and_the_state_stays_usable(tmp_path):
    call = textwrap.dedent(
        """
        try:
            sim.step(10**7)
        except KeyboardInterrupt:
            n = sim.iteration
            sim.step(1)
            assert sim.iteration == n + 1
            print("caught", n, file=sys.stderr)
            sys.exit(3)
        """
    )
    code, err = interrupt(tmp_path, call)
    assert code == 3, err
    assert "caught" in err


def test_sigint_inside_a_python_term_is_an_interrupt_not_a_blow_up(tmp_path):
    # Most of each tick is spent in the term, so the KeyboardInterrupt is
    # raised inside it; the run must still end as interrupted.
    call = textwrap.dedent(
        """
        import time, numpy as np
        def slow(x):
            time.sleep(0.002)
            return 0.0, np.zeros_like(x)
        sim = rm.Simulation(scene)
        sim.add_force_term("slow", slow)
        sim.run(out=sys.argv[2], progress=False)
        """
    )
    code, err = interrupt(tmp_path, call)
    assert code != 0 and "KeyboardInterrupt" in err, err
    assert (tmp_path / "out.incomplete").is_dir()
    assert not (tmp_path / "out").exists()
