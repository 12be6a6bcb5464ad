"""Compiled order statistics: the quickselect the frame and crosstalk kernels share.

numba's ``np.partition`` and ``np.sort`` took seconds to compile; this loop takes a
fraction of one, and it works in place on a scratch buffer a kernel already holds.
"""

from __future__ import annotations

from numba import njit


@njit(nogil=True, cache=False)
def select(values, count, rank):  # pragma: no cover - compiled
    """Reorder ``values[:count]`` so that ``values[rank]`` is its ``rank``-th smallest.

    Hoare's quickselect with a median-of-three pivot: afterwards none of
    ``values[:rank]`` is larger and none of ``values[rank + 1 : count]`` smaller.

    Parameters
    ----------
    values : 1-D float array
        Reordered in place; must hold no NaN.
    count : int
        How many leading values take part.
    rank : int
        ``0 <= rank < count``.

    Returns
    -------
    float
        ``values[rank]`` after the reordering.

    Examples
    --------
    >>> import numpy as np
    >>> select(np.array([5.0, 1.0, 4.0, 2.0]), 4, 1)
    2.0
    """
    lo, hi = 0, count - 1
    while lo < hi:
        a, b, c = values[lo], values[(lo + hi) // 2], values[hi]
        pivot = max(min(a, b), min(max(a, b), c))
        i, j = lo, hi
        while i <= j:
            while values[i] < pivot:
                i += 1
            while values[j] > pivot:
                j -= 1
            if i <= j:
                values[i], values[j] = values[j], values[i]
                i += 1
                j -= 1
        if rank <= j:
            hi = j
        elif rank >= i:
            lo = i
        else:  # values[j + 1 : i] all equal the pivot
            break
    return values[rank]


@njit(nogil=True, cache=False)
def median(values, count):  # pragma: no cover - compiled
    """The median of ``values[:count]``, reordered in place (as ``np.median``: the mean
    of the two middle values for an even count).

    Examples
    --------
    >>> import numpy as np
    >>> median(np.array([4.0, 1.0, 3.0, 2.0]), 4)
    2.5
    """
    k = count // 2
    upper = select(values, count, k)
    if count % 2 == 1:
        return upper
    lower = values[0]
    for q in range(1, k):
        lower = max(lower, values[q])
    return 0.5 * (lower + upper)
