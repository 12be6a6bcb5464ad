"""Prism dispersion from Snell's law: the textbook deviation and a 3-D ray trace.

The workbench never models a prism with a polynomial: the virtual bench traces rays
through the two prism faces with the glass's Sellmeier index, so the dispersion fits
of the calibration are tested against real physics.

Geometry of :func:`trace_prism`: rays travel along +z, the prism's refracting edge is
parallel to y (vertical), and the base lies towards -x, so the prism bends rays
towards -x, more for larger index (shorter wavelength).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "deviation_deg",
    "face_normals",
    "min_deviation_incidence_deg",
    "refract",
    "rotation_about_y",
    "trace_prism",
]


def deviation_deg(n: ArrayLike, apex_deg: float, incidence_deg: ArrayLike) -> NDArray[np.float64]:
    """In-plane deviation angle of a ray through a prism (textbook formula).

    Parameters
    ----------
    n
        Refractive index of the prism (relative to air).
    apex_deg
        Apex (refracting) angle of the prism, degrees.
    incidence_deg
        Angle of incidence on the first face, degrees from its normal.

    Returns
    -------
    ndarray
        Deviation in degrees; NaN where the ray is totally internally reflected.

    Examples
    --------
    >>> round(float(deviation_deg(1.5, 60.0, 48.590377890729)), 4)  # minimum deviation
    37.1808
    """
    n = np.asarray(n, dtype=np.float64)
    a = np.deg2rad(apex_deg)
    ti = np.deg2rad(np.asarray(incidence_deg, dtype=np.float64))
    with np.errstate(invalid="ignore"):
        tr1 = np.arcsin(np.sin(ti) / n)
        to = np.arcsin(n * np.sin(a - tr1))
    return np.rad2deg(ti + to - a)


def min_deviation_incidence_deg(n: float, apex_deg: float) -> float:
    """Incidence angle (degrees) at which the prism is at minimum deviation.

    Examples
    --------
    >>> round(min_deviation_incidence_deg(1.5, 60.0), 4)
    48.5904
    """
    return float(np.rad2deg(np.arcsin(n * np.sin(np.deg2rad(apex_deg) / 2))))


def refract(
    d: NDArray[np.float64], normal: NDArray[np.float64], n1: ArrayLike, n2: ArrayLike
) -> NDArray[np.float64]:
    """Vector form of Snell's law.

    Parameters
    ----------
    d
        Unit ray directions, shape (..., 3).
    normal
        Unit surface normal oriented along the propagation (``d @ normal > 0``), (3,).
    n1, n2
        Indices before and after the surface; broadcast against ``d[..., 0]``.

    Returns
    -------
    ndarray
        Unit refracted directions (..., 3); NaN on total internal reflection.

    Examples
    --------
    >>> t = refract(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), 1.0, 1.5)
    >>> t.tolist()
    [0.0, 0.0, 1.0]
    """
    eta = (np.asarray(n1, dtype=np.float64) / np.asarray(n2, dtype=np.float64))[..., None]
    cos_i = (d @ normal)[..., None]
    sin2_t = eta**2 * (1.0 - cos_i**2)
    with np.errstate(invalid="ignore"):
        cos_t = np.sqrt(1.0 - sin2_t)
    return eta * d + (cos_t - eta * cos_i) * normal


def rotation_about_y(angle_rad: float) -> NDArray[np.float64]:
    """The 3x3 matrix of a rotation by ``angle_rad`` about the y axis (z towards x).

    Examples
    --------
    >>> (rotation_about_y(np.pi / 2) @ [0.0, 0.0, 1.0]).round(12).tolist()
    [1.0, 0.0, 0.0]
    """
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def face_normals(
    apex_deg: float, incidence_deg: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit normals of the prism's two faces, oriented along the propagation.

    The first face is tilted by the incidence angle; the second by (apex - incidence)
    the other way, so the faces meet at the apex angle and a ray bends towards -x (the
    base) at both faces.

    Examples
    --------
    >>> n1, n2 = face_normals(60.0, 30.0)
    >>> round(float(np.degrees(np.arccos(n1 @ n2))), 6)  # the faces meet at the apex
    60.0
    """
    ti = np.deg2rad(incidence_deg)
    normal1 = np.array([-np.sin(ti), 0.0, np.cos(ti)])
    return normal1, rotation_about_y(np.deg2rad(apex_deg)) @ normal1


def trace_prism(
    directions: NDArray[np.float64], n: ArrayLike, apex_deg: float, incidence_deg: float
) -> NDArray[np.float64]:
    """Trace unit ray directions through a prism in air.

    The prism is oriented so a ray along +z meets the first face at ``incidence_deg``.
    Out-of-plane (skew) rays are traced exactly, which produces the classic curvature
    of spectral lines ("smile") of prism spectrometers.

    Parameters
    ----------
    directions
        Unit directions (..., 3) of the rays entering the prism.
    n
        Refractive index, broadcast against ``directions[..., 0]``.
    apex_deg, incidence_deg
        Apex angle and incidence angle of the +z ray on the first face, degrees.

    Returns
    -------
    ndarray
        Unit directions (..., 3) leaving the prism.

    Examples
    --------
    >>> out = trace_prism(np.array([0.0, 0.0, 1.0]), 1.5, 60.0, 48.590377890729)
    >>> round(float(np.rad2deg(np.arctan2(-out[0], out[2]))), 4)  # deviation
    37.1808
    """
    normal1, normal2 = face_normals(apex_deg, incidence_deg)
    inside = refract(directions, normal1, 1.0, n)
    return refract(inside, normal2, n, 1.0)
