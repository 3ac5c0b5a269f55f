"""Contact-law objects: formulas at sample points, registry, parameter checks."""

import math

import numpy as np
import pytest

from roverimpact import InputError
from roverimpact.contact import LAWS, HuntCrossleyFamily, KelvinVoigt, get_law

NAMES = [
    "kelvin-voigt", "hertz", "hunt-crossley", "lankarani-nikravesh", "flores", "gonthier",
    "herbert-mcwhannell", "lee-wang", "zhiying-qishao", "carvalho-martins",
]

# z = chi v_i as printed in the cited papers / reviews, written out independently here.
Z_OF_E = {
    "hunt-crossley": lambda e: 3 * (1 - e) / 2,
    "lankarani-nikravesh": lambda e: 3 * (1 - e**2) / 4,
    "herbert-mcwhannell": lambda e: 6 * (1 - e) / ((2 * e - 1) ** 2 + 3),
    "lee-wang": lambda e: 3 * (1 - e) / 4,
    "gonthier": lambda e: (1 - e**2) / e,
    "flores": lambda e: 8 * (1 - e) / (5 * e),
    "zhiying-qishao": lambda e: 3 * (1 - e**2) * math.exp(2 * (1 - e)) / 4,
    "carvalho-martins": lambda e: 3 * (1 - e) * (11 - e) / (2 * (1 + 9 * e)),
}


def test_registry_names():
    assert sorted(LAWS) == sorted(NAMES)
    for name, cls in LAWS.items():
        assert cls.name == name and cls.reference and cls.equation


@pytest.mark.parametrize("name", sorted(Z_OF_E))
def test_hunt_crossley_family_force(name):
    k, e, n, v_i = 2.0e6, 0.6, 1.3, 0.7
    law = get_law(name, k=k, e=e, n=n)
    assert isinstance(law, HuntCrossleyFamily)
    assert (law.k, law.e, law.n) == (k, e, n)
    delta = np.array([1e-3, 2e-4, 0.0, -1e-3])
    ddot = np.array([0.3, -0.2, 0.5, 0.5])
    chi = Z_OF_E[name](e) / v_i
    expected = [k * d**n * (1 + chi * dd) if d > 0 else 0.0
                for d, dd in zip(delta, ddot, strict=True)]
    np.testing.assert_allclose(law.force(delta, ddot, v_i), expected, rtol=1e-14)
    # e = 1 (where allowed) reduces to Hertz
    assert get_law(name, k=k, e=1.0).z == 0.0


def test_hertz_and_kelvin_voigt_force():
    hz = get_law("hertz", k=3e7, n=1.5)
    np.testing.assert_allclose(hz.force(4e-4, 1.0, 1.0), 3e7 * 4e-4**1.5)
    kv = get_law("kelvin-voigt", k=1e5, c=50.0)
    np.testing.assert_allclose(kv.force([1e-3, 1e-3, -1e-3], [0.1, -1.0, 0.1]),
                               [100 + 5, 100 - 50, 0.0])
    # c from e and m: zeta = -ln e / sqrt(pi^2 + ln^2 e), c = 2 zeta sqrt(k m)
    kv2 = KelvinVoigt.from_restitution(1e5, 0.5, 3.0)
    zeta = math.log(2) / math.sqrt(math.pi**2 + math.log(2) ** 2)
    assert kv2.c == pytest.approx(2 * zeta * math.sqrt(3e5), rel=1e-14)
    assert kv2.n == 1.0 and kv2.e == 0.5


@pytest.mark.parametrize(
    ("name", "kw", "match"),
    [
        ("hunt-crossley", {"k": 0.0, "e": 0.5}, "k"),
        ("hunt-crossley", {"k": -1.0, "e": 0.5}, "k"),
        ("hunt-crossley", {"k": 1.0, "e": 1.2}, r"e must be in \[0, 1\]"),
        ("lankarani-nikravesh", {"k": 1.0, "e": -0.1}, "e must be in"),
        ("flores", {"k": 1.0, "e": 0.0}, r"undefined at e = 0"),
        ("gonthier", {"k": 1.0, "e": 0.0}, r"undefined at e = 0"),
        ("hunt-crossley", {"k": 1.0}, "needs the coefficient of restitution"),
        ("hertz", {"k": 1.0, "e": 0.5}, "elastic"),
        ("hertz", {"k": 1.0, "n": 0.0}, "n"),
        ("kelvin-voigt", {"k": 1.0, "e": 0.5}, "m_eff"),
        ("kelvin-voigt", {"k": 1.0, "c": -1.0}, "c"),
        ("nope", {"k": 1.0}, "unknown contact law"),
    ],
)
def test_bad_parameters(name, kw, match):
    with pytest.raises(InputError, match=match):
        get_law(name, **kw)


def test_name_normalisation():
    assert get_law("Hunt_Crossley", k=1.0, e=0.5).name == "hunt-crossley"
