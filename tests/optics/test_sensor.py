import numpy as np
import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.optics.sensor import NOISE_BANDS, SensorModel, qe_curve


@pytest.fixture()
def sensor():
    return SensorModel(read_noise_e=5.0, full_well_e=30000.0, bit_depth=16, dark_offset_adu=100)


def test_noise_variance_matches_shot_plus_read_noise(sensor):
    rng = np.random.default_rng(1)
    mean_e = 2000.0
    frame = sensor.expose(np.full((400, 400), mean_e / 0.01), 0.01, rng).astype(np.float64)
    g = sensor.gain_e_per_adu
    mean_e_total = mean_e + sensor.dark_current_e_per_s * 0.01
    assert frame.mean() == pytest.approx(mean_e_total / g + 100, rel=2e-3)
    expected_var = (mean_e_total + 5.0**2) / g**2 + 1 / 12  # + ADC rounding
    assert frame.var() == pytest.approx(expected_var, rel=0.02)


def test_read_noise_alone_in_the_dark(sensor):
    frame = sensor.expose(np.zeros((500, 500)), 1e-4, np.random.default_rng(2)).astype(float)
    assert frame.std() * sensor.gain_e_per_adu == pytest.approx(5.0, rel=0.03)


def test_saturation_clips_at_full_well_and_adc_range(sensor):
    frame = sensor.expose(np.full((10, 10), 1e9), 1.0, np.random.default_rng(3))
    assert frame.dtype == np.uint16
    full = round(30000.0 / sensor.gain_e_per_adu + 100)
    assert np.all(frame == min(full, 65535))
    small = SensorModel(read_noise_e=1.0, full_well_e=1e6, bit_depth=12, dark_offset_adu=10)
    assert small.expose(np.full((4, 4), 1e9), 1.0, np.random.default_rng(4)).max() == 4095


def test_eight_bit_sensor_uses_uint8():
    s = SensorModel(read_noise_e=1.0, full_well_e=5000, bit_depth=8, dark_offset_adu=0)
    assert s.expose(np.zeros((2, 2)), 0.01, np.random.default_rng(0)).dtype == np.uint8


def test_qe_curve_is_smooth_and_bounded():
    qe = qe_curve("scmos")
    lam = np.linspace(380, 750, 200)
    values = qe(lam)
    assert np.all((values > 0) & (values < 1))
    assert lam[np.argmax(values)] == pytest.approx(550, abs=30)
    with pytest.raises(ConfigError):
        qe_curve("nonexistent")
    with pytest.raises(ConfigError):
        qe_curve({400: 0.5, 500: 1.5})


def test_bands_of_rows_are_independent_and_the_stream_decides_the_frame(sensor):
    rate = np.full((64, 32), 5e4)
    a = sensor.expose(rate, 0.01, np.random.default_rng([7, 1]))
    b = sensor.expose(rate, 0.01, np.random.default_rng([7, 1]))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, sensor.expose(rate, 0.01, np.random.default_rng([7, 2])))
    # Each band of rows draws its own stream: no two bands repeat each other's noise.
    bands = a.reshape(NOISE_BANDS, -1, 32).astype(float)
    assert all(not np.array_equal(bands[0], bands[i]) for i in range(1, NOISE_BANDS))
    # A frame with fewer rows than bands still gets every pixel.
    assert sensor.expose(np.zeros((2, 3)), 0.01, np.random.default_rng(0)).shape == (2, 3)
