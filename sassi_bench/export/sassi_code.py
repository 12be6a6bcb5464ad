"""The SASSI authors' extraction, run from their own source, unmodified.

``sassi_upstream/`` holds ``modules/cassi.py`` and ``modules/filtering.py`` of
Image-Science-Lab-cmu/SASSI at commit :data:`UPSTREAM_COMMIT`, byte for byte (MIT
licence, ``sassi_upstream/LICENSE``; :data:`UPSTREAM_BLOBS` are their git blob ids, which
``tests/export/test_sassi_upstream.py`` checks). The export runs their ``get_cassi_cube``
to choose the row window ``vsize`` it writes (:mod:`sassi_bench.export.window_choice`),
so that the value is the one *their* extraction does best with.

``cassi.py`` cannot be imported as it stands: at its top it imports a GPU array library
(``cupy``), a compiled SLIC (``fast_slic``), its own Cython module (``cassi_cp``) and
scikit-learn, none of which the extraction uses. :func:`upstream_extraction` therefore
compiles only the function definitions the extraction needs (``get_cassi_cube``,
``get_cassi_img``, ``get_offset``, ``_get_cassi_cube``, and ``gaussdiskwin`` and
``gausswin2d`` from ``filtering.py``) from the files' own syntax trees, with their file
names and line numbers, and runs them against the modules their bodies name (numpy,
``scipy.signal``, ``scipy.interpolate``, OpenCV, PyTorch). Nothing in their bodies is
changed. ``get_cassi_img`` needs PyTorch (``grid_sample`` and ``conv2d``): it is the
optional extra ``sassi-bench[sassi]``; the CPU build is enough.

Why ship their code rather than re-implement it: the point of the choice is to match
*their* code's behaviour (its offset estimate from the nearest streak-free pixel, its
half-pixel ``grid_sample`` reading, its window); a re-implementation would choose for
itself. The two files are 35 kB and MIT-licensed.

Examples
--------
Not run here (it needs captured frames or the authors' code)::

    code = upstream_extraction()
    cube = code.get_cassi_cube(img, mask, xl, yl, row, col, 9, ksizes)
"""

from __future__ import annotations

import ast
import functools
import hashlib
from pathlib import Path
from types import SimpleNamespace

from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "UPSTREAM_BLOBS",
    "UPSTREAM_COMMIT",
    "UPSTREAM_FOLDER",
    "UPSTREAM_REPOSITORY",
    "git_blob_id",
    "upstream_extraction",
]

UPSTREAM_REPOSITORY = "Image-Science-Lab-cmu/SASSI"
UPSTREAM_COMMIT = "77d27e38ef8da24f522d66fd4cc5a5e0b674bb16"
UPSTREAM_FOLDER = Path(__file__).with_name("sassi_upstream")
#: File -> its git blob id at :data:`UPSTREAM_COMMIT` (``git ls-tree`` of the upstream
#: repository shows the same ids under ``modules/``; ``LICENSE`` at its root).
UPSTREAM_BLOBS = {
    "cassi.py": "3439934467cde194965669fd2140abf7de72935e",
    "filtering.py": "1812077a7f377868214004ffa61f4e0de23bf048",
    "LICENSE": "c8b7f326fbb586b5d7f84168c9a17bed43252461",
}
_CASSI_FUNCTIONS = ("get_cassi_img", "get_offset", "_get_cassi_cube", "get_cassi_cube")
_FILTERING_FUNCTIONS = ("gausswin2d", "gaussdiskwin")


def git_blob_id(data: bytes) -> str:
    """The git blob id (SHA-1 of ``blob <size>\\0`` and the bytes) of a file's content.

    Examples
    --------
    >>> git_blob_id(b"")
    'e69de29bb2d1d6434b8b29ae775ad8c2e48c5391'
    """
    return hashlib.sha1(b"blob %d\0" % len(data) + data, usedforsecurity=False).hexdigest()


def _definitions(path: Path, names: tuple[str, ...], namespace: dict) -> None:
    """Compile the top-level functions ``names`` of ``path`` into ``namespace``."""
    tree = ast.parse(path.read_bytes(), filename=str(path))
    chosen = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name in names]
    missing = set(names) - {n.name for n in chosen}
    if missing:
        raise ProcedureError(
            step_error(
                "SASSI code",
                f"{path.name} has no function {', '.join(sorted(missing))}",
                f"restore {path} from {UPSTREAM_REPOSITORY} at commit {UPSTREAM_COMMIT[:7]}",
            )
        )
    exec(compile(ast.Module(body=chosen, type_ignores=[]), str(path), "exec"), namespace)


@functools.cache
def upstream_extraction() -> SimpleNamespace:
    """The authors' extraction functions, compiled from ``sassi_upstream/cassi.py``.

    Returns
    -------
    SimpleNamespace
        ``get_cassi_cube``, ``get_cassi_img``, ``get_offset``, ``_get_cassi_cube`` (as in
        ``cassi.py``) and ``filtering`` (``gaussdiskwin``, ``gausswin2d``).

    Raises
    ------
    ProcedureError
        If PyTorch is missing, or the vendored files were changed.

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        code = upstream_extraction()
        code.get_cassi_cube.__code__.co_filename.endswith("cassi.py")
        # True
    """
    try:
        import torch
    except ImportError:
        raise ProcedureError(
            step_error(
                "SASSI code",
                "the SASSI authors' get_cassi_cube, which chooses the exported vsize, needs "
                "PyTorch (its get_cassi_img calls grid_sample), and it is not installed",
                'pip install "sassi-bench[sassi]" (the CPU build of torch is enough), or '
                "pass --vsize N to choose the window yourself",
            )
        ) from None
    for name, blob in UPSTREAM_BLOBS.items():
        path = UPSTREAM_FOLDER / name
        if not path.is_file() or git_blob_id(path.read_bytes()) != blob:
            raise ProcedureError(
                step_error(
                    "SASSI code",
                    f"{path} is missing or differs from {UPSTREAM_REPOSITORY} at commit "
                    f"{UPSTREAM_COMMIT[:7]}",
                    "reinstall sassi-bench (the vendored files must stay byte-identical)",
                )
            )
    import cv2
    import numpy as np
    from scipy import interpolate, signal

    filtering: dict = {"np": np, "signal": signal}
    _definitions(UPSTREAM_FOLDER / "filtering.py", _FILTERING_FUNCTIONS, filtering)
    cassi: dict = {
        "np": np,
        "signal": signal,
        "interpolate": interpolate,
        "cv2": cv2,
        "torch": torch,
        "filtering": SimpleNamespace(**{k: filtering[k] for k in _FILTERING_FUNCTIONS}),
    }
    _definitions(UPSTREAM_FOLDER / "cassi.py", _CASSI_FUNCTIONS, cassi)
    return SimpleNamespace(**{k: cassi[k] for k in _CASSI_FUNCTIONS}, filtering=cassi["filtering"])
