"""Run the SASSI authors' published code on a ``sassi-mat`` export, in a process of its own.

``python tests/export/sassi_upstream_run.py ROOT EXPNAME OUT.npz [--vsize N]
[--build DIR]`` runs, from ``ROOT`` (``calibration/`` and ``EXPNAME/`` inside), the
Python block of the export's ``README.txt`` verbatim (``sassi_readme.CALLS``) against
their ``modules`` package: ``cassi.py`` and ``filtering.py`` from
``sassi_bench/export/sassi_upstream/``, the rest of what ``cassi.py`` imports from
``tests/export/vendored_sassi/modules/``, all byte-identical to upstream, and their
Cython module ``cassi_cp.pyx`` compiled here with their own ``setup.py`` flags (cached in
``--build``). ``--vsize N`` replaces the README's ``vsize = int(data['vsize'].item())``
by ``vsize = N`` (the export before the window was chosen: 3, their hard-coded value).
Writes ``cube`` (their spectra at the open pixels) and ``cube_rec`` (their rank-1
reconstruction) to ``OUT.npz`` and prints the seconds each took.

One OpenMP thread (``OMP_NUM_THREADS=1``): ``cassi_cp.recon_superpixel`` counts each
superpixel's members with ``cnt_array_view[lbl] += 1`` inside a ``prange`` over rows, a
race between threads; with one thread it is exact and the run repeatable. The rank-6
projection draws a randomised SVD from numpy's global generator; it is seeded (0).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
VENDORED = HERE / "vendored_sassi"
PACKAGE_UPSTREAM = HERE.parents[1] / "sassi_bench" / "export" / "sassi_upstream"
#: Their setup.py's compiler and linker flags for cassi_cp.
COMPILE_ARGS = ["-fopenmp", "-march=native", "-O3", "-ffast-math"]
LINK_ARGS = ["-fopenmp"]


def assemble(build: Path) -> Path:
    """``build/modules/`` with their files and the compiled ``cassi_cp``; returns ``build``."""
    import numpy as np

    source = VENDORED / "modules" / "cassi_cp.pyx"
    key = hashlib.sha256(source.read_bytes() + sys.version.encode()).hexdigest()[:16]
    target = build / key
    modules = target / "modules"
    if not list(modules.glob("cassi_cp*.so")):
        from Cython.Build import cythonize
        from setuptools import Extension
        from setuptools.dist import Distribution

        extension = Extension(
            "modules.cassi_cp", [str(source)], extra_compile_args=COMPILE_ARGS,
            extra_link_args=LINK_ARGS, include_dirs=[np.get_include()],
        )  # fmt: skip
        compiled = cythonize([extension], build_dir=str(target / "c"), quiet=True, language_level=3)
        command = Distribution({"ext_modules": compiled}).get_command_obj("build_ext")
        command.build_lib, command.build_temp = str(target), str(target / "tmp")
        command.ensure_finalized()
        command.run()
    for path in (*sorted((VENDORED / "modules").glob("*.py")), *PACKAGE_UPSTREAM.glob("*.py")):
        shutil.copyfile(path, modules / path.name)
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root")
    parser.add_argument("expname")
    parser.add_argument("out")
    parser.add_argument("--vsize", type=int)
    parser.add_argument("--build", default=str(Path.home() / ".cache" / "sassi-upstream"))
    args = parser.parse_args()
    os.environ["OMP_NUM_THREADS"] = "1"
    start = time.perf_counter()
    sys.path.insert(0, str(assemble(Path(args.build))))
    built = time.perf_counter()
    import numpy as np

    from sassi_bench.export.sassi_readme import CALLS

    calls = CALLS
    if args.vsize is not None:
        line = "vsize = int(data['vsize'].item())"
        assert line in calls
        calls = calls.replace(line, f"vsize = {int(args.vsize)}")
    extraction, rest = calls.split("cube /= cube.max()\n")
    os.chdir(args.root)
    np.random.seed(0)  # noqa: NPY002 - their randomized_svd draws from the global generator
    scope = {"expname": args.expname}
    exec(compile(extraction, "README.txt", "exec"), scope)
    extracted = time.perf_counter()
    cube = scope["cube"].copy()
    exec(compile("cube /= cube.max()\n" + rest, "README.txt", "exec"), scope)
    done = time.perf_counter()
    np.savez(args.out, cube=cube, cube_rec=scope["cube_rec"], vsize=scope["vsize"])
    print(
        f"build {built - start:.1f} s, extraction {extracted - built:.1f} s, "
        f"rank-1 {done - extracted:.1f} s"
    )


if __name__ == "__main__":
    main()
