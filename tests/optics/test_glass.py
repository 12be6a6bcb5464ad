import numpy as np
import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.optics.glass import GLASSES, get_glass, refractive_index

# Fraunhofer and laser lines (nm) and SCHOTT's catalog indices of N-BK7 (5 decimals).
N_BK7_CATALOG = {
    2325.42: 1.48921, 1529.582: 1.50091, 1060.0: 1.50669, 852.11: 1.50980,
    706.5188: 1.51289, 656.2725: 1.51432, 643.8469: 1.51472, 632.8: 1.51509,
    589.2938: 1.51673, 587.5618: 1.51680, 546.074: 1.51872, 486.1327: 1.52238,
    479.9914: 1.52283, 435.8343: 1.52668, 404.6561: 1.53024, 365.0146: 1.53627,
}  # fmt: skip
D_LINE, F_LINE, C_LINE = 587.5618, 486.1327, 656.2725


@pytest.mark.parametrize(("wavelength", "catalog"), list(N_BK7_CATALOG.items()))
def test_n_bk7_matches_catalog_at_many_lines(wavelength, catalog):
    assert refractive_index("N-BK7", wavelength) == pytest.approx(catalog, abs=1e-5)


@pytest.mark.parametrize("name", sorted(GLASSES))
def test_every_glass_matches_its_catalog_nd_and_abbe_number(name):
    glass = GLASSES[name]
    nd, nf, nc = glass.index([D_LINE, F_LINE, C_LINE])
    assert nd == pytest.approx(glass.nd, abs=1e-5)
    assert (nd - 1) / (nf - nc) == pytest.approx(glass.vd, abs=0.01)


def test_required_glasses_are_in_the_catalog():
    for name in ("N-BK7", "N-SF11", "F2", "SF10", "N-SF5"):
        assert get_glass(name.lower()).name == name


def test_index_is_vectorised_and_decreasing_in_the_visible():
    lam = np.linspace(390, 720, 50).reshape(5, 10)
    n = refractive_index("N-SF11", lam)
    assert n.shape == (5, 10)
    assert np.all(np.diff(n.ravel()) < 0)


def test_unknown_glass_names_the_key_and_the_choices():
    with pytest.raises(ConfigError, match=r"prism\.glass.*N-BK7"):
        get_glass("unobtainium")
