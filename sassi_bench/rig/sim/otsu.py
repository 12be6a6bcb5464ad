"""Vectorised spectral recovery from colour (Otsu, Yamamoto and Hachisuka 2018).

colour-science implements the method one colour per call, far too slow to lift a
photograph to spectra. This module applies the same dataset (eight clusters of three
basis functions and a mean, selected by a tree over CIE xy) to every pixel at once:
the cluster tree is walked for all pixels in parallel and each cluster's 3x3 system is
solved once, giving identical results to
:func:`colour.recovery.XYZ_to_sd_Otsu2018` (see the tests).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["OTSU2018_WAVELENGTHS_NM", "xyz_to_reflectance_otsu2018"]


@lru_cache(maxsize=1)
def _model() -> tuple[NDArray[np.float64], ...]:
    import colour
    from colour.recovery import (
        BASIS_FUNCTIONS_OTSU2018,
        CLUSTER_MEANS_OTSU2018,
        SELECTOR_ARRAY_OTSU2018,
        SPECTRAL_SHAPE_OTSU2018,
    )

    cmfs = (
        colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        .copy()
        .align(SPECTRAL_SHAPE_OTSU2018)
    )
    illuminant = colour.SDS_ILLUMINANTS["D65"].copy().align(cmfs.shape)
    wl = SPECTRAL_SHAPE_OTSU2018.wavelengths

    def to_xyz(values: NDArray[np.float64]) -> NDArray[np.float64]:
        sd = colour.SpectralDistribution(values, wl)
        with (
            colour.utilities.domain_range_scale("ignore"),
            colour.utilities.suppress_warnings(colour_runtime_warnings=True),
        ):
            return colour.sd_to_XYZ(sd, cmfs, illuminant) / 100

    n_clusters = BASIS_FUNCTIONS_OTSU2018.shape[0]
    m_inverse = np.empty((n_clusters, 3, 3))
    xyz_mean = np.empty((n_clusters, 3))
    for k in range(n_clusters):  # eight clusters, once per process
        m = np.stack([to_xyz(BASIS_FUNCTIONS_OTSU2018[k, i]) for i in range(3)], axis=1)
        m_inverse[k] = np.linalg.inv(m)
        xyz_mean[k] = to_xyz(CLUSTER_MEANS_OTSU2018[k])
    return (
        np.asarray(wl, dtype=np.float64),
        np.asarray(SELECTOR_ARRAY_OTSU2018, dtype=np.float64),
        np.asarray(BASIS_FUNCTIONS_OTSU2018, dtype=np.float64),
        np.asarray(CLUSTER_MEANS_OTSU2018, dtype=np.float64),
        m_inverse,
        xyz_mean,
    )


def _select_clusters(xy: NDArray[np.float64], selector: NDArray[np.float64]) -> NDArray[np.intp]:
    """Walk the Otsu cluster tree for all chromaticities at once."""
    node = np.zeros(len(xy), dtype=np.intp)
    cluster = np.full(len(xy), -1, dtype=np.intp)
    pending = np.arange(len(xy))
    while pending.size:
        origin, direction, lesser, greater = selector[node[pending]].T
        coord = xy[pending, direction.astype(np.intp)]
        nxt = np.where(coord <= origin, lesser, greater).astype(np.intp)
        leaf = nxt >= 0
        cluster[pending[leaf]] = nxt[leaf]
        node[pending[~leaf]] = -nxt[~leaf]
        pending = pending[~leaf]
    return cluster


def OTSU2018_WAVELENGTHS_NM() -> NDArray[np.float64]:
    """Wavelengths (nm) of the spectra returned by :func:`xyz_to_reflectance_otsu2018`."""
    return _model()[0].copy()


def xyz_to_reflectance_otsu2018(xyz: ArrayLike, clip: bool = True) -> NDArray[np.float64]:
    """Recover reflectance spectra from CIE XYZ (D65, CIE 1931 2 degree), vectorised.

    Parameters
    ----------
    xyz
        Tristimulus values in domain [0, 1], shape (..., 3).
    clip
        Clip reflectances to [0, 1], as colour-science does by default.

    Returns
    -------
    ndarray
        Spectra (..., 36) at :func:`OTSU2018_WAVELENGTHS_NM` (380-730 nm, 10 nm).

    Examples
    --------
    >>> r = xyz_to_reflectance_otsu2018([[0.20654008, 0.12197225, 0.05136952]])
    >>> round(float(r[0, 0]), 4)
    0.0602
    """
    _, selector, basis, means, m_inverse, xyz_mean = _model()
    xyz = np.asarray(xyz, dtype=np.float64)
    flat = xyz.reshape(-1, 3)
    total = flat.sum(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = np.where(total > 0, flat[:, :2] / total, 0.0)
    # colour-science maps black to the D65 white point's chromaticity.
    xy[total[:, 0] <= 0] = (0.3127, 0.3290)
    cluster = _select_clusters(xy, selector)
    weights = np.einsum("nij,nj->ni", m_inverse[cluster], flat - xyz_mean[cluster])
    spectra = np.einsum("ni,nil->nl", weights, basis[cluster]) + means[cluster]
    if clip:
        np.clip(spectra, 0.0, 1.0, out=spectra)
    return spectra.reshape(*xyz.shape[:-1], spectra.shape[-1])
