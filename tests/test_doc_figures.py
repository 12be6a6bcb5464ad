"""The documentation's figures come from one source: the data files the benchmarks write.

Every marked table in the README and the user pages equals what ``benchmarks/figures.py``
renders from ``docs/_data/``, every data file says when, where and how it was measured,
and no dB or dE00 figure is quoted in those files that no data file holds. Package
docstrings and comments quote no measured figure at all: no dB or dE00, no timing of a run
and no before -> after (those belong to ``docs/notes/`` and the benchmarks).
"""

from __future__ import annotations

import importlib.util
import io
import json
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]


def _figures():
    spec = importlib.util.spec_from_file_location("figures", ROOT / "benchmarks" / "figures.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


figures = _figures()
DATA_FILES = sorted((ROOT / "docs" / "_data").glob("*.json"))

#: A measured figure as the documentation quotes one: a number before "dB", or after
#: "dE00" (tolerances and settings are named by their key, not quoted as figures).
FIGURE = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?)(?=\s*dB\b)|dE00\s+(\d+(?:\.\d+)?)")
NUMBER = re.compile(r"\d+(?:\.\d+)?")


def quoted_figures(text: str) -> list[str]:
    """The dB and dE00 figures of ``text``, outside its marked blocks."""
    text = figures.MARKER.sub("", text)
    return [a or b for a, b in FIGURE.findall(text)]


def measured_numbers() -> set[str]:
    """Every number in every value of every data file."""
    numbers = set()
    for path in DATA_FILES:
        for column in json.loads(path.read_text())["columns"]:
            for value in column["values"].values():
                numbers.update(NUMBER.findall(value or ""))
    return numbers


def test_the_readme_is_short_and_keeps_the_commands_ci_runs():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 150
    ci = (ROOT / ".ci" / "run").read_text()
    assert "pip install . && sassi-bench calibrate --rig sim" in readme
    assert 'sassi-bench" calibrate --rig sim' in ci
    assert (
        '.venv/bin/pip install "torch==2.13.0" && .venv/bin/pip install -e ".[dev]" && '
        ".venv/bin/pip install --no-build-isolation fast-slic==0.4.0 && .venv/bin/python -m pytest"
    ) in readme
    readme_args = re.search(r"\.venv/bin/python -m pytest(.*)$", readme, re.MULTILINE)[1]
    assert f'"$py" -m pytest -q{readme_args}\n' in ci, "CI runs the README's test command"


def test_every_data_file_says_when_where_and_how_it_was_measured():
    assert {p.stem for p in DATA_FILES} >= {"accuracy", "snapshot_accuracy"}
    for path in DATA_FILES:
        table = json.loads(path.read_text())
        assert table["title"] and table["rows"], path.name
        for column in table["columns"]:
            assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", column["date"]), (path.name, column)
            assert column["machine"] and column["command"].startswith("python benchmarks/")
            assert set(column["values"]) <= set(table["rows"]), (path.name, column["key"])


@pytest.mark.parametrize("path", figures.marked_files(ROOT), ids=lambda p: p.name)
def test_every_marked_table_equals_its_data_file(path):
    for name, held, rendered in figures.blocks(path.read_text()):
        assert held == rendered, (
            f"{path.relative_to(ROOT)}: the '{name}' table differs from docs/_data/{name}.json;"
            " run `python benchmarks/figures.py`"
        )


def test_the_readme_and_the_accuracy_page_quote_the_tables():
    readme = [name for name, _, _ in figures.blocks((ROOT / "README.md").read_text())]
    page = [name for name, _, _ in figures.blocks((ROOT / "docs/accuracy.md").read_text())]
    assert readme == ["accuracy"]
    assert {"accuracy", "snapshot_accuracy"} <= set(page)
    # The headline's laser cell is the benchmark's own wording, from the data file.
    assert "lamp-anchored: all five at their true lines" in (ROOT / "README.md").read_text()


@pytest.mark.parametrize("path", figures.marked_files(ROOT), ids=lambda p: p.name)
def test_no_page_quotes_a_figure_no_data_file_holds(path):
    measured = measured_numbers()
    stray = [f for f in quoted_figures(path.read_text()) if f not in measured]
    assert not stray, f"{path.relative_to(ROOT)} quotes {stray} (dB / dE00) from no data file"


def test_the_checks_fail_on_a_figure_that_differs(tmp_path):
    """The checks above can fail: a changed cell and a stray figure are both caught."""
    text = (ROOT / "README.md").read_text()
    held, rendered = figures.blocks(text)[0][1:]
    assert held == rendered
    cell = re.search(r"\| (\d+\.\d+ / \d+\.\d+ deg) \|", text).group(1)  # a Macbeth cell
    changed = text.replace(cell, "9.99 / 9.99 deg", 1)
    assert figures.blocks(changed)[0][1] != figures.blocks(changed)[0][2]
    assert figures.render(changed) == text  # rewriting restores the data file's figure
    assert quoted_figures("rank-1 gives 31.37 dB, mean dE00 0.1873") == ["31.37", "0.1873"]
    assert "31.37" not in measured_numbers() and "0.1873" not in measured_numbers()
    # A marked table's own figures are not quoted figures: they are checked as a copy.
    assert quoted_figures(text) == []


def test_the_headline_laser_cell_is_the_benchmarks_own(calibrated_sim):
    """The README's "all five at their true lines" is what accuracy_table.py writes for
    the sim rig's lamp-anchored calibration, scored against the bench's truth."""
    import sys

    from sassi_bench.rig.sim import truth

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        from accuracy_table import laser_cell
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    rig, result, _ = calibrated_sim
    cell = laser_cell(result, truth(rig))
    print(f"\nsim's laser cell: {cell}")
    match = re.fullmatch(r"lamp-anchored: all five at their true lines \(within (\S+) nm\)", cell)
    assert match, cell
    assert float(match[1]) < 0.01  # measured 0.001 nm (0.005 in the transcribed table)


def test_the_benchmarks_merge_their_columns_into_the_data_file(tmp_path):
    rows = ["a figure", "another"]
    figures.update_columns("t", "A table", rows, [{"key": "x", "values": {"a figure": "1 dB"}}],
                           data=tmp_path)  # fmt: skip
    figures.update_columns("t", "A table", rows, [{"key": "y", "values": {"another": "2"}}],
                           data=tmp_path)  # fmt: skip
    table = figures.load("t", tmp_path)
    assert [c["key"] for c in table["columns"]] == ["x", "y"]
    assert table["columns"][0]["command"].startswith("python ")
    assert figures.markdown(table) == (
        "| | x | y |\n| --- | --- | --- |\n| a figure | 1 dB | - |\n| another | - | 2 |\n"
    )


def test_no_package_module_quotes_an_accuracy_figure():
    # Measurements belong to the benchmarks' data files and docs/notes/; a docstring or
    # comment quoting one goes stale the day the code improves.
    quoting = {
        str(path.relative_to(ROOT)): found
        for path in sorted((ROOT / "sassi_bench").rglob("*.py"))
        if (found := quoted_figures(path.read_text(encoding="utf-8")))
    }
    assert quoting == {}
    assert quoted_figures("spectra at 42.1 dB, mean dE00 0.06") == ["42.1", "0.06"]


_SPAN = r"\d+(?:\.\d+)?(?:\s*-\s*\d+(?:\.\d+)?)?"  # 12, 0.4, 50-110
#: A sub-second timing ("took 95 ms", "2.3 ns each"); the word before it, to tell a setting.
_SUBSECOND = re.compile(rf"(?:([^\s(]+)\s+)?(?<![\w.])({_SPAN}\s*(?:ns|µs|us|ms))\b")
#: Words after which a sub-second figure is a setting or a bound, not a measurement
#: ("a 10 ms pulse", "a timeout of at most 20 ms", "the paper's < 2 ms step").
_SETTING = {"a", "an", "every", "each", "wait", "waits", "timeout", "period", "interval",
            "pulse", "exposure", "default", "most", "least", "within", "under", "below",
            "<", ">", "<=", ">=", "="}  # fmt: skip
#: Seconds of a run: after a verb or comparison of one, or before what the time was of.
_SECONDS = re.compile(
    rf"\b(?:took|takes|take|costs?|about|against|instead\s+of|in|->|→)\s+{_SPAN}\s*s\b"
    rf"|(?<![\w.]){_SPAN}\s*s\s+(?:of\s+(?:CPU|wall)|a\s+frame|per\s+frame|with\s+(?:one|two)\b"
    r"|on\s+a\b|instead\b|against\b)"
)
#: A before -> after between numbers ("2.9 -> 1.4 ms", "25 s -> 6"), or a measured speed-up.
_CHANGE = re.compile(
    r"(?<![\w.])\d+(?:\.\d+)?\s*(?:[a-zA-Zµ%]{1,3}\s*)?(?:->|→)\s*\d"
    r"|(?<![\w.])\d+(?:\.\d+)?\s*x\s+(?:faster|slower|less|more)\b"
)


def prose(source: str) -> str:
    """The comments and the triple-quoted strings (docstrings) of Python ``source``."""
    parts = []
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT or (
            token.type == tokenize.STRING and re.match(r"[rRbBuU]*(\'\'\'|\"\"\")", token.string)
        ):
            parts.append(token.string)
    return "\n".join(parts)


def quoted_timings(text: str) -> list[str]:
    """The measured timings and before -> after figures of ``text``."""
    found = [m[2] for m in _SUBSECOND.finditer(text) if (m[1] or "").lower() not in _SETTING]
    found += [m[0] for m in _SECONDS.finditer(text)]
    found += [m[0] for m in _CHANGE.finditer(text)]
    return [" ".join(f.split()) for f in found]


def test_no_package_module_quotes_a_timing_or_a_before_and_after():
    # A constant's or a design's justification is one sentence and a pointer to the note
    # or the benchmark that measured it (docs/notes/2026-12-01-measured-in-code-comments.md).
    quoting = {
        str(path.relative_to(ROOT)): found
        for path in sorted((ROOT / "sassi_bench").rglob("*.py"))
        if (found := quoted_timings(prose(path.read_text(encoding="utf-8"))))
    }
    assert quoting == {}


def test_the_timing_check_fails_on_a_planted_figure_and_passes_settings(tmp_path):
    module = tmp_path / "planted.py"
    module.write_text(
        '''"""A module.

        As numpy the pass took 95 ms of CPU; compiled it takes 9 ms (2.9 -> 1.4 ms, same masks),
        5x faster, and the operators took 0.65 s with two threads, 0.15 s with one.

        Parameters
        ----------
        pulse_wait_s
            How long the trigger counts pulses (a real SLM pulses with its refresh: 0.5 s
            counts about 30); a 10 ms pulse, a timeout of at most 20 ms, the paper's < 2 ms
            step. Exposure (s) per line, 1 + 2 s per row, float32 (8 MB), a 60 Hz SLM.
        """


        def f(exposure_s: float = 0.5) -> float:  # 12 ms on a prototype frame
            return exposure_s * 1000.0  # in ms: a unit, not a figure
        '''
    )
    found = quoted_timings(prose(module.read_text()))
    assert found == ["95 ms", "9 ms", "1.4 ms", "12 ms", "took 0.65 s", "0.15 s with one",
                     "2.9 -> 1", "5x faster"]  # fmt: skip
    # The code itself (a default, a type hint's arrow) is not prose; a unit alone is no figure.
    assert "-> float" not in prose(module.read_text())
    assert "* 1000.0" not in prose(module.read_text())
    assert not quoted_timings("exposure = 0.5  # s")
