"""The dwell model's cached two-ray fallback equals shipradar.sensors.propagation.two_ray_factor."""

import numpy as np
import pytest

from shipradar.sensors.propagation import horizon_range, interference_region_limit, two_ray_factor
from shipradar.sim.dwell.model import DwellModel
from shipradar.sim.dwell.prepared import TwoRayFallback
from shipradar.tables.scene import SceneTables

from .helpers import bare_scene, quiet_radar


@pytest.mark.parametrize("pol, pattern, wave", [
    ("H", {"type": "cosec2", "sidelobe_db": 20, "tilt_deg": 3}, 0.0),
    ("V", {"type": "sinc", "sidelobe_db": 25}, 2.5),
    ("H", {"type": "isotropic"}, 1.0),
])
def test_cached_fallback_equals_two_ray_factor(pol, pattern, wave):
    radar = quiet_radar(polarization=pol, pattern_el=pattern, frequency_hz=3.1e9,
                        antenna_height_m=25.0, beamwidth_el_deg=12.0)
    s = bare_scene(radar=radar, propagation="two_ray")
    m = DwellModel(s, s.platforms[0], s.platforms[0].radars[0], SceneTables())
    fb = TwoRayFallback(m.radar, wave, m.elevation_pattern)
    rng = np.random.default_rng(4)
    heights = np.array([0.0, 3.0, 5.0, 150.0, 3385.0, 8001.0])
    h = rng.choice(heights, 400)
    d_h = horizon_range(25.0, h)
    d_lim = interference_region_limit(25.0, h, 3.1e9)
    # every region: inside the limit, the intermediate region, beyond the horizon
    d = np.concatenate([rng.uniform(0, 1, 100) * d_lim[:100],
                        d_lim[100:200] + rng.uniform(0, 1, 100) * (d_h - d_lim)[100:200],
                        d_h[200:] * rng.uniform(1.0, 1.5, 200)])
    ref = two_ray_factor(d, 25.0, h, 3.1e9, pol, wave_height_m=wave,
                         elevation_pattern=m.elevation_pattern)
    for _ in range(2):  # cold cache, then warm
        np.testing.assert_allclose(fb(d, h), ref, rtol=1e-12, atol=1e-300)
    assert len(fb._cache) == heights.size
    assert fb(np.zeros(0), np.zeros(0)).shape == (0,)
    with pytest.raises(ValueError):
        fb(np.array([-1.0]), np.array([5.0]))


def test_cache_is_bounded():
    s = bare_scene(propagation="two_ray")
    m = DwellModel(s, s.platforms[0], s.platforms[0].radars[0], SceneTables())
    fb = TwoRayFallback(m.radar, 0.0, m.elevation_pattern)
    fb.MAX_HEIGHTS = 10
    h = np.linspace(1.0, 500.0, 25)
    d = np.full(25, 5e3)
    ref = two_ray_factor(d, m.radar.antenna_height_m, h, m.radar.frequency_hz, "H",
                         elevation_pattern=m.elevation_pattern)
    np.testing.assert_allclose(fb(d, h), ref, rtol=1e-12)
    assert len(fb._cache) <= 10
