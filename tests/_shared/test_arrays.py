"""Array argument checks: what they accept, what they refuse and how they say it."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench._shared.arrays import (
    as_float_array,
    check_dtype_kind,
    check_ndim,
    check_shape,
    check_shape_equality,
)
from sassi_bench.errors import ConfigError, ProcedureError


def test_check_ndim_accepts_one_of_several_and_names_step_cause_and_fix():
    check_ndim([[1, 2]], (2, 3), step="s", name="the image")
    with pytest.raises(ProcedureError) as info:
        check_ndim(np.zeros((2, 3, 4, 5)), (2, 3), step="warp", name="the image", fix="pass one")
    assert str(info.value) == (
        "warp: the image has shape (2, 3, 4, 5), expected a 2-D or 3-D array. Fix: pass one"
    )


def test_check_shape_matches_ints_exactly_and_strs_as_any_length():
    check_shape(np.zeros((7, 2)), ("N", 2), step="s", name="the pixel list")
    check_shape(np.zeros(()), [(), (3, 4)], step="s", name="the dark frame")
    check_shape(np.zeros((3, 4)), [(), (3, 4)], step="s", name="the dark frame")
    for bad in (np.zeros((7, 3)), np.zeros(7), np.zeros((7, 2, 1))):
        with pytest.raises(ProcedureError, match=r"has shape .*, expected \(N, 2\)\. Fix:"):
            check_shape(bad, ("N", 2), step="s", name="the pixel list")


def test_check_shape_says_what_the_expected_shape_is_for():
    with pytest.raises(ProcedureError) as info:
        check_shape(np.zeros(5), (68,), step="models.response", name="the response",
                    expected_for="68 wavelength bins")  # fmt: skip
    assert str(info.value) == (
        "models.response: the response has shape (5,), expected (68,) for 68 wavelength bins. "
        "Fix: pass the response with shape (68,)"
    )


def test_one_dimensional_and_alternative_shapes_read_as_python_tuples():
    with pytest.raises(ProcedureError, match=r"expected \(H, W\), \(H, W, 1\) or \(H, W, 3\)\."):
        check_shape(np.zeros((4, 4, 2)), [("H", "W"), ("H", "W", 1), ("H", "W", 3)],
                    step="s", name="the guide image")  # fmt: skip


@pytest.mark.parametrize("check", [check_ndim, check_shape])
def test_empty_arrays_are_refused_only_when_asked(check):
    expected = 2 if check is check_ndim else ("H", "W")
    check(np.zeros((0, 3)), expected, step="s", name="the image")
    with pytest.raises(ProcedureError, match=r"the image has shape \(0, 3\), which holds no"):
        check(np.zeros((0, 3)), expected, step="s", name="the image", allow_empty=False)


def test_check_shape_equality_names_both_shapes():
    check_shape_equality(np.zeros((2, 3)), [[0, 0, 0], [1, 1, 1]], step="s", names=("a", "b"))
    with pytest.raises(ProcedureError) as info:
        check_shape_equality(np.zeros((2, 3)), np.zeros((3,)), step="fit", names=("x", "y"))
    assert (
        str(info.value)
        == "fit: x (2, 3) and y (3,) differ in shape. Fix: pass x and y of one shape"
    )


@pytest.mark.parametrize(
    ("kinds", "words"),
    [
        ("iu", "integer"),
        ("u", "unsigned integer"),
        ("uf", "unsigned integer or floating-point"),
        ("uif", "real numeric"),
        ("biuf", "boolean or real numeric"),
    ],
)
def test_check_dtype_kind_names_the_kinds_in_words(kinds, words):
    check_dtype_kind(np.zeros(2, np.uint8), kinds, step="s", name="the frame")
    with pytest.raises(ProcedureError, match=f"the frame has dtype complex128, expected {words} "):
        check_dtype_kind(np.zeros(2, complex), kinds, step="s", name="the frame")


def test_as_float_array_converts_numbers_and_refuses_the_rest():
    out = as_float_array([[1, 2], [3, 4]], step="s", name="the cube", dtype=np.float32)
    assert out.dtype == np.float32 and out.tolist() == [[1, 2], [3, 4]]
    same = np.ones(3)
    assert as_float_array(same, step="s", name="the cube") is same
    for bad in (["a", "b"], [[1, 2], [3]]):
        with pytest.raises(ProcedureError, match=r"^s: the cube is not an array of numbers"):
            as_float_array(bad, step="s", name="the cube")


@pytest.mark.parametrize(
    "call",
    [
        lambda error: check_ndim(np.zeros(3), 2, step="s", name="n", error=error),
        lambda error: check_shape(np.zeros(3), (2,), step="s", name="n", error=error),
        lambda error: check_shape_equality([1], [1, 2], step="s", names=("a", "b"), error=error),
        lambda error: check_dtype_kind(np.zeros(3), "b", step="s", name="n", error=error),
        lambda error: as_float_array(["x"], step="s", name="n", error=error),
    ],
)
def test_every_check_raises_the_error_class_the_caller_names(call):
    with pytest.raises(ProcedureError):
        call(ProcedureError)
    with pytest.raises(ConfigError):
        call(ConfigError)
    with pytest.raises(ValueError) as info:
        call(ValueError)
    assert type(info.value) is ValueError and ". Fix: " in str(info.value)
