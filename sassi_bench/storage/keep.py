"""What a finished calibration chain keeps of its raw frames (the procedure's ``keep``).

A chain keeps every frame while it runs, so an interrupted run resumes where it stopped.
Once its bundle is published, the frames only serve an audit, and they are most of the
run's disk (at the prototype's scale, 500 of the 900 frames are the Macbeth scan's).
``keep`` says what stays:

* ``all``: every frame;
* ``audit``: the frames the spectral models are fitted from (the grey levels and the
  structured-light sweeps), from which the whole spectral stage can be re-derived; the
  scans (response, guide, Macbeth) are assembled into the bundle's models and report;
* ``records``: no frame.

A session whose frames go keeps its record (``session.json`` and ``events.jsonl``, with
every frame's SHA-256), so the bundle's inputs still verify, and gets a
``frames-dropped.json`` note saying when, why and how many bytes.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench.acquire.session.frames import FRAMES_DIR
from sassi_bench.storage.inventory import folder_size, format_size

__all__ = ["DROPPED_NOTE", "KEEP_POLICIES", "KeptFrames", "keep_frames"]

KEEP_POLICIES = ("all", "audit", "records")
#: The note left in a session folder whose frames were removed.
DROPPED_NOTE = "frames-dropped.json"
# Session id suffixes (after the chain's base id) kept by ``audit``.
_AUDIT = ("-spectral-grey", "-spectral-sweep")


@dataclass(frozen=True)
class KeptFrames:
    """Raw frames a chain kept and dropped: session id -> bytes of frames."""

    policy: str
    kept: dict[str, int]
    dropped: dict[str, int]

    def lines(self) -> list[str]:
        """One line for what was kept and one for what was dropped.

        Examples
        --------
        >>> KeptFrames("audit", {"a-spectral-sweep": 2**30}, {"a-macbeth-chart": 2**31}).lines()
        ['kept (keep: audit): a-spectral-sweep 1.0 GB', 'dropped: a-macbeth-chart 2.0 GB']
        """
        kept = ", ".join(f"{s} {format_size(n)}" for s, n in self.kept.items()) or "no frames"
        lines = [f"kept (keep: {self.policy}): {kept}"]
        if self.dropped:
            lines.append(
                "dropped: " + ", ".join(f"{s} {format_size(n)}" for s, n in self.dropped.items())
            )
        return lines


def keep_frames(staging: Path, base: str, policy: str) -> KeptFrames:
    """Remove the frames ``policy`` does not keep from a published chain's sessions.

    Parameters
    ----------
    staging
        The chain's staging folder (its sessions are in ``staging/sessions``).
    base
        The chain's session id (its sessions are named ``<base>-<stage>...``).
    policy
        One of :data:`KEEP_POLICIES`.

    Returns
    -------
    KeptFrames

    Examples
    --------
    >>> import tempfile
    >>> staging = Path(tempfile.mkdtemp())
    >>> (staging / "sessions" / "run-macbeth-chart" / FRAMES_DIR).mkdir(parents=True)
    >>> keep_frames(staging, "run", "audit").dropped
    {'run-macbeth-chart': 0}
    """
    kept: dict[str, int] = {}
    dropped: dict[str, int] = {}
    sessions = staging / "sessions"
    folders = sorted(sessions.iterdir()) if sessions.is_dir() else []
    for folder in folders:
        frames = folder / FRAMES_DIR
        if not frames.is_dir():
            continue
        size, _ = folder_size(frames)
        audit = any(folder.name == base + suffix for suffix in _AUDIT)
        if policy == "all" or (policy == "audit" and audit):
            kept[folder.name] = size
            continue
        note = {
            "dropped": datetime.now(UTC).isoformat(timespec="seconds"),
            "why": f"the calibration chain's keep: {policy}, after its bundle was published",
            "bytes": size,
        }
        atomic_write_text(folder / DROPPED_NOTE, json.dumps(note, indent=2) + "\n", overwrite=True)
        shutil.rmtree(frames)
        dropped[folder.name] = size
    return KeptFrames(policy, kept, dropped)
