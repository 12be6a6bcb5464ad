"""Stand-ins for GenApi nodes and a harvesters acquirer, for exposure and trigger logic."""

from __future__ import annotations

from contextlib import contextmanager
from types import SimpleNamespace

import numpy as np


class FakeNode:
    """A GenApi node: ``value``, ``min``/``max`` for numbers, ``symbolics`` for enums."""

    def __init__(self, value, *, min=None, max=None, symbolics=None):
        self._value = value
        self.min, self.max = min, max
        self.symbolics = tuple(symbolics) if symbolics else None
        self.writes: list = []
        self.executed = 0

    @property
    def value(self):
        return self._value

    @value.setter
    def value(self, new):
        if self.symbolics is not None and new not in self.symbolics:
            raise ValueError(f"{new!r} not in {self.symbolics}")
        if self.min is not None and not self.min <= new <= self.max:
            raise ValueError(f"{new!r} out of range")
        self.writes.append(new)
        self._value = new

    def execute(self):
        self.executed += 1


class LayeredNodeMap:
    """Fake nodes first, then a real node map (features the producer lacks)."""

    def __init__(self, base=None, **nodes):
        self._base = base
        self._nodes = nodes

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        if name in self._nodes:
            return self._nodes[name]
        if self._base is None:
            raise AttributeError(name)
        return getattr(self._base, name)


def exposure_nodes(lo_us=10.0, hi_us=10e6, value_us=10000.0):
    return {
        "ExposureTime": FakeNode(value_us, min=lo_us, max=hi_us),
        "ExposureAuto": FakeNode("Continuous", symbolics=("Off", "Once", "Continuous")),
    }


def trigger_nodes():
    return {
        "TriggerMode": FakeNode("Off", symbolics=("Off", "On")),
        "TriggerSelector": FakeNode(
            "AcquisitionStart", symbolics=("AcquisitionStart", "FrameStart")
        ),
        "TriggerSource": FakeNode("Software", symbolics=("Software", "Line0", "Line2")),
        "TriggerActivation": FakeNode("FallingEdge", symbolics=("RisingEdge", "FallingEdge")),
        "TriggerSoftware": FakeNode(None),
    }


class FakeAcquirer:
    """Counts start/stop and hands out numbered Mono16 frames."""

    def __init__(self, node_map, height=4, width=6):
        self.remote_device = SimpleNamespace(node_map=node_map)
        self.height, self.width = height, width
        self.starts = self.stops = self.fetched = 0
        self.buffered = 0  # frames exposed before the next capture (SLM pulses)
        self.requeued = 0
        self.destroyed = False

    def start(self):
        self.starts += 1

    def stop(self):
        self.stops += 1

    @contextmanager
    def fetch(self, timeout):
        self.fetched += 1
        data = np.full(self.height * self.width, self.fetched, dtype=np.uint16)
        component = SimpleNamespace(data=data, width=self.width, height=self.height)
        yield SimpleNamespace(payload=SimpleNamespace(components=[component]))

    def try_fetch(self, timeout):
        if not self.buffered:
            return None
        self.buffered -= 1
        self.fetched += 1
        return SimpleNamespace(queue=self._requeue)

    def _requeue(self):
        self.requeued += 1

    def destroy(self):
        self.destroyed = True
