import os

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")
# kernels always compiled (or loaded from numba's cache), never their Python code for small
# work while the cache lacks them: results that do not depend on the cache's state
# (tests/test_kernel_python.py runs the Python code on purpose)
os.environ.setdefault("ROVERIMPACT_KERNELS", "compiled")

# the same examples on every run (a red CI names a defect, not a lucky draw);
# HYPOTHESIS_PROFILE=explore draws fresh examples to hunt for new failures
settings.register_profile("repeatable", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)


@pytest.fixture
def compile_plan(monkeypatch):
    """A command's compile plan, recorded instead of run in a second process: ``sent``
    (kernels sent to the background process) and ``got`` (kernels asked for in this one,
    in order), each by the attribute its ``Kernel.home`` names."""
    from types import SimpleNamespace

    from roverimpact._kernels import _jit

    plan = SimpleNamespace(sent=[], got=[])

    def name(k):
        return k.home.split(":")[1]

    monkeypatch.setattr(_jit, "compile_in_background",
                        lambda *ks: plan.sent.extend(map(name, ks)) or [])
    real_get = _jit.Kernel.get
    monkeypatch.setattr(_jit.Kernel, "get", lambda self, items=None:
                        plan.got.append(name(self)) or real_get(self, items))
    return plan


# --- numba's cache filled by a second process while the session starts (tests/prewarm.py)
def _start_prewarm():
    """The prewarm process and the file it writes, or None: switched off
    (``ROVERIMPACT_TEST_PREWARM=0``), one core, no cache, or every kernel cached."""
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    if os.environ.get("ROVERIMPACT_TEST_PREWARM", "1") == "0" or (os.cpu_count() or 1) < 2:
        return None
    from roverimpact._kernels._jit import NJIT_OPTIONS

    from .prewarm import kernels

    if not NJIT_OPTIONS["cache"] or all(k.cached() for k in kernels()):
        return None
    out = Path(tempfile.mkdtemp(prefix="roverimpact-prewarm-")) / "helpers.json"
    src = str(Path(kernels()[0].py_func.__code__.co_filename).resolve().parents[2])
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (src, env.get("PYTHONPATH")) if p)
    proc = subprocess.Popen([sys.executable, str(Path(__file__).with_name("prewarm.py")),
                             str(out)], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=env)
    return proc, out


_PREWARM = _start_prewarm()


def pytest_unconfigure(config):
    """A prewarm still running when the session ends (a short run) is stopped."""
    if _PREWARM is None:
        return
    import shutil

    if _PREWARM[0].poll() is None:
        _PREWARM[0].kill()
        _PREWARM[0].wait()
    shutil.rmtree(_PREWARM[1].parent, ignore_errors=True)


@pytest.fixture(scope="session")
def prewarm_helpers():
    """The helpers the prewarm process compiled (name -> signatures), waiting for it; an
    empty dict when it did not run (a warm cache) or failed."""
    import json

    if _PREWARM is None:
        return {}
    proc, out = _PREWARM
    proc.wait(timeout=600)
    return json.loads(out.read_text()) if proc.returncode == 0 and out.is_file() else {}
