"""The ``README.txt`` of a ``sassi-mat`` export: what each variable holds, which line of
the SASSI authors' ``modules/cassi.py`` reads it, and what to change there.

The evidence quoted for the row window was measured on the virtual bench (the
``sim`` rig) with the authors' extraction re-implemented as in
``tests/export/test_sassi_consumer.py``; see that test and the export's module
documentation (:mod:`sassi_bench.export.sassi_mat`).
"""

from __future__ import annotations

import textwrap

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.export.camera_lookup import CameraLookup

__all__ = ["readme_text"]


def readme_text(
    bundle: CalibrationBundle,
    lookup: CameraLookup,
    unreached: NDArray[np.float64],
    manifest_sha256: str,
    *,
    vsize: int,
    share: NDArray[np.float64],
    columns: NDArray[np.float64],
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
    vsize
        The row window written.
    share
        Per band, the share of a band's light inside the window.
    columns
        Per band, nm per camera column.
    quantum
        The rounding of the positions in px (0: exact).

    Returns
    -------
    str
        The text.

    Examples
    --------
    >>> text = readme_text(bundle, lookup, unreached, sha, vsize=3, share=share,
    ...                    columns=nm_per_column, quantum=1 / 64)  # doctest: +SKIP
    """
    wavelengths = lookup.wavelengths
    hc, wc = lookup.camera_shape
    hl, wl = bundle.slm_shape
    t = wavelengths.size
    status = "passed" if bundle.passed else "FAILED its quality checks (published with override)"
    sigma = np.asarray(bundle.blur_width(wavelengths), dtype=np.float64)
    wide = 2 * int(np.ceil(sigma.max())) + 1
    if quantum:
        positions = (
            f"rounded to multiples of {quantum:g} px (position_quantum_px;\n"
            f"          at most {quantum / 2:g} px off, against the calibration's own\n"
            "          0.02-0.04 px), which lets zlib shrink the files about four times;\n"
            "          export with --position-quantum 0 for the exact float32 values"
        )
    else:
        positions = "exact (position_quantum_px = 0)"
    body = f"""\
    Calibration files for the SASSI reconstruction code (Image-Science-Lab-cmu/SASSI,
    modules/cassi.py), exported by sassi-bench from a calibration bundle.

    Source bundle : {bundle.rig_name}/{bundle.version} ({status})
    Bundle path   : {bundle.path}
    manifest.json : sha256 {manifest_sha256}
                    (manifest.json lists the sha256 of every array of the bundle)
    Bands         : T = {t}, {wavelengths[0]:.2f} - {wavelengths[-1]:.2f} nm
    Camera        : Hc x Wc = {hc} x {wc} px (spectral camera)
    SLM           : Hl x Wl = {hl} x {wl} px

    Use: put both files in <root>/calibration/ (that is where cassi.py's __main__
    loads them with scipy.io.loadmat). All indices below are MATLAB 1-based: the
    code subtracts 1. Arrays are indexed [row, column, band] in MATLAB/numpy order
    (scipy.io.loadmat returns them with exactly these shapes).

    calibstack.mat
      calibstack_row  single (Hc, Wc, T) = ({hc}, {wc}, {t})
      calibstack_col  single (Hc, Wc, T)
          For camera pixel [r, c] and band k: the SLM row / column (1-based,
          sub-pixel) whose light of band k lands on the centre of that camera
          pixel; the exact inverse of the bundle's dispersion map (solved by
          Newton's method on camera nodes every {lookup.step} px, interpolated
          bilinearly). Where several SLM pixels fall into one camera
          pixel, this is the position under the pixel's centre; round it to get
          the SLM pixel whose area contains that point.
          0 (both arrays) where no SLM pixel reaches the camera pixel: after the
          code's "- 1" that is -1, which get_cassi_img's grid_sample reads as 0
          (zero padding), so get_offset treats the pixel as streak-free. Not NaN:
          grid_sample mishandles NaN grids.
          Single precision because get_cassi_img feeds them to grid_sample with a
          float32 cube, and grid_sample refuses a grid of another dtype.
          Positions (these and Xl/Yl) are {positions}.
          Share of camera pixels unreached: {unreached.min():.1%} - {unreached.max():.1%}
          per band.
          Note: get_cassi_img normalises a 0-based coordinate c as (2c - H)/H with
          align_corners=False, which samples the SLM at c - 0.5 (half an SLM pixel
          up and left). That affects only the streak mask used for the offset
          estimate; the values stored here are the true positions.
      wavelengths     double (1, T): band centres in nm (cassi.py ravels it).
      blur_sigma_px   double (1, T): the bundle's Gaussian blur sigma per band
                      (camera px). Not read by cassi.py.
      ksizes          double (1, T): ceil(3 sigma) + 0.5, so that
                      filtering.gaussdiskwin(ksizes[k]) spans +/- 3 sigma. cassi.py
                      hard-codes ksizes = linspace(1, 4, T)**2 / 4 instead; to use
                      the calibrated blur replace that line by
                      ksizes = calibdata['ksizes'].ravel()
                      (on the virtual bench the hard-coded windows are narrower
                      than the blue blur: streak light beside them is taken as
                      offset and bins below 415 nm keep under 25 % of their
                      signal; with these ksizes the spectra agree with
                      sassi-bench's to 3.7 % RMS per pixel, median).
      vsize           int32 (1, 1) = {vsize}: the row window of get_cassi_cube.
          cassi.py's __main__ sets vsize = 3 (line 768 at commit 77d27e3) and
          passes it to get_cassi_cube(cassi_img, mask, Xl, Yl, calibstack_row,
          calibstack_col, vsize, ksizes) (line 811), whose _get_cassi_cube sums
          vsize camera rows around every pixel before it samples the streaks
          (line 669):
              cassi_img = signal.convolve2d(cassi_img, np.ones((vsize, 1)), 'same')
          It is one integer for all bands (the code cannot take one per band) and
          np.ones needs a Python int, so replace "vsize = 3" by
              vsize = int(calibdata['vsize'].item())
          {vsize} is the odd window nearest to 2.8 x the median blur sigma
          ({np.median(sigma):.2f} px here; sigma runs {sigma.min():.2f}-{sigma.max():.2f} px):
          the width at which a Gaussian spot's light over the square root of the
          rows summed is largest, that is the best signal against the noise of
          the code's offset estimate (one streak-free pixel's value per pixel,
          summed over the window) and, on dense masks, the neighbouring rows'
          streaks.
      row_window_share double (1, T): per band, the share of the band's light
          that the vsize-row window keeps ({share.min():.2f}-{share.max():.2f}; median over
          the field of the bilinear sample cv2.remap takes). Where the blur is
          wide the window keeps little, so divide it out right after the
          get_cassi_cube call (before "cube /= cube.max()", line 813):
              cube /= calibdata['row_window_share']
          The spectra then no longer depend on vsize.
          Why a small window and this division rather than a window wide enough
          for the widest blur (2 ceil(max sigma) + 1 = {wide} rows): measured
          on the virtual bench (sim rig, an adaptive snapshot of 284 open pixels,
          natural scene, white LED; PSNR of the open pixels' spectra against the
          bench's hidden scene, one gain for all bands), the authors' extraction scores
          26.7 dB at vsize 3, 35.2 dB at vsize 9, and 39.8 dB at vsize 3 with
          this division (36.6 dB at vsize 9 with it): the wider window brings in
          more noise than light (on a sparse pinhole mask: 27.0, 37.0 and
          41.1 dB). The rank-1 cube built from those spectra (the paper's model,
          affine PSNR over the SLM) goes from 26.8 to 32.1 dB (31.2 dB at vsize
          9; 32.3 dB from sassi-bench's own spectra, for the rank-1 model's error
          dominates there). sassi-bench's own extraction scores 45.9 dB; the
          5.5 dB between is its spectral deblur, which cassi.py does not do
          (40.4 dB without it).
      nm_per_column   double (1, T): the spectral width of one camera column per
          band ({columns.min():.1f}-{columns.max():.1f} nm). A value of the cube is the light of one
          camera column, so cube / row_window_share / nm_per_column is light per
          nm. On a band grid coarser than the columns (--wavelengths paper: every
          10 nm) each band is still one column's sample, not a 10 nm integral:
          the light between the samples is not used.
      position_quantum_px: the rounding of the positions (0 = exact).
      bundle_rig, bundle_version, bundle_manifest_sha256: where this came from.

    reverse_lookup.mat
      Xl  single (Hl, Wl, T) = ({hl}, {wl}, {t}): camera ROW (1-based, sub-pixel)
          where SLM pixel [r, c] lands in band k.
      Yl  single (Hl, Wl, T): camera COLUMN (1-based) of the same point.
          Xl holds rows and Yl columns, whatever the names suggest, because that is
          what the code does: get_cassi_cube calls _get_cassi_cube(img, mask, Yl, Xl)
          (swapped), which calls cv2.remap(img, Xl, Yl) whose first map is the
          column (x) and second the row (y). So cv2.remap samples the camera image
          at column Yl - 1, row Xl - 1.
          SLM pixels whose light leaves the camera keep their outside coordinates;
          cv2.remap's constant border reads them as 0.
      wavelengths, position_quantum_px, bundle_rig, bundle_version,
      bundle_manifest_sha256: as above.

    Files: every variable is zlib-compressed (MATLAB's default v7 format, which
    scipy.io.loadmat and MATLAB's load read as they are). Both are read whole
    and __main__ copies the tables once more ("- 1"), so reading them needs
    about twice their uncompressed size in memory; export fewer bands
    (--wavelengths paper: every 10 nm) where that is too much.

    Per capture (adaptive_cassi.mat, from "sassi-bench snapshot export --format
    sassi-mat"): lcos_mask uint8 (Hl, Wl) 0/255, cassi_img uint16 (Hc, Wc) raw
    camera frame, guide_img_rec uint8 RGB (h2-h1, w2-w1, 3), limits int32
    [h1 h2 w1 w2] (0-based Python slice bounds: cassi.py crops mask[h1:h2, w1:w2]).
    limits default to the whole SLM: __main__ passes the uncropped cube from
    get_cassi_cube with the cropped mask and guide to recon_superpixel, which only
    works when they have one shape; with other limits crop the cube first.
    """
    return textwrap.dedent(body)
