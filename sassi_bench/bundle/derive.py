"""Publishing a bundle derived from another: the parent's models plus one stage's result.

A stage that refines a published calibration (the radiometric response, the guide
homography, a validation) publishes a *derived* bundle: the parent's models with some
replaced, and the parent's record carried along, so the child never claims more than
its parent earned:

- every quality check of the parent is carried, except those of the same stage, which
  the new measurement supersedes; the stage's own checks are named ``<stage>.<check>``;
- a parent that failed its checks (published with an override) is refused unless the
  child is published with ``allow_failed`` too, and then the child is marked failed as
  well (its carried checks fail);
- the parent's procedure, input sessions and other quality sections are kept, and
  ``quality.derived_from`` names the parent (rig, version, folder, status, manifest hash).

Examples
--------
>>> from sassi_bench.bundle import QualityCheck, load
>>> parent = load(rig="sim")
>>> response = np.ones(parent.wavelengths.size)  # a measured response, one value per bin
>>> session_input = {"id": "response-1", "sha256": "cd" * 32}  # the session it came from
>>> path = publish_derived(parent, stage="response", rig=parent.manifest["rig"],
...     models={"response": response}, checks=[QualityCheck.at_most("spread", 0.02, 0.1, "1")],
...     procedure={"response": {"light": "halogen"}}, inputs=[session_input], data="derived")
>>> path.name
'v0001'
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from sassi_bench.bundle.bundle import CalibrationBundle
from sassi_bench.bundle.errors import BundleError, BundleQualityError
from sassi_bench.bundle.integrity import MANIFEST_NAME, sha256_bytes
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.bundle.quality import QualityCheck
from sassi_bench.bundle.writer import ReportSource, publish
from sassi_bench.errors import step_error

__all__ = ["check_parent", "derived_checks", "publish_derived", "stage_checks"]

STEP = "bundle publish"
_STAGE = re.compile(r"^[a-z][a-z0-9_]{0,31}$")


def _check_stage(stage: str) -> str:
    if not isinstance(stage, str) or not _STAGE.match(stage):
        raise BundleError(
            step_error(
                STEP,
                f"stage name {stage!r} is not a short lowercase identifier",
                "name the stage like 'response' or 'guide'",
            )
        )
    return stage


def stage_checks(stage: str, checks: Iterable[QualityCheck]) -> list[QualityCheck]:
    """The checks of one stage, named ``<stage>.<check>`` (a name that has it is kept).

    Examples
    --------
    >>> [c.name for c in stage_checks("guide", [QualityCheck.at_most("rms", 0.2, 1, "px")])]
    ['guide.rms']
    """
    prefix = _check_stage(stage) + "."
    return [
        c if c.name.startswith(prefix) else dataclasses.replace(c, name=prefix + c.name)
        for c in checks
    ]


def derived_checks(
    parent: CalibrationBundle, stage: str, checks: Iterable[QualityCheck]
) -> list[QualityCheck]:
    """The checks a bundle derived from ``parent`` by ``stage`` carries.

    Every check of the parent except the stage's own earlier ones (superseded), then the
    stage's checks named ``<stage>.<check>``.

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck, load
    >>> parent = load(rig="sim")
    >>> guide_checks = [QualityCheck.at_least("inliers", 120, 50, "1")]
    >>> [c.name for c in derived_checks(parent, "guide", guide_checks)]
    ['dispersion_rms', 'homography_rms', 'macbeth_psnr', 'guide.inliers']
    """
    prefix = _check_stage(stage) + "."
    carried = [
        QualityCheck(**dict(thaw(c)))
        for c in parent.manifest["quality"]["checks"]
        if not str(c["name"]).startswith(prefix)
    ]
    return carried + stage_checks(stage, checks)


def _parent_identity(parent: CalibrationBundle) -> dict[str, Any]:
    raw = (Path(parent.path) / MANIFEST_NAME).read_bytes()
    return {
        "rig_name": parent.rig_name,
        "version": parent.version,
        "path": str(Path(parent.path).resolve()),
        "created": parent.created,
        "passed": parent.passed,
        "override": parent.override,
        "manifest_sha256": sha256_bytes(raw),
    }


def check_parent(parent: CalibrationBundle, stage: str, *, allow_failed: bool = False) -> None:
    """Refuse to derive from a parent that failed its checks, unless ``allow_failed``.

    Stages call it before they capture anything, so no scan is spent on a bundle that
    could not be published.

    Raises
    ------
    BundleQualityError
        If ``parent`` was published with an override and ``allow_failed`` is False.

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> check_parent(load(rig="sim"), "guide")  # passed: nothing to say
    """
    if parent.passed or allow_failed:
        return
    failed = [c for c in parent.manifest["quality"]["checks"] if not c["passed"]]
    listed = ", ".join(str(c["name"]) for c in failed) or "marked failed"
    raise BundleQualityError(
        step_error(
            f"{STEP} ({stage})",
            f"the parent bundle {parent.rig_name}/{parent.version} failed its quality checks "
            f"({listed}) and was published with an override; a bundle derived from it "
            "would carry those failures",
            "calibrate again to get a passing parent, or run again with --allow-failed "
            "(from Python: allow_failed=True) to publish this bundle marked as failed",
        )
    )


def _merged_inputs(
    parent: CalibrationBundle, inputs: Iterable[Mapping[str, Any]]
) -> list[dict[str, Any]]:
    merged: dict[str, dict[str, Any]] = {}
    for item in [*thaw(parent.manifest["inputs"]), *(dict(i) for i in inputs)]:
        merged[str(item["id"])] = dict(item)  # a resumed session: its latest hash
    return list(merged.values())


def publish_derived(
    parent: CalibrationBundle,
    *,
    stage: str,
    rig: Mapping[str, Any] | Any,
    models: Mapping[str, Any] | None = None,
    checks: Iterable[QualityCheck] = (),
    residuals: Mapping[str, Any] | None = None,
    procedure: Mapping[str, Any] | None = None,
    inputs: Iterable[Mapping[str, Any]] = (),
    reports: Mapping[str, ReportSource] | None = None,
    allow_failed: bool = False,
    data: str | os.PathLike[str] | None = None,
) -> Path:
    """Publish ``parent``'s models with some replaced, carrying the parent's record.

    Parameters
    ----------
    parent
        The verified bundle this one derives from.
    stage
        Short name of the deriving stage (``"response"``, ``"guide"``...): prefixes its
        checks and keys its residuals.
    rig
        The rig description the stage ran on.
    models
        Model fields to replace (keyword arguments of
        :class:`~sassi_bench.bundle.CalibrationModels`, e.g. ``{"response": array}``).
    checks
        The stage's quality checks (named ``<stage>.<check>`` in the bundle).
    residuals
        The stage's residuals, kept as ``quality.residuals[<stage>]``.
    procedure
        Entries added to the parent's procedure (e.g. ``{"guide_registration": {...}}``).
    inputs
        The stage's raw sessions (``{"id", "sha256", ...}``), added to the parent's.
    reports
        The child's report files (see :func:`~sassi_bench.bundle.publish`); the parent's
        are not carried.
    allow_failed
        Publish even if a check failed, carried or new; required again when the parent
        itself was published with an override.
    data
        Data root the child is published under.

    Returns
    -------
    pathlib.Path
        The new bundle folder.

    Raises
    ------
    BundleQualityError
        If the parent failed its checks, or a check of the stage failed, and
        ``allow_failed`` is False (nothing is written).

    Examples
    --------
    See the module docstring.
    """
    check_parent(parent, stage, allow_failed=allow_failed)
    quality = dict(thaw(parent.manifest["quality"]))
    quality["checks"] = derived_checks(parent, stage, checks)
    carried_residuals = dict(quality.get("residuals", {}))
    if residuals is not None:
        carried_residuals[stage] = dict(residuals)
    quality["residuals"] = carried_residuals
    quality["derived_from"] = _parent_identity(parent)
    return publish(
        dataclasses.replace(parent.models, **dict(models or {})),
        rig=rig,
        quality=quality,
        procedure={**thaw(parent.manifest["procedure"]), **dict(procedure or {})},
        inputs=_merged_inputs(parent, inputs),
        reports=reports,
        allow_failed=allow_failed,
        data=data,
    )
