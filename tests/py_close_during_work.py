"""Closing a handle while a library call runs on it (issue 30, 4.3): Envmap.close() from the
call's progress callback, or from another thread, freed the map under the running call: a
use after free (ASan) or SIGSEGV (the map's pixels, mmapped, unmapped). Now close() waits for
another thread's call to return, and refuses (ValueError) during one of its own thread's; a
ValueError raised in the callback cancels that call (envlight.Error ENVL_ERR_CANCELLED), one the
callback catches does not. Each case runs in a child process, so that a crash is a failure of
its own, not of pytest."""
import os
import subprocess
import sys
import textwrap

import pytest

SHIM = os.path.join(os.environ.get("ENVL_SOURCE_DIR", os.path.join(os.path.dirname(__file__),
                                                                   "..")), "py_shim")

pytestmark = pytest.mark.skipif(not os.environ.get("ENVLIGHT_LIBRARY"),
                                reason="needs ENVLIGHT_LIBRARY (run through ctest)")

# a 2048 x 1024 sky: its 24 MB of pixels are mmapped, so a call reading them after a free
# faults at once
PRELUDE = """
import threading, time
import envlight
env = envlight.sky(width=2048)
"""


def child(body):
    """Runs PRELUDE + body in a fresh interpreter: (exit status, stdout, stderr)."""
    code = PRELUDE + textwrap.dedent(body)
    env = dict(os.environ, PYTHONPATH=SHIM + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600, env=env)
    return r.returncode, r.stdout, r.stderr


def test_close_from_the_progress_callback_is_refused():
    rc, out, err = child("""
        said = []
        def progress(fraction, stage):
            try:
                env.close()
            except ValueError as e:
                said.append(str(e))
            return False
        with envlight.progress(progress):
            with env.prefilter(chain=True, measure=True, width=256) as p:
                levels = len(p.levels)
        print(levels, len(said) > 0, env.closed)
        print(said[0])
        env.close()
        print(env.closed)
    """)
    assert rc == 0, err
    lines = out.splitlines()
    assert lines[0] == "6 True False", out
    assert "Envmap.close: a call on it is running in this thread" in lines[1], out
    assert lines[2] == "True", out


def test_close_raised_in_the_callback_cancels_the_call():
    rc, out, err = child("""
        def progress(fraction, stage):
            env.close()  # raises: the callback's exception cancels the call
        try:
            with envlight.progress(progress):
                env.lights(4)
            print("not cancelled")
        except envlight.Error as e:
            print(e.name, env.closed)
        print(env.info()["width"])
    """)
    assert rc == 0, err
    assert out.splitlines() == ["ENVL_ERR_CANCELLED False", "2048"], out


def test_close_from_another_thread_waits_for_the_call():
    """close() returns only when the call on the object has ended: no progress callback of the
    call comes after it (the call's result is set by its thread a moment later: not a sign)."""
    rc, out, err = child("""
        started, closed, result, late = threading.Event(), threading.Event(), {}, []
        def work():
            def progress(fraction, stage):
                started.set()
                if closed.is_set():
                    late.append(fraction)
                return False
            with envlight.progress(progress):
                with env.prefilter(chain=True, irradiance=True, measure=True) as p:
                    result["levels"] = len(p.levels)
                    result["first"] = float(p.levels[1]["rgb"][0][0][0])
        t = threading.Thread(target=work)
        t.start()
        started.wait()
        time.sleep(0.2)           # well inside the computation
        env.close()               # waits for it
        closed.set()
        t.join()
        print(result["levels"], not late, env.closed, result["first"] > 0)
        try:
            env.info()
        except ValueError as e:
            print(e)
    """)
    assert rc == 0, (rc, err[-2000:])
    assert out.splitlines() == ["6 True True True", "Envmap is closed"], out


def test_results_close_alike():
    """Products.export's progress callback closing the products: refused, not freed."""
    rc, out, err = child("""
        import tempfile
        with env.prefilter(roughness=[0.5], width=64) as p:
            said = []
            def progress(fraction, stage):
                try:
                    p.close()
                except ValueError as e:
                    said.append(type(e).__name__)
                return False
            with envlight.progress(progress):
                p.export(tempfile.mkdtemp(), format="pfm")
            print(bool(said), p.closed)
        print(p.closed)
    """)
    assert rc == 0, err
    assert out.splitlines() == ["True False", "True"], out
