"""The ``README.txt`` of a ``sassi-mat`` export: which of the SASSI authors' functions to
call with which files.

The calls are those of ``cassi.py``'s ``__main__`` (Image-Science-Lab-cmu/SASSI), with
the blur list and the row window read from the exported files instead of its
hard-coded ``ksizes`` and ``vsize = 3``, and the cube cropped to ``limits`` like the
mask and guide (``__main__`` passes it whole, which works only for the whole SLM, the
export's default). ``tests/export/test_sassi_upstream.py`` runs
the Python block of this text verbatim against the authors' code.
"""

from __future__ import annotations

import textwrap

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.export.camera_lookup import CameraLookup
from sassi_bench.export.sassi_code import UPSTREAM_COMMIT, UPSTREAM_REPOSITORY

__all__ = ["CALLS", "readme_text"]

#: The Python the README gives, run from ``<root>`` with ``from modules import cassi``.
CALLS = """\
import numpy as np
from scipy import io
from modules import cassi

calibdata = io.loadmat('calibration/calibstack.mat')
reverse_calibdata = io.loadmat('calibration/reverse_lookup.mat')
data = io.loadmat(expname + '/adaptive_cassi.mat')

mask = data['lcos_mask'].astype(np.float32) / 255
cassi_img = data['cassi_img'].astype(np.float32)
imrgb = data['guide_img_rec']
h1, h2, w1, w2 = data['limits'].ravel()
Xl = reverse_calibdata['Xl'].astype(np.float32) - 1
Yl = reverse_calibdata['Yl'].astype(np.float32) - 1
calibstack_row = calibdata['calibstack_row'] - 1
calibstack_col = calibdata['calibstack_col'] - 1
ksizes = calibdata['ksizes'].ravel()
vsize = int(data['vsize'].item())

cube = cassi.get_cassi_cube(cassi_img, mask, Xl, Yl, calibstack_row,
                            calibstack_col, vsize, ksizes)
cube /= cube.max()
L, N = cassi.slic_update(imrgb, mask[h1:h2, w1:w2].astype(np.uint8), 10.0)
cube_rec = cassi.recon_superpixel(cube[h1:h2, w1:w2], mask[h1:h2, w1:w2], L,
                                  imrgb.astype(np.float32).mean(2) / 255, N,
                                  renorm=True, net=None, lr_filter=True, rank=6,
                                  recon_3d=False)
"""


def readme_text(
    bundle: CalibrationBundle,
    lookup: CameraLookup,
    unreached: NDArray[np.float64],
    manifest_sha256: str,
    *,
    quantum: float,
) -> str:
    """The ``README.txt`` written beside the two files.

    Parameters
    ----------
    bundle
        The bundle exported.
    lookup
        The camera lookup written to ``calibstack.mat`` (its bands and camera shape).
    unreached
        Per band, the fraction of camera pixels that see no SLM pixel.
    manifest_sha256
        The bundle manifest's checksum.
    quantum
        The rounding of the positions in px (0: exact).

    Returns
    -------
    str
        The text.

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        text = readme_text(bundle, lookup, unreached, sha, quantum=1 / 64)
    """
    wavelengths = lookup.wavelengths
    hc, wc = lookup.camera_shape
    hl, wl = bundle.slm_shape
    t = wavelengths.size
    status = "passed" if bundle.passed else "FAILED its quality checks (published with override)"
    rounding = f"rounded to {quantum:g} px" if quantum else "exact"
    head = f"""\
    Calibration for the SASSI reconstruction code ({UPSTREAM_REPOSITORY},
    modules/cassi.py at commit {UPSTREAM_COMMIT[:7]}), exported by sassi-bench.

    Bundle  : {bundle.rig_name}/{bundle.version} ({status}), {bundle.path}
              manifest.json sha256 {manifest_sha256}
    Bands   : T = {t}, {wavelengths[0]:.2f} - {wavelengths[-1]:.2f} nm
    Camera  : {hc} x {wc} px; SLM: {hl} x {wl} px

    Put calibstack.mat and reverse_lookup.mat in <root>/calibration/ and each capture
    folder (adaptive_cassi.mat, from "sassi-bench snapshot export --format sassi-mat")
    in <root>/. From <root>, with expname the capture folder's name, call:

    """
    tail = f"""
    cube_rec is the reconstruction; cube holds the spectra at the open pixels.

    calibstack.mat   calibstack_row, calibstack_col (Hc, Wc, T) single: SLM row and
                     column each camera pixel sees per band, 1-based, 0 where none;
                     wavelengths (1, T) nm; ksizes (1, T): blur windows reaching 3
                     sigma of the bundle's blur; blur_sigma_px (1, T).
    reverse_lookup.mat  Xl (Hl, Wl, T) single: camera row, Yl: camera column of every
                     SLM pixel per band, 1-based (get_cassi_cube swaps them before
                     cv2.remap, which reads Yl as columns).
    adaptive_cassi.mat  lcos_mask (Hl, Wl) uint8 0/255, cassi_img raw frame,
                     guide_img_rec (h2-h1, w2-w1, 3) uint8 RGB, limits [h1 h2 w1 w2],
                     vsize: the row window for this capture, chosen by running
                     get_cassi_cube itself on this frame.
    Positions are {rounding}. Share of camera pixels unreached per band:
    {unreached.min():.1%} - {unreached.max():.1%}.
    """
    return textwrap.dedent(head) + CALLS + textwrap.dedent(tail)
