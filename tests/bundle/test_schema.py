"""Schema versions, migrations, and property-based tests with malformed manifests."""

from __future__ import annotations

import copy
import json
import shutil
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from jsonschema import Draft202012Validator

from sassi_bench.bundle import (
    BundleError,
    BundleSchemaError,
    BundleSchemaWarning,
    CalibrationBundle,
    UnsupportedSchemaError,
    load,
    loader,
)
from sassi_bench.bundle.integrity import format_manifest_checksum, sha256_bytes
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.bundle.migrations import MigrationRegistry
from sassi_bench.bundle.schema import SCHEMA_VERSION, manifest_schema
from sassi_bench.errors import SassiBenchError


def read_manifest(path: Path) -> dict[str, Any]:
    return json.loads((path / "manifest.json").read_text())


def write_manifest(path: Path, manifest: Any) -> None:
    raw = json.dumps(manifest).encode()
    (path / "manifest.json").write_bytes(raw)
    (path / "manifest.sha256").write_text(format_manifest_checksum(sha256_bytes(raw)))


def test_schema_ships_in_the_package_and_is_valid():
    text = resources.files("sassi_bench.bundle").joinpath("manifest.schema.json").read_text()
    Draft202012Validator.check_schema(json.loads(text))
    assert manifest_schema()["properties"]["schema"]["const"] == "sassi-bench/calibration-bundle"


def test_newer_major_is_refused_with_a_clear_message(published: Path):
    manifest = read_manifest(published)
    manifest["schema_version"] = "2.0.0"
    write_manifest(published, manifest)
    with pytest.raises(UnsupportedSchemaError) as info:
        load(published)
    message = str(info.value)
    assert "2.0.0" in message  # the version found
    assert f"1.0.0 to {SCHEMA_VERSION}" in message  # the versions supported
    assert "Fix: upgrade sassi-bench" in message


def test_older_major_is_refused(published: Path):
    manifest = read_manifest(published)
    manifest["schema_version"] = "0.9.0"
    write_manifest(published, manifest)
    with pytest.raises(UnsupportedSchemaError, match=r"0\.9\.0"):
        load(published)


def test_older_minor_is_migrated(published: Path, monkeypatch):
    # Pretend this sassi-bench writes 1.1.0, in which blur got a required "units" key; the
    # bundle on disk is a 1.0.0 one, so the migration must add it.
    manifest = read_manifest(published)
    manifest["schema_version"] = "1.0.0"
    write_manifest(published, manifest)
    registry = MigrationRegistry("1.1.0")
    calls = []

    @registry.register("1.0", "1.1")
    def add_blur_units(manifest: dict[str, Any]) -> dict[str, Any]:
        calls.append(manifest["schema_version"])
        manifest["models"]["blur"]["units"] = "px"
        return manifest

    monkeypatch.setattr(loader.migrations, "REGISTRY", registry)
    bundle = load(published)
    assert calls == ["1.0.0"]
    assert bundle.migrated_from == "1.0.0"
    assert bundle.manifest["schema_version"] == "1.1.0"
    assert bundle.manifest["models"]["blur"]["units"] == "px"
    # The files on disk are untouched.
    assert read_manifest(published)["schema_version"] == "1.0.0"


def test_missing_migration_is_refused(published: Path, monkeypatch):
    monkeypatch.setattr(loader.migrations, "REGISTRY", MigrationRegistry("1.9.0"))
    with pytest.raises(UnsupportedSchemaError, match=r"no migration from schema version 1\.1"):
        load(published)


def test_a_1_0_bundle_loads_with_its_rows_in_wavelength(published: Path):
    # Schema 1.0 had no y_index_coeffs: its rows are the quadratic in wavelength.
    manifest = read_manifest(published)
    manifest["schema_version"] = "1.0.0"
    manifest["models"]["dispersion"].pop("y_index_coeffs", None)
    write_manifest(published, manifest)
    bundle = load(published)
    assert bundle.migrated_from == "1.0.0"
    assert bundle.manifest["schema_version"] == SCHEMA_VERSION
    model = bundle.models.dispersion
    assert not model.row_in_index
    np.testing.assert_array_equal(model.row_coordinate([400.0]), model.spectral_y([400.0]))


def test_newer_minor_loads_with_a_warning(published: Path):
    manifest = read_manifest(published)
    manifest["schema_version"] = "1.7.0"
    manifest["future_key"] = {"anything": 1}
    write_manifest(published, manifest)
    with pytest.warns(BundleSchemaWarning, match="1.7.0"):
        bundle = load(published)
    assert bundle.version == "v0001"


def test_not_a_bundle_manifest(published: Path):
    write_manifest(published, {"schema": "something-else"})
    with pytest.raises(BundleSchemaError, match="not a sassi-bench calibration bundle"):
        load(published)


def test_schema_error_names_the_key(published: Path):
    manifest = read_manifest(published)
    manifest["models"]["blur"]["window_sigmas"] = "wide"
    write_manifest(published, manifest)
    with pytest.raises(BundleSchemaError, match=r"models\.blur\.window_sigmas: 'wide' is not"):
        load(published)


def test_malformed_model_with_valid_schema(published: Path):
    manifest = read_manifest(published)
    manifest["models"]["blur"]["coeffs"] = [-5.0, 0.0, 0.0]
    write_manifest(published, manifest)
    with pytest.raises(BundleSchemaError, match="sigma must be > 0"):
        load(published)
    manifest["models"]["blur"]["coeffs"] = [1.0, 0.0, 2.0]
    manifest["models"]["response"] = {"array": "missing_array"}
    write_manifest(published, manifest)
    with pytest.raises(BundleSchemaError, match="names array 'missing_array'"):
        load(published)


# ---------------------------------------------------------------------------------------------
# Property-based: whatever the manifest says, load() returns a complete bundle or raises a
# BundleError -- never another exception, never a partly built object.
# ---------------------------------------------------------------------------------------------

json_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=12),
)
json_values = st.recursive(
    json_scalars,
    lambda children: st.one_of(
        st.lists(children, max_size=4), st.dictionaries(st.text(max_size=8), children, max_size=4)
    ),
    max_leaves=10,
)


def key_paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    """Every path (tuple of keys / indices) into a JSON value."""
    paths = [prefix] if prefix else []
    if isinstance(value, dict):
        for key, item in value.items():
            paths.extend(key_paths(item, (*prefix, key)))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            paths.extend(key_paths(item, (*prefix, index)))
    return paths


def mutate(manifest: dict, path: tuple, action: str, new_value: Any) -> dict:
    out = copy.deepcopy(manifest)
    parent = out
    for key in path[:-1]:
        parent = parent[key]
    if action == "delete":
        del parent[path[-1]]
    else:
        parent[path[-1]] = new_value
    return out


@pytest.fixture(scope="module")
def template(tmp_path_factory, synthetic) -> Path:
    return synthetic.publish_synthetic(tmp_path_factory.mktemp("template"))


def fresh_copy(template: Path) -> Path:
    target = Path(tempfile.mkdtemp(dir=template.parent.parent)) / "bundle"
    shutil.copytree(template, target)
    return target


def load_outcome(path: Path) -> CalibrationBundle | BundleError:
    try:
        return load(path)
    except BundleError as exc:
        return exc
    except SassiBenchError as exc:  # pragma: no cover - would be a bug: wrong family
        pytest.fail(f"{type(exc).__name__} is not a BundleError: {exc}")
    finally:
        shutil.rmtree(path.parent, ignore_errors=True)


HYPOTHESIS = settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@HYPOTHESIS
@given(data=st.data())
def test_mutated_manifests_fail_cleanly(template: Path, data):
    manifest = read_manifest(template)
    paths = key_paths(manifest)
    path = data.draw(st.sampled_from(paths), label="path")
    action = data.draw(st.sampled_from(["delete", "replace"]), label="action")
    new_value = data.draw(json_values, label="value") if action == "replace" else None
    mutated = mutate(manifest, path, action, new_value)
    bundle_dir = fresh_copy(template)
    write_manifest(bundle_dir, mutated)
    outcome = load_outcome(bundle_dir)
    # The oracle: the manifest schema itself, applied here independently of the loader.
    schema_valid = not any(Draft202012Validator(manifest_schema()).iter_errors(mutated))
    if not schema_valid:
        assert isinstance(outcome, BundleError), (
            f"{action} {path}: loaded a manifest the schema refuses"
        )
        assert str(outcome)
    elif isinstance(outcome, CalibrationBundle):
        # Loaded: complete and usable, and it is the mutated manifest (nothing dropped).
        assert thaw(outcome.manifest) == mutated
        assert outcome.wavelengths.shape == (68,)
        x, _ = outcome.slm_to_camera(10, 10, outcome.wavelengths)
        assert np.all(np.isfinite(x))
    else:
        # Schema-valid but refused: only a check beyond the schema (array checksums,
        # shapes, model contract) may refuse it, and it says so.
        assert isinstance(outcome, BundleError) and str(outcome)
    required = manifest_schema()["required"]
    if action == "delete" and len(path) == 1 and path[0] in required:
        assert not schema_valid and isinstance(outcome, BundleError)


@HYPOTHESIS
@given(value=json_values)
def test_random_json_manifest_fails_cleanly(template: Path, value):
    bundle_dir = fresh_copy(template)
    write_manifest(bundle_dir, value)
    assert isinstance(load_outcome(bundle_dir), BundleError)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    name=st.sampled_from(
        ["dispersion_x_coeffs", "bin_edges_nm", "bin_centres_nm", "guide_to_slm", "response"]
    ),
    shape=st.lists(st.integers(0, 12), min_size=0, max_size=3),
    fill=st.sampled_from(["random", "nan", "zeros", "huge", "int"]),
    seed=st.integers(0, 2**16),
)
def test_rehashed_malformed_arrays_fail_cleanly(template: Path, name, shape, fill, seed):
    rng = np.random.default_rng(seed)
    array = {
        "random": lambda: rng.normal(0, 100, shape),
        "nan": lambda: np.full(shape, np.nan),
        "zeros": lambda: np.zeros(shape),
        "huge": lambda: np.full(shape, 1e300),
        "int": lambda: rng.integers(-5, 5, shape),
    }[fill]()
    bundle_dir = fresh_copy(template)
    file = bundle_dir / "arrays" / f"{name}.npy"
    np.save(file, array, allow_pickle=False)
    manifest = read_manifest(bundle_dir)
    manifest["arrays"][name].update(
        sha256=sha256_bytes(file.read_bytes()), dtype=array.dtype.str, shape=list(array.shape)
    )
    write_manifest(bundle_dir, manifest)
    outcome = load_outcome(bundle_dir)
    assert isinstance(outcome, (BundleError, CalibrationBundle))
