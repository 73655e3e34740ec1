"""Early vision without a body: eq. 3.8–3.9's shift on synthetic eye images, and the Zernike compass."""

import numpy as np
import pytest

from neuronav import ConfigError, PortError
from neuronav.brains.vision import (
    ZernikeBasis,
    beacon_shift,
    compass_command,
    landmark_offset_px,
    radial_polynomial,
    zernike_orders,
)

W, H = 74, 19


def eye_with_blob(first_column: int, width: int = 4) -> np.ndarray:
    image = np.full((H, W), 0.8)
    image[5:15, first_column:first_column + width] = 0.0
    return image


def test_landmark_offset_is_centre_minus_the_mean_dark_column():
    # Columns 10..13: mean centre 12.0 (pixel c's centre at c + 0.5); δ = 37 - 12 = 25.
    assert landmark_offset_px(eye_with_blob(10))[0] == pytest.approx(25.0)
    assert np.isnan(landmark_offset_px(np.full((H, W), 0.8))[0])


@pytest.mark.parametrize("first_column, expected", [(0, -3), (10, -3), (30, -1), (35, 0), (40, 1), (70, 3)])
def test_shift_sign_and_size_follow_eq_3_8(first_column, expected):
    # Left of centre (small columns) -> negative shift (a left turn); size ceil(|6 δ / W|).
    image = eye_with_blob(first_column)
    delta = W / 2 - (first_column + 2.0)
    assert expected == -np.sign(delta) * np.ceil(abs(6 * delta / W))
    assert beacon_shift(image, None)[0, 0] == expected
    assert beacon_shift(None, image)[0, 0] == expected


def test_binocular_shift_averages_the_eyes_and_uses_one_eye_alone_when_only_it_sees():
    left, right = eye_with_blob(50), eye_with_blob(20)  # δ = -15 and +15: centred between the eyes
    assert beacon_shift(left, right)[0, 0] == 0
    blank = np.full((H, W), 0.8)
    assert beacon_shift(blank, right)[0, 0] == beacon_shift(None, right)[0, 0] == -2
    assert beacon_shift(blank, blank)[0, 0] == 0  # nothing seen: keep the current heading


def test_shift_is_batched():
    batch = np.stack([eye_with_blob(0), eye_with_blob(70), np.full((H, W), 0.8)])
    assert beacon_shift(batch).tolist() == [[-3.0], [3.0], [0.0]]


def test_bad_eye_images_are_refused():
    with pytest.raises(PortError, match="left eye, the right eye"):
        beacon_shift(None, None)
    with pytest.raises(PortError, match="shape"):
        beacon_shift(np.zeros(5))
    with pytest.raises(PortError, match="NaN"):
        beacon_shift(np.full((H, W), np.nan))
    with pytest.raises(PortError, match="differ in shape"):
        beacon_shift(np.zeros((H, W)), np.zeros((H, W + 1)))


def test_radial_polynomials_match_their_closed_forms():
    rho = np.linspace(0, 1, 11)
    assert np.allclose(radial_polynomial(7, 1, rho), 35 * rho**7 - 60 * rho**5 + 30 * rho**3 - 4 * rho)
    assert np.allclose(radial_polynomial(2, 0, rho), 2 * rho**2 - 1)
    assert np.allclose(radial_polynomial(4, 4, rho), rho**4)
    assert radial_polynomial(7, 1, 1.0) == pytest.approx(1.0)
    assert len(zernike_orders(16)) == 81


def test_amplitudes_are_invariant_and_the_phase_moves_one_for_one_with_a_column_roll():
    rng = np.random.default_rng(0)
    basis = ZernikeBasis(72, 72)
    for _ in range(5):
        panorama = rng.random((72, 72))
        z0 = basis.moments(panorama)[0]
        for roll in (1, 3, -7, 20):
            z = basis.moments(np.roll(panorama, roll, axis=1))[0]
            assert np.allclose(np.abs(z), np.abs(z0), rtol=0, atol=1e-12)
            for k, (_, m) in enumerate(basis.orders):
                if m and abs(z0[k]) > 1e-9:
                    # A roll by +1 column (the scene moving right) lowers the phase by m * 5°.
                    moved = np.angle(z[k] / z0[k])
                    assert moved == pytest.approx(np.angle(np.exp(-1j * m * np.radians(5.0 * roll))), abs=1e-9)
        compass = basis.compass_phase(np.roll(panorama, -2, axis=1))[0] - basis.compass_phase(panorama)[0]
        assert np.angle(np.exp(1j * compass)) == pytest.approx(np.radians(10.0))


def test_a_pattern_of_one_zernike_mode_has_that_moment_largest():
    basis = ZernikeBasis(144, 144, n_max=8)
    rho = (np.arange(72) + 0.5) / 72
    phi = ((np.arange(144) + 0.5) / 144 - 0.5) * 2 * np.pi
    for n, m in ((7, 1), (4, 2), (6, 0)):
        pattern = np.zeros((144, 144))
        pattern[:72] = radial_polynomial(n, m, rho)[:, None] * np.cos(m * phi)[None, :]
        amplitudes = basis.amplitudes(pattern)[0]
        assert basis.orders[int(np.argmax(amplitudes))] == (n, m)
        # Orthogonality: Z_{n,m} of R_{n,m} cos(mφ) is 1/2 for m > 0 (the e^{±imφ} halves), 1 for m = 0.
        assert amplitudes[basis.orders.index((n, m))] == pytest.approx(1.0 if m == 0 else 0.5, abs=0.02)


def test_compass_command_turns_back_toward_the_stored_direction():
    basis = ZernikeBasis(72, 72)
    rng = np.random.default_rng(3)
    panorama = rng.random((72, 72))
    stored = basis.compass_phase(panorama)[0]
    # Turned right by 10°: the scene moves left by two columns in the panorama.
    turned_right = basis.compass_phase(np.roll(panorama, -2, axis=1))[0]
    turn, stride = compass_command(turned_right, stored)
    assert turn == 1.0 and stride == pytest.approx(np.radians(2.0))  # a left turn, S_l = 10°/5
    turn, _ = compass_command(basis.compass_phase(np.roll(panorama, 2, axis=1))[0], stored)
    assert turn == -1.0
    assert compass_command(stored + np.radians(0.5), stored) == (0.0, 0.0)  # inside the 0.8° dead band
    assert compass_command(stored + np.pi - 0.01, stored)[1] == pytest.approx(np.radians(179.43 / 5), abs=1e-3)


def test_bad_compass_inputs_are_refused():
    basis = ZernikeBasis(72, 72)
    with pytest.raises(PortError, match="72"):
        basis.compass_phase(np.zeros((36, 72)))
    with pytest.raises(ConfigError, match="n_max >= 7"):
        ZernikeBasis(72, 72, n_max=5).compass_phase(np.zeros((72, 72)))
    with pytest.raises(ConfigError, match="finite"):
        compass_command(np.nan, 0.0)
    with pytest.raises(ConfigError, match="rows"):
        ZernikeBasis(72, 72, rows=0)
