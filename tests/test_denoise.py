"""The gather's denoiser against known truth: a page whose true indirect light is given, with Gaussian noise of a
known variance added. Averaging n independent texels divides the noise's standard deviation by sqrt(n); a real
step of the light, many times the noise, must stay where it is; another chart beside it in the atlas must not mix
in; and light without noise passes unchanged."""
import numpy as np
import pytest

from core.denoise import denoise_gathered

SIZE, TEXEL_M = 48, 0.1


def flat_page(rows=SIZE, columns=SIZE, height_m=0.0):
    """Texels of a rows x columns chart on the plane z = height_m, facing up, 0.1 m apart."""
    y, x = np.mgrid[:rows, :columns]
    points = np.stack([x.ravel() * TEXEL_M, y.ravel() * TEXEL_M, np.full(x.size, height_m)], axis=1)
    return (y * columns + x).ravel(), points, np.tile([0.0, 0.0, 1.0], (x.size, 1))


def noisy(truth, relative_sd, seed=0):
    sd = relative_sd * truth
    return truth + np.random.default_rng(seed).normal(size=truth.shape) * sd, sd ** 2


def test_noise_falls_and_a_step_stays():
    """Light 1.0 left of the middle and 4.0 right of it (a bounce off a bright wall), with 10% noise. The filter's
    two passes of 3 x 3 windows, the second's texels 2 apart, average each texel with 7 x 7 texels, weighted
    (1, 1, 2, 1, 2, 1, 1) along each axis: with every neighbour's weight 1 that divides the noise by 6.2, its
    bound. Neighbours that differ only by their noise keep weights near 1, so the noise over the whole page must
    fall below a fifth (one pass over 5 x 5 texels left 0.22 of it), and the columns on either side of the step
    keep their own level within 3% (blurring over the step would move them by a fifth of it or more, 60% on the
    dark side)."""
    pixel, points, normals = flat_page()
    column = pixel % SIZE
    truth = np.where(column < SIZE // 2, 1.0, 4.0)[:, None] * np.ones(3)
    light, variance = noisy(truth, 0.1)
    filtered = denoise_gathered(pixel, SIZE, SIZE, points, normals, np.full(len(pixel), TEXEL_M), light, variance)
    relative_error = lambda values: np.sqrt(np.mean(((values - truth) / truth) ** 2))
    assert relative_error(filtered) < 0.2 * relative_error(light)
    for side in (SIZE // 2 - 1, SIZE // 2):
        at = column == side
        assert filtered[at].mean() == pytest.approx(truth[at].mean(), rel=0.03)


def test_another_chart_beside_it_in_the_atlas_does_not_mix_in():
    """Two charts side by side on the page, one on the floor (light 1.0) and one on a ceiling 3 m above (light
    0.8), with the same 10% noise: close enough in value to be averaged by their noise alone (which would pull the
    floor's edge column about 7% down), but another surface. The floor's texels beside the ceiling's keep their
    level within 2%."""
    pixel, points, normals = flat_page(columns=SIZE // 2)
    pixel = (pixel // (SIZE // 2)) * SIZE + pixel % (SIZE // 2)
    ceiling_points = points + [SIZE // 2 * TEXEL_M, 0.0, 3.0]
    all_pixel = np.concatenate([pixel, pixel + SIZE // 2])
    all_points = np.concatenate([points, ceiling_points])
    truth = np.concatenate([np.full(len(pixel), 1.0), np.full(len(pixel), 0.8)])[:, None] * np.ones(3)
    light, variance = noisy(truth, 0.1, seed=1)
    filtered = denoise_gathered(all_pixel, SIZE, SIZE, all_points, np.concatenate([normals, normals]),
                                np.full(len(all_pixel), TEXEL_M), light, variance)
    edge = np.flatnonzero(all_pixel % SIZE == SIZE // 2 - 1)
    assert filtered[edge].mean() == pytest.approx(1.0, rel=0.02)


def test_light_without_noise_passes_unchanged():
    """A gradient along x with zero variance: a neighbour in another column differs by more than its noise
    (none) and counts for nothing, one in the same column holds the same value, so each texel keeps its own value
    (to round-off)."""
    pixel, points, normals = flat_page()
    light = (1.0 + 0.05 * (pixel % SIZE))[:, None] * np.ones(3)
    filtered = denoise_gathered(pixel, SIZE, SIZE, points, normals, np.full(len(pixel), TEXEL_M), light,
                                np.zeros_like(light))
    np.testing.assert_allclose(filtered, light, rtol=1e-12)


@pytest.mark.parametrize("guided", [True, False])
def test_corners_darker_than_the_span_by_its_noise_keep_their_level_by_their_close_hits(guided):
    """A span lit 1.0 with 20% noise holds 64 corner texels (every sixth in each direction) lit 0.45 with 3% noise:
    the courtyard's soffit corners, where most gather rays meet the next arch a few centimetres away (little
    noise, less light) beside the open span. The corner differs from each neighbour by under three of the span's
    standard deviations, so by the light alone eight neighbours count and pull it up. Their shares of close hits
    out of 36 rays, 0.85 at the corners and 0.2 on the span, differ by many times their binomial noise: guided by
    them, the corners' mean stays within 3% of 0.45 (its own noise over 64 corners is 0.5%; measured 0.449);
    unguided, it rises past 0.6 (measured 0.81). The span's noise still falls below a quarter (measured 0.18 of
    it, as unguided)."""
    pixel, points, normals = flat_page()
    x, y = pixel % SIZE, pixel // SIZE
    corner = (x % 6 == 3) & (y % 6 == 3)
    truth = np.where(corner, 0.45, 1.0)[:, None] * np.ones(3)
    light, variance = noisy(truth, np.where(corner, 0.03 / 0.45, 0.2)[:, None], seed=2)
    share = np.where(corner, 0.85, 0.2)
    filtered = denoise_gathered(pixel, SIZE, SIZE, points, normals, np.full(len(pixel), TEXEL_M), light, variance,
                                guide=(share, 36) if guided else None)
    corner_level = filtered[corner].mean()
    if guided:
        assert corner_level == pytest.approx(0.45, rel=0.03)
    else:
        assert corner_level > 0.6   # the test can fail: the light alone lets the span in
    span_error = lambda values: np.sqrt(np.mean((values[~corner] - truth[~corner]) ** 2))
    assert span_error(filtered) < span_error(light) / 4
