"""The package's compiled kernels built into numba's on-disk cache by a second process while
the test session starts (started by tests/conftest.py, only when the cache lacks some).

On an empty cache (CI, a fresh clone) the kernels took 90 s of compile in the test process,
one after the other, while the machine's second core idled: the frictional kernel 35 s,
the lane partition 20 s, Lemke's impact kernel 15 s, the stiff and classic Runge-Kutta
peaks 14 s, the one-item partition 7 s, the effective masses 2 s. This process compiles
them meanwhile, from the frictional kernel on (the test process compiles the first two
itself, in its first tests); the test process loads from the cache what is there by then
and compiles the rest itself, as before (a kernel half built here is built there too:
numba has no lock across processes).

Run as a script, it writes which helper functions it compiled and for which signatures
(``python tests/prewarm.py OUT.json``): tests/test_kernels_jit.py checks those as it
checks the ones its own process compiled.
"""

from __future__ import annotations

import json
import sys


def compile_helpers() -> None:
    """One call of each path to the kernels whose helpers are checked: the frictional
    and impact kernels, the one-item partition, the effective masses of a lane batch,
    ``T_c_at``'s kernel and the height-field wheel contact."""
    import numpy as np

    import roverimpact as ri
    from roverimpact import energy
    from roverimpact.frictional import frictional_impact
    from roverimpact.models.terrain import HeightField, wheel_ground_contact
    from roverimpact.scenario import ImpactSetup

    M = np.diag([2.0, 3.0, 4.0])
    ri.partition(M, [0.0, 1.0, 0.0], [0.2, -1.0, 0.1])
    ri.active_set(M, [0.0, -1.0, -1.0], [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    frictional_impact(M, [0.2, -1.0, 0.1], [[0.0, 1.0, 0.0]], [[[1.0, 0.0, 0.0]]], 0.5)
    k = energy.LANES_MIN_BATCH  # a batch that takes the effective-mass kernel
    m_eff = energy.row_masses(np.broadcast_to(M, (k, 3, 3)), np.tile([0.0, 1.0, 1.0], (k, 1)),
                              [0.0, 0.0, 1.0])[0]
    np.testing.assert_allclose(m_eff, 3.0, rtol=1e-6)
    setup = ImpactSetup.from_scenario(ri.Scenario.model_validate({
        "model": {"name": "rover2d"}, "velocity": {"u": 0.5},
        "obstacle": {"wheel": "front", "beta_deg": 45.0}}))
    assert setup.T_c_at(setup.q) > 0.0  # T_c_at's kernel calls partition_factored too
    hf = HeightField(np.random.default_rng(0).normal(size=(8, 8)) * 0.01, 0.5)
    assert np.isfinite(wheel_ground_contact(hf, [1.5, 1.5, 0.3], (0, 1, 0), 0.2).gap)


def compiled_helpers() -> dict[str, list[str]]:
    """The helper functions of the kernel modules this process compiled: name -> the
    signatures (as text, ``Literal[...]`` marking a literal argument type)."""
    from numba.core.registry import CPUDispatcher

    from roverimpact._kernels import friction, lemke, partition, terrain

    helpers = {id(d): d for mod in (friction, lemke, partition, terrain)
               for d in vars(mod).values() if isinstance(d, CPUDispatcher)}.values()
    return {d.py_func.__name__: [str(s) for s in d.signatures] for d in helpers
            if d.signatures}


def kernels():
    """Every :class:`~roverimpact._kernels._jit.Kernel` of the package."""
    from roverimpact._kernels.bootstrap import agreement_kernel
    from roverimpact._kernels.friction import friction_kernel
    from roverimpact._kernels.lanes_jit import LANES
    from roverimpact._kernels.lemke import impact_kernel
    from roverimpact._kernels.masses import masses_kernel
    from roverimpact._kernels.partition import partition_kernel
    from roverimpact._kernels.reduced import rk4_peaks, stiff_peaks

    return (partition_kernel, impact_kernel, friction_kernel, masses_kernel, LANES,
            rk4_peaks, stiff_peaks, agreement_kernel)


def main(out: str) -> None:
    # the test process compiles the one-item partition and the impact kernel itself, in
    # its first tests: this one starts with what it needs next (the frictional kernel,
    # in tests/test_activeset.py), then the traverse's, then the rest of the calls
    for k in kernels()[2:]:
        k.get()
    compile_helpers()
    with open(out, "w", encoding="utf-8") as f:
        json.dump(compiled_helpers(), f)


if __name__ == "__main__":
    main(sys.argv[1])
