"""Work on threads in order, behind a progress bar."""

from __future__ import annotations

import pytest

from sassi_bench._shared.threads import run_in_order


@pytest.mark.parametrize("workers", [1, 2])
def test_results_come_in_order_behind_a_bar(capsys, workers):
    assert run_in_order(lambda x: 2 * x, [3, 1, 2], "doubles", True, workers) == [6, 2, 4]
    assert "doubles: 100%" in capsys.readouterr().err


def test_no_items_show_no_bar(capsys):
    assert run_in_order(lambda x: x, [], "scan frames", True, 2) == []
    assert capsys.readouterr().err == ""
