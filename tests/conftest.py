import os

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

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
    monkeypatch.setattr(_jit.Kernel, "get",
                        lambda self: plan.got.append(name(self)) or real_get(self))
    return plan
