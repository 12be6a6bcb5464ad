"""Checks of array arguments whose errors name the step, the cause and the fix.

A function checks its array arguments on entry, one call per fact it relies on, the way
scikit-image's metrics call ``check_shape_equality`` before they compute::

    check_shape_equality(reference, estimate, step="snapshot metrics",
                         names=("the reference", "the estimate"))

Every check raises ``error`` (:class:`~sassi_bench.errors.ProcedureError` unless the caller
names another class, e.g. its package's own error type) with a
``"<step>: <cause>. Fix: <fix>"`` message (:func:`~sassi_bench.errors.step_error`). The
cause names the argument, its shape or dtype and what was expected; ``fix`` defaults to a
generic sentence, so callers pass the one that tells the user what to do.

A shape pattern is a tuple of dimensions: an int must match exactly, a str matches any
length and names the axis in the message (``("N", 2)`` reads "(N, 2)"). A list of patterns
accepts any one of them.

Examples
--------
>>> check_shape(np.zeros((5, 2)), ("N", 2), step="snapshot", name="the pixel list")
>>> check_shape(np.zeros((5, 3)), ("N", 2), step="snapshot", name="the pixel list")
Traceback (most recent call last):
...
sassi_bench.errors.ProcedureError: snapshot: the pixel list has shape (5, 3), expected (N, 2). ...
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from numpy.typing import ArrayLike, DTypeLike, NDArray

from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "ShapePattern",
    "as_float_array",
    "check_dtype_kind",
    "check_ndim",
    "check_shape",
    "check_shape_equality",
]

#: Dimensions of an expected shape: an int must match, a str matches any length.
ShapePattern = tuple[int | str, ...]

#: What a check raises: an exception class (or factory) taking the message.
ErrorType = Callable[[str], Exception]

#: Words for dtype kinds, the widest group first: "iuf" reads "real numeric".
_KIND_GROUPS = (
    ("b", "boolean"),
    ("iuf", "real numeric"),
    ("iu", "integer"),
    ("i", "signed integer"),
    ("u", "unsigned integer"),
    ("f", "floating-point"),
    ("c", "complex"),
)


def check_ndim(
    array: ArrayLike,
    ndim: int | Iterable[int],
    *,
    step: str,
    name: str,
    fix: str | None = None,
    allow_empty: bool = True,
    error: ErrorType = ProcedureError,
) -> None:
    """Refuse an array whose number of dimensions is not ``ndim`` (or not one of them).

    Parameters
    ----------
    array
        The argument to check.
    ndim
        The allowed number of dimensions, or several.
    step
        What the caller is doing, e.g. ``"spectrum extraction"``.
    name
        The argument as the message names it, e.g. ``"the frame"``.
    fix
        What the user should do; by default "pass <name> as a <ndim>-D array".
    allow_empty
        If False, an array without elements is refused too.
    error
        The exception class to raise.

    Raises
    ------
    ProcedureError
        Or ``error``: when the check fails.

    Examples
    --------
    >>> check_ndim(np.zeros((2, 3)), (2, 3), step="warp", name="the image")
    >>> check_ndim(np.zeros(4), 2, step="extraction", name="the frame", fix="pass one frame")
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: extraction: the frame has shape (4,), expected a 2-D ...
    """
    shape = np.shape(array)
    allowed = (ndim,) if isinstance(ndim, int) else tuple(ndim)
    expected = f"a {' or '.join(f'{n}-D' for n in allowed)} array"
    if len(shape) not in allowed:
        cause = f"{name} has shape {shape}, expected {expected}"
        raise error(step_error(step, cause, fix or f"pass {name} as {expected}"))
    if not allow_empty:
        _check_not_empty(shape, step, name, fix or f"pass {name} with values", error)


def check_shape(
    array: ArrayLike,
    shape: ShapePattern | list[ShapePattern],
    *,
    step: str,
    name: str,
    expected_for: str | None = None,
    fix: str | None = None,
    allow_empty: bool = True,
    error: ErrorType = ProcedureError,
) -> None:
    """Refuse an array whose shape does not match ``shape`` (or any of a list of shapes).

    Parameters
    ----------
    array
        The argument to check.
    shape
        The expected shape as a pattern: a tuple of ints (must match) and strs (any
        length, named in the message), or a list of patterns of which one must match.
    step
        What the caller is doing, e.g. ``"SLM show"``.
    name
        The argument as the message names it, e.g. ``"the pattern"``.
    expected_for
        What the expected shape comes from, e.g. ``"the SLM"``: the message then reads
        "expected (400, 640) for the SLM".
    fix
        What the user should do; by default "pass <name> with shape <shape>".
    allow_empty
        If False, an array without elements is refused too.
    error
        The exception class to raise.

    Raises
    ------
    ProcedureError
        Or ``error``: when the check fails.

    Examples
    --------
    >>> check_shape(np.zeros((4, 5, 3)), [("H", "W"), ("H", "W", 3)], step="s", name="the image")
    >>> check_shape(np.zeros((4, 5)), (4, 6), step="SLM show", name="the pattern",
    ...             expected_for="the SLM")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: SLM show: the pattern has shape (4, 5), expected (4, 6) ...
    >>> try:
    ...     check_shape(np.zeros((2, 2)), [(), (3, 3)], step="fit", name="the dark frame")
    ... except ValueError as exc:
    ...     print(exc)  # doctest: +NORMALIZE_WHITESPACE
    fit: the dark frame has shape (2, 2), expected () or (3, 3). Fix: pass the dark frame with
    shape () or (3, 3)
    """
    actual = np.shape(array)
    patterns = shape if _is_pattern_list(shape) else [tuple(shape)]
    if not any(_matches(actual, pattern) for pattern in patterns):
        expected = _or_list([_shape_text(pattern) for pattern in patterns])
        cause = f"{name} has shape {actual}, expected {expected}"
        if expected_for:
            cause += f" for {expected_for}"
        raise error(step_error(step, cause, fix or f"pass {name} with shape {expected}"))
    if not allow_empty:
        _check_not_empty(actual, step, name, fix or f"pass {name} with values", error)


def check_shape_equality(
    first: ArrayLike,
    second: ArrayLike,
    *,
    step: str,
    names: tuple[str, str],
    fix: str | None = None,
    error: ErrorType = ProcedureError,
) -> None:
    """Refuse two arrays of different shapes.

    Parameters
    ----------
    first, second
        The arguments that must have one shape.
    step
        What the caller is doing, e.g. ``"Gray decoding"``.
    names
        The two arguments as the message names them.
    fix
        What the user should do; by default "pass <first> and <second> of one shape".
    error
        The exception class to raise.

    Raises
    ------
    ProcedureError
        Or ``error``: when the shapes differ.

    Examples
    --------
    >>> check_shape_equality(np.zeros((2, 3)), np.ones((2, 3)), step="s", names=("a", "b"))
    >>> check_shape_equality(np.zeros((2, 3)), np.ones((3, 2)), step="Gray decoding",
    ...                      names=("positive frames", "negative frames"))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: Gray decoding: positive frames (2, 3) and negative ...
    """
    first_shape, second_shape = np.shape(first), np.shape(second)
    if first_shape != second_shape:
        cause = f"{names[0]} {first_shape} and {names[1]} {second_shape} differ in shape"
        raise error(step_error(step, cause, fix or f"pass {names[0]} and {names[1]} of one shape"))


def check_dtype_kind(
    array: ArrayLike,
    kinds: str,
    *,
    step: str,
    name: str,
    fix: str | None = None,
    error: ErrorType = ProcedureError,
) -> None:
    """Refuse an array whose dtype is not of one of the NumPy ``kinds``.

    Parameters
    ----------
    array
        The argument to check.
    kinds
        The allowed :attr:`numpy.dtype.kind` characters: ``"b"`` boolean, ``"i"`` signed
        and ``"u"`` unsigned integer, ``"f"`` floating point, ``"c"`` complex.
    step
        What the caller is doing.
    name
        The argument as the message names it.
    fix
        What the user should do; by default "pass <name> as <kinds> values".
    error
        The exception class to raise.

    Raises
    ------
    ProcedureError
        Or ``error``: when the dtype is of another kind.

    Examples
    --------
    >>> check_dtype_kind(np.zeros(3, np.uint16), "iu", step="s", name="the pixel list")
    >>> check_dtype_kind(np.zeros(3), "iu", step="snapshot", name="the pixel list")
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: snapshot: the pixel list has dtype float64, expected ...
    """
    dtype = np.asarray(array).dtype
    if dtype.kind not in kinds:
        expected = f"{_kind_text(kinds)} values"
        cause = f"{name} has dtype {dtype}, expected {expected}"
        raise error(step_error(step, cause, fix or f"pass {name} as {expected}"))


def as_float_array(
    value: ArrayLike,
    *,
    step: str,
    name: str,
    dtype: DTypeLike = np.float64,
    fix: str | None = None,
    error: ErrorType = ProcedureError,
) -> NDArray[np.floating]:
    """``value`` as a floating-point array, refusing what cannot be converted.

    Parameters
    ----------
    value
        An array or nested sequence of real numbers.
    step
        What the caller is doing.
    name
        The argument as the message names it.
    dtype
        The floating-point dtype of the result.
    fix
        What the user should do; by default "pass <name> as numbers".
    error
        The exception class to raise.

    Returns
    -------
    ndarray
        ``value`` as ``dtype`` (not copied if it already is one).

    Raises
    ------
    ProcedureError
        Or ``error``: for what :func:`numpy.asarray` cannot convert (words, ragged
        sequences...).

    Examples
    --------
    >>> as_float_array([1, 2], step="metrics", name="the reference").tolist()
    [1.0, 2.0]
    >>> as_float_array([1, "x"], step="metrics", name="the reference")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: metrics: the reference is not an array of numbers (...
    """
    try:
        return np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        cause = f"{name} is not an array of numbers ({exc})"
        raise error(step_error(step, cause, fix or f"pass {name} as numbers")) from exc


def _check_not_empty(shape: tuple[int, ...], step: str, name: str, fix: str, error: ErrorType):
    if 0 in shape:
        raise error(step_error(step, f"{name} has shape {shape}, which holds no values", fix))


def _is_pattern_list(shape: ShapePattern | list[ShapePattern]) -> bool:
    return isinstance(shape, list) and bool(shape) and all(isinstance(p, tuple) for p in shape)


def _matches(actual: tuple[int, ...], pattern: ShapePattern) -> bool:
    return len(actual) == len(pattern) and all(
        isinstance(want, str) or got == want for got, want in zip(actual, pattern, strict=True)
    )


def _shape_text(pattern: ShapePattern) -> str:
    dims = [str(dim) for dim in pattern]
    return f"({dims[0]},)" if len(dims) == 1 else f"({', '.join(dims)})"


def _or_list(items: list[str]) -> str:
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} or {items[-1]}"


def _kind_text(kinds: str) -> str:
    left, words = set(kinds), []
    for group, word in _KIND_GROUPS:
        if set(group) <= left:
            words.append(word)
            left -= set(group)
    return _or_list(words)
