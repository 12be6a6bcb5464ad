"""Camera kinds: each kind of camera one class, registered under the name a rig uses.

A rig's cameras are opened by the class of their kind (:data:`CAMERA_KINDS`, as
python-microscope names device classes in its configuration): on a real bench the
``kind`` of ``hardware.spectral_camera`` and ``hardware.guide_camera`` (``genicam``,
``dcam``: the adapters of :mod:`sassi_bench.rig.hardware`, which import their vendor SDKs
only when a camera opens), on the virtual bench ``bench`` (:mod:`sassi_bench.rig.sim`).
A kind is a :class:`~sassi_bench.rig.base.CameraBase` subclass with a class method
``open(name, options, context)`` (the camera's name, ``"spectral"`` or ``"guide"``; its
section's options; what its backend hands every camera: the SLM pattern and light of
each frame on a real bench, the bench itself on the virtual one) and ``hardware`` true
when a rig's ``hardware`` section may name it.

A new kind is one module in :mod:`sassi_bench.rig.hardware` registering its class with
``@CAMERA_KINDS.register("<name>")``, plus its contract tests
(``tests/rig/test_contract.py``); options of its own also go into the ``hw_camera``
section of ``rig/rig.schema.json``.
"""

from __future__ import annotations

from typing import Any

from sassi_bench._shared.registry import Registry

__all__ = ["CAMERA_KINDS", "hardware_camera_kinds"]

#: Camera kinds by name.
CAMERA_KINDS: Registry[Any] = Registry(
    "camera kind", "sassi_bench.rig.hardware", "sassi_bench.rig.sim"
)


def hardware_camera_kinds() -> tuple[str, ...]:
    """The camera kinds a rig's ``hardware`` section may name.

    Examples
    --------
    >>> hardware_camera_kinds()
    ('dcam', 'genicam')
    """
    return tuple(sorted(name for name, cls in CAMERA_KINDS.items() if cls.hardware))
