"""The Principled BSDF's hemispherical reflectance (core.bsdf) against Fresnel's closed form and Cycles."""
import numpy as np
import pytest

from core.bsdf import adjusted_ior, dielectric_albedo, fresnel_dielectric, principled_reflectance


def test_fresnel_at_normal_incidence_and_grazing():
    """F(1) = ((n - 1) / (n + 1))^2 = 0.04 for n = 1.5; F -> 1 at grazing incidence."""
    assert fresnel_dielectric(np.array([1.0]), 1.5)[0] == pytest.approx(0.04, rel=1e-9)
    assert fresnel_dielectric(np.array([1e-6]), 1.5)[0] == pytest.approx(1.0, abs=1e-4)


def test_smooth_glass_reflects_its_published_hemispherical_share():
    """A smooth interface of index 1.5 reflects 0.0918 of diffuse light (the external diffuse reflectance of
    glass, e.g. Duntley 1942; 2 int F(mu) mu dmu). Roughness 0 is clamped to alpha = 1e-6, i.e. smooth."""
    assert dielectric_albedo(1.5, 0.0) == pytest.approx(0.0918, abs=0.0005)


@pytest.mark.parametrize("roughness, measured", [(0.5, 0.0603), (1.0, 0.0224)])
def test_rough_specular_layer_matches_cycles(roughness, measured):
    """Cycles 5.2, a Principled plane (base colour 0) under a uniform white sky, rendered from 8 Gauss-Legendre
    view angles and averaged with weight mu: 0.0603 at roughness 0.5 and 0.0224 at 1 (256 spp; the grazing view
    sees a little horizon, so +-0.003)."""
    assert dielectric_albedo(1.5, roughness) == pytest.approx(measured, abs=0.003)


def test_principled_reflectance_is_affine_in_the_base_colour():
    """Dielectric: S + (1 - S) base (Cycles measured 0.5113 for base 0.5 and 0.8046 for 0.8 at roughness 1);
    Specular IOR Level 0 removes the layer; a metal reflects its base colour; transmission keeps only S."""
    offset, scale = principled_reflectance(1.0, 0.0, 1.5, 0.5, 0.0)
    assert offset + scale == pytest.approx(1.0)
    assert offset + 0.5 * scale == pytest.approx(0.5113, abs=0.003)
    assert offset + 0.8 * scale == pytest.approx(0.8046, abs=0.003)
    assert principled_reflectance(0.5, 0.0, 1.5, 0.0, 0.0) == pytest.approx((0.0, 1.0))
    assert principled_reflectance(0.5, 1.0, 1.5, 0.5, 0.0) == pytest.approx((0.0, 1.0))
    assert principled_reflectance(0.5, 0.0, 1.5, 0.5, 1.0) == pytest.approx((dielectric_albedo(1.5, 0.5), 0.0))


def test_specular_ior_level_scales_normal_incidence_reflectance():
    """Level 1 doubles F0: 0.08 for n = 1.5, i.e. n = (1 + sqrt 0.08) / (1 - sqrt 0.08)."""
    doubled = adjusted_ior(1.5, 1.0)
    assert ((doubled - 1) / (doubled + 1)) ** 2 == pytest.approx(0.08)
    assert adjusted_ior(1.5, 0.5) == pytest.approx(1.5)
