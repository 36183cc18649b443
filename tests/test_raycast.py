"""The two ray-casting backends (core.raycast) answer alike: on random rays through a cloud of 20,000 small
triangles, the same first triangle and hit point (to float32 round-off) and the same occlusion, for every ray."""
import numpy as np
import pytest

from core import SettingsError, raycast

pytest.importorskip("embreex", reason="both backends are needed to compare them")
pytest.importorskip("warp", reason="both backends are needed to compare them")


def _queries(name, triangles, origins, directions, monkeypatch):
    monkeypatch.setenv(raycast.BACKEND_VARIABLE, name)
    caster = raycast.RayCaster(triangles, threads=2)
    try:
        hit, bary = caster.first_hit(origins, directions)
        occluded = caster.occluded(origins, directions, np.full(len(origins), 0.5))
        empty = caster.first_hit(origins[:0], directions[:0])
    finally:
        caster.close()
    return hit, bary, occluded, empty


def test_embree_and_warp_agree_on_random_rays(monkeypatch):
    rng = np.random.default_rng(7)
    triangles = rng.uniform(-1, 1, (20000, 1, 3)) + rng.normal(0, 0.05, (20000, 3, 3))
    origins = rng.uniform(-1.5, 1.5, (100000, 3))
    directions = rng.normal(size=(100000, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    embree = _queries("embree", triangles, origins, directions, monkeypatch)
    warp = _queries("warp", triangles, origins, directions, monkeypatch)
    hit = embree[0]
    assert 0.3 < np.mean(hit >= 0) < 0.7  # the test has hits and misses to tell apart
    assert np.array_equal(hit, warp[0])
    found = hit >= 0
    points = [np.einsum("mc,mck->mk", result[1][found], triangles[hit[found]]) for result in (embree, warp)]
    assert np.abs(points[0] - points[1]).max() < 1e-4
    assert np.array_equal(embree[2], warp[2])
    assert [part.shape for part in warp[3]] == [part.shape for part in embree[3]] == [(0,), (0, 3)]


def test_an_unknown_backend_is_refused_by_name(monkeypatch):
    monkeypatch.setenv(raycast.BACKEND_VARIABLE, "optix")
    with pytest.raises(SettingsError, match="RADIOSITY_RAY_BACKEND must be one of embree, warp"):
        raycast.RayCaster(np.zeros((1, 3, 3)))


def test_the_environment_chooses_the_backend(monkeypatch):
    monkeypatch.delenv(raycast.BACKEND_VARIABLE, raising=False)
    assert raycast.backend_name() == "embree"  # the default where embreex is installed
    monkeypatch.setenv(raycast.BACKEND_VARIABLE, "warp")
    assert raycast.backend_name() == "warp"
