# Long references report progress to a callback and stop on Ctrl-C within a fraction of a second
# (issue 16: KeyboardInterrupt during reference_environment(..., spp=4096) used to wait for the
# whole call).
import _thread
import threading
import time

import numpy as np
import pytest

import penumbra

# 134 M samples at spp 4096: measured 2.7 M samples a second per core (the built-in scene and
# sky, 2 cores: 25 s), so even 16 cores would need 3 s and the interrupt lands inside the call.
LONG = dict(width=256, height=128, spp=4096)
INTERRUPT_AFTER_S = 0.3
# KeyboardInterrupt must arrive this soon after the interrupt: the library reports progress at
# least every 100 ms and workers stop after their current pixel, and the bindings look for
# Ctrl-C at every report.
BOUND_S = 1.5


def run_interrupted(call):
    """Runs call() with a simulated Ctrl-C (as SIGINT does) INTERRUPT_AFTER_S into it. Returns
    (how it ended, seconds from the interrupt to KeyboardInterrupt)."""
    sent = []

    def interrupt():
        sent.append(time.monotonic())
        _thread.interrupt_main()

    timer = threading.Timer(INTERRUPT_AFTER_S, interrupt)
    outcome = "not started"
    try:
        timer.start()
        outcome = "running"
        call()
        outcome = "finished before the interrupt"
        timer.join()
        time.sleep(0.5)  # a late KeyboardInterrupt lands here, not in pytest
    except KeyboardInterrupt:
        caught = time.monotonic()
        timer.join()
        return outcome, caught - sent[0]
    finally:
        timer.cancel()
    return outcome, None


@pytest.mark.parametrize("with_callback", [False, True])
def test_ctrl_c_stops_the_reference(scene, camera, env, with_callback):
    fractions = []
    options = penumbra.ReferenceOptions(**LONG)
    progress = fractions.append if with_callback else None
    outcome, delay = run_interrupted(
        lambda: penumbra.reference_environment(scene, camera, env, options, progress=progress))
    assert outcome == "running", outcome  # KeyboardInterrupt came out of the call itself
    assert delay is not None and delay < BOUND_S, delay
    if with_callback:
        assert fractions and all(0 <= f < 1 for f in fractions)
        assert all(a < b for a, b in zip(fractions, fractions[1:]))  # each fraction once
    # The workers were stopped and joined: the next call runs normally.
    img = penumbra.reference_environment(scene, camera, env,
                                         penumbra.ReferenceOptions(width=8, height=4, spp=2))
    assert img.shape == (4, 8, 4) and np.isfinite(img).all()


def test_progress_reaches_the_callback_and_its_errors_stop_the_reference(scene, camera, lights,
                                                                         env):
    fractions = []
    options = penumbra.ReferenceOptions(width=32, height=16, spp=16, threads=2)
    img = penumbra.reference_lights(scene, camera, lights, env, options, progress=fractions.append)
    assert img.shape == (16, 32, 4)
    # The library reports 0 before any work and 1 once at the end (reference.hpp); the module
    # passes each fraction on once, in increasing order.
    assert fractions and fractions[0] == 0 and fractions[-1] == 1
    assert all(0 <= f <= 1 for f in fractions)
    assert all(a < b for a, b in zip(fractions, fractions[1:]))
    # Same pixels with and without a callback.
    assert np.array_equal(img, penumbra.reference_lights(scene, camera, lights, env, options))

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop(f"stopped at {fraction}")

    started = time.monotonic()
    with pytest.raises(Stop, match="stopped at"):
        penumbra.reference_environment(scene, camera, env, penumbra.ReferenceOptions(**LONG),
                                       progress=stop)
    assert time.monotonic() - started < 1 + BOUND_S
    with pytest.raises(TypeError):
        penumbra.reference_lights(scene, camera, lights, env, options, progress=42)
