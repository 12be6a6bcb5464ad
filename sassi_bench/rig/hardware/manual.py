"""What the operator does by hand on a real bench: switch lights, place targets."""

from __future__ import annotations

import sys
from collections.abc import Callable

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.base import LightSourceBase
from sassi_bench.rig.lights import kind_of, light_names

__all__ = ["ManualLight", "ask_operator"]


def ask_operator(message: str) -> None:
    """Print ``message`` and wait for Enter; refuse when nobody can answer.

    Examples
    --------
    Not run here (it needs the hardware)::

        ask_operator("Switch the light to led")
        # Switch the light to led, then press Enter
    """
    if not sys.stdin or not sys.stdin.isatty():
        raise DeviceError(
            step_error(
                "operator",
                f"{message!r} needs an operator, but standard input is not a terminal",
                "run the procedure from a terminal at the bench",
            )
        )
    input(f"{message}, then press Enter ")


class ManualLight(LightSourceBase):
    """Lights switched by the operator when asked.

    Parameters
    ----------
    lasers_nm
        The rig's laser lines; the names are those of the virtual bench
        (``"off"``, ``"laser:532"``, ``"led"``, ``"halogen"``, ``"fluorescent"``).
    lamps
        The rig's ``wavelength_lamps`` (lights ``"lamp:<name>"``).
    prompt
        Called with the instruction; defaults to :func:`ask_operator`.

    Examples
    --------
    >>> said = []
    >>> light = ManualLight((450, 532), ("HgAr",), prompt=said.append)
    >>> light.select("laser:532")
    >>> light.select("lamp:hgar")
    >>> said  # doctest: +NORMALIZE_WHITESPACE
    ['Switch on the 532 nm laser only',
     'Switch on the HgAr lamp only (let it warm up for 2 minutes)']
    """

    #: Switched by a person, not by the computer.
    by_hand = True

    def __init__(
        self,
        lasers_nm: tuple[float, ...],
        lamps: tuple[str, ...] = (),
        prompt: Callable[[str], None] | None = None,
    ) -> None:
        super().__init__(light_names(lasers_nm, lamps))
        self._prompt = prompt or ask_operator

    def _switch(self, name: str) -> None:
        if name == self.current:
            return
        self._prompt(kind_of(name).instruction(name))
