"""Stopping a render: Ctrl-C raises KeyboardInterrupt within a moment and leaves no file (or
temporary) behind; an exception in the progress callback stops the render the same way."""

import signal
import subprocess
import sys
import textwrap
import time

import pytest

import aleph

# The child raises KeyboardInterrupt on SIGINT whatever it inherits: a shell without job control
# starts background commands with SIGINT ignored, and Python then installs no handler (a CI
# script run in the background failed this test that way, the render running on for minutes).
SCRIPT = textwrap.dedent(
    """
    import signal, sys, aleph
    signal.signal(signal.SIGINT, signal.default_int_handler)
    started = False
    def progress(p):
        global started
        if not started and p.total_samples > 0:
            started = True
            print("started", flush=True)
    aleph.render(sys.argv[1], spp=4000, resolution=(256, 256), output=sys.argv[2],
                 progress=progress)
    print("finished", flush=True)
    """
)


def test_ctrl_c_stops_cleanly(tmp_path, cornell):
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-c", SCRIPT, str(cornell), str(out / "still")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout.readline().strip() == "started"
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    stopped_after = time.monotonic() - t0
    assert proc.returncode != 0
    assert "KeyboardInterrupt" in err
    assert "finished" not in err
    # A render of 4000 spp at 256² would take minutes; it stopped within a pass's row of pixels.
    assert stopped_after < 10, stopped_after
    assert list(out.iterdir()) == []


class Stop(Exception):
    pass


def test_callback_exception_stops_the_render(cornell):
    calls = []

    def progress(p):
        calls.append(p)
        raise Stop("enough")

    t0 = time.monotonic()
    with pytest.raises(Stop, match="enough"):
        aleph.render(cornell, spp=4000, resolution=(128, 128), progress=progress)
    assert time.monotonic() - t0 < 10
    assert len(calls) == 1
    # The interpreter and the library are fine afterwards.
    r = aleph.render(cornell, spp=2, resolution=(16, 16))
    assert r.rgb.shape == (16, 16, 3)
