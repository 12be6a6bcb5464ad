"""``batch validate``: each chart scan's Macbeth scores are those of the serial
``validate_scans`` on the same session, and a re-run reads them back instead of scoring
again."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from sassi_bench.acquire.session import Session
from sassi_bench.batch import run_batch
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.scan import assemble_scan
from sassi_bench.validate.chart import validate_scans


def test_batch_scores_equal_the_serial_validation_and_a_rerun_reads_them(
    chart, client, corners, tmp_path
):
    data, bundle = chart
    kwargs = {"data": data, "client": client, "progress": False, "corners": corners}
    batch = run_batch("validate", ["scan-chart"], bundle, tmp_path, **kwargs)
    (result,) = batch.results
    assert result.status == "done", result.error
    procedure = load_procedure("macbeth_validation")
    procedure["white_reference"]["source"] = "patch"
    scan = assemble_scan(
        Session.open("scan-chart", data=data), bundle, keep_raw=True, progress=False
    )
    serial = validate_scans(scan, bundle, procedure, corners=corners)
    assert result.metrics == {**serial.summary(), "passed": serial.passed}
    assert np.isfinite(result.metrics["mean_de00"])
    again = run_batch("validate", ["scan-chart"], bundle, tmp_path, **kwargs)
    assert again.results[0].status == "skipped"
    assert again.results[0].metrics == result.metrics
    with open(again.summary_csv) as stream:
        (row,) = csv.DictReader(stream)
    assert float(row["mean_de00"]) == pytest.approx(result.metrics["mean_de00"], abs=5e-4)
