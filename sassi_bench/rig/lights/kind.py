"""Light kinds: each kind of light a rig can have, one class registered under its name.

A rig's lights are named ``off``, ``laser:<nm>`` (one per line of ``lasers_nm``), ``led``,
``halogen``, ``fluorescent`` and ``lamp:<name>`` (one per ``wavelength_lamps`` entry).
Each name belongs to one kind (:data:`LIGHT_KINDS`), which knows:

* which lights a rig has of it (:meth:`LightKind.lights`), how a name of it is written
  (:meth:`LightKind.canonical`) and what an operator is asked to do to switch it on
  (:meth:`LightKind.instruction`);
* the data sets it names, checked when a rig loads (:meth:`LightKind.check`);
* its spectrum as photon samples (:meth:`LightKind.samples`) from its settings
  (:meth:`LightKind.settings`, as the description gives them; the virtual bench renders
  them as built instead), and whether it is coherent (a laser's speckle and power jitter
  on the virtual bench).

A new kind is one module in this package defining a :class:`LightKind` subclass
registered with ``@LIGHT_KINDS.register("<name>")``, plus its contract tests
(``tests/rig/test_lights.py``); a kind with settings of its own also adds them to the
``light`` section of ``rig/rig.schema.json``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.registry import Registry
from sassi_bench.optics.sources import SpectralSamples

__all__ = ["LIGHT_KINDS", "LightKind", "kind_of", "light_kinds", "light_names"]

#: Light kinds by name.
LIGHT_KINDS: Registry[LightKind] = Registry("light kind", "sassi_bench.rig.lights")


class LightKind:
    """One kind of light (see the module's note); subclasses fill in what differs."""

    #: Where its lights come in a rig's list of lights.
    order: ClassVar[int] = 100
    #: A laser's coherence: speckle and power jitter on the virtual bench, and its closed-SLM
    #: background rendered at the full spectral sampling.
    coherent: ClassVar[bool] = False

    def lights(self, lasers_nm: tuple[float, ...], lamps: tuple[str, ...]) -> tuple[str, ...]:
        """The lights of this kind a rig with these laser lines and lamps has."""
        raise NotImplementedError

    def owns(self, light: str) -> bool:
        """Whether ``light`` (lower case) is a light of this kind."""
        raise NotImplementedError

    def canonical(self, light: str) -> str:
        """``light`` (lower case) as the rig's list writes it, before the case is matched."""
        return light

    def instruction(self, light: str) -> str:
        """What an operator at a real bench is asked to do to switch ``light`` on."""
        return f"Switch on the {light} only"

    def check(self, desc: Any) -> None:
        """Refuse a description whose settings of this kind name data that does not exist."""

    def settings(self, light: str, desc: Any) -> dict[str, Any]:
        """The light's settings as the rig's description gives them."""
        return {}

    def samples(
        self, light: str, grid_nm: NDArray[np.float64], settings: Mapping[str, Any]
    ) -> SpectralSamples:
        """The light's spectrum as photon samples, from its ``settings``."""
        raise NotImplementedError


def light_kinds() -> list[LightKind]:
    """One instance of every registered kind, in the order a rig lists their lights.

    Examples
    --------
    >>> [type(kind).__name__ for kind in light_kinds()]  # doctest: +NORMALIZE_WHITESPACE
    ['OffLight', 'Laser', 'Led', 'Halogen', 'Fluorescent', 'Lamp']
    """
    return sorted((cls() for _, cls in LIGHT_KINDS.items()), key=lambda kind: kind.order)


def light_names(lasers_nm: tuple[float, ...], lamps: tuple[str, ...] = ()) -> tuple[str, ...]:
    """The light names of a rig with these laser lines and wavelength lamps.

    Parameters
    ----------
    lasers_nm
        The laser labels, nm.
    lamps
        ``wavelength_lamps`` entries (shipped lamp names or CSV paths).

    Examples
    --------
    >>> light_names((450.0, 532.5))
    ('off', 'laser:450', 'laser:532.5', 'led', 'halogen', 'fluorescent')
    >>> light_names((450.0,), ("hgar", "lab/Kr.csv"))[-2:]
    ('lamp:HgAr', 'lamp:Kr')
    """
    return tuple(name for kind in light_kinds() for name in kind.lights(lasers_nm, lamps))


def kind_of(light: str) -> LightKind:
    """The kind of light ``light`` (any case).

    Raises
    ------
    KeyError
        For a name no kind owns.

    Examples
    --------
    >>> type(kind_of("laser:532")).__name__, kind_of("laser:532").coherent
    ('Laser', True)
    """
    key = str(light).strip().lower()
    for kind in light_kinds():
        if kind.owns(key):
            return kind
    raise KeyError(light)
