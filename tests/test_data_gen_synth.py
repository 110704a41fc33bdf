"""The synth kinds' registry (envfit.data_gen.SYNTH_KINDS, synthesize): each kind is its generator
called with its parameters, each offset policy is the arithmetic it states, and the registry is
what ``envfit synth --kind`` offers. Oracles: the generators called directly (the registry must
add nothing but its stated offset), closed forms of the analytic maps, the marker's axes."""
from __future__ import annotations

import numpy as np
import pytest

from envfit.data_gen import (SYNTH_KINDS, ConstantMap, SkyGradientMap, StepMap, SunGPOptions,
                             SunSkyMap, SyntheticMapError, gaussian_process_map, sht,
                             sun_gp_map, synth_kind_names, synthesize)
from envfit.data_gen._synth import GP_OFFSET, SUN_GP_OFFSET

H = 16


def test_registry_is_the_cli_kinds():
    from envfit.cli._synth import KINDS
    assert KINDS == synth_kind_names() == tuple(SYNTH_KINDS)
    assert set(SYNTH_KINDS) == {"gp", "sun-gp", "constant", "sky", "sun", "step", "marker"}
    with pytest.raises(TypeError):
        SYNTH_KINDS["new"] = None                       # read-only
    for name, spec in SYNTH_KINDS.items():
        assert spec.name == name and (spec.offset is None) == ("offset" not in spec.params)


@pytest.mark.parametrize("kind", [k for k in SYNTH_KINDS if k != "marker"])
def test_every_kind_with_its_defaults(kind):
    m = synthesize(kind, H, seed=1)
    assert m.data.shape[:2] == (H, 2 * H) and np.all(np.isfinite(m.data))
    assert m.to_dict()["kind"] == kind and m.to_dict()["height"] == H


def test_gp_auto_offset_is_its_stated_policy():
    m = synthesize("gp", H, seed=5, s0=1.3, channels=2, amplitude=0.7)
    f = gaussian_process_map(1.3, H, seed=5, channels=2, scale=0.7)   # the sample, no offset
    off = -f.min() + 0.1 * (f.max() - f.min())
    assert m.record["offset"] == off
    np.testing.assert_array_equal(m.data, f + off)
    assert np.isclose(m.data.min(), 0.1 * (f.max() - f.min()))        # every pixel positive
    given = synthesize("gp", H, seed=5, s0=1.3, channels=2, amplitude=0.7, offset=-2.0)
    np.testing.assert_array_equal(given.data, f - 2.0)
    assert given.record["offset"] == -2.0


def test_sun_gp_offset_policy_and_sun():
    m = synthesize("sun-gp", H, seed=2, amplitude=0.5, sun_radiance=(30.0, 20.0, 10.0))
    f, sun = sun_gp_map(H, seed=2, sun_radiance=(30.0, 20.0, 10.0), channels=3, offset=2.0,
                        scale=0.5, sun_radius=0.05, options=SunGPOptions(method="sht"))
    assert f.min() > 0                                    # no lift needed: 4 x amplitude
    np.testing.assert_array_equal(m.data, f)
    assert m.record["offset"] == 2.0 and m.sun.radiance.tolist() == [30.0, 20.0, 10.0]
    assert m.record["sun"]["solid_angle"] == pytest.approx(2 * np.pi * (1 - np.cos(0.05)))
    # the lift: a map still negative after 4 x amplitude is raised by -min + 0.1 offset
    neg = np.array([[-3.0, 1.0]])
    lifted, offset = SUN_GP_OFFSET.resolve(lambda o: (neg + o,), 0.25, "auto")
    assert offset == 1.0 + (3.0 - 1.0 + 0.1) and lifted.min() == pytest.approx(0.1)
    same, off = GP_OFFSET.resolve(lambda o: (neg + o,), 1.0, 0.5)         # a number: as given
    np.testing.assert_array_equal(same, neg + 0.5)
    assert off == 0.5


def test_analytic_kinds_are_their_maps():
    for kind, params, m in (
            ("constant", {"value": [2.0, 3.0]}, ConstantMap((2.0, 3.0))),
            ("sky", {}, SkyGradientMap((0.6, 0.7, 0.8), (0.2, 0.35, 0.9))),
            ("sun", {"sun_radius": 0.2, "sky": [0.5]}, SunSkyMap(0.6, 1.0, 0.2, 200.0, 0.5)),
            ("step", {"low": 0.0, "high": [1.0], "theta_edge": 1.0}, StepMap(0.0, 1.0, 1.0))):
        s = synthesize(kind, H, **params)
        np.testing.assert_array_equal(s.data, m.render(H))
        assert s.record == {"map": repr(m)} and repr(s.analytic) == repr(m)
    # the closed form rides along: a constant map's normalised diffuse integral is its value
    s = synthesize("constant", H, value=4.0)
    assert s.analytic.diffuse_integral([0.0, 0.0, 1.0]).tolist() == [4.0]


def test_marker_default_directions_local_frame():
    s = synthesize("marker", 32)
    dirs = sht.grid_directions(32)
    top = np.unravel_index(np.argmax(s.data.sum(axis=2)), s.data.shape[:2])
    assert dirs[top] @ np.array([1.0, 0.0, 0.0]) > np.cos(3 * np.pi / 32)    # +x, brightest
    assert s.record["marker_radius"] == 3 * np.pi / 32 and s.record["markers"]["+x"]["amplitude"] == 10


def test_errors_are_one_line_value_errors():
    with pytest.raises(SyntheticMapError, match="unknown synthetic map kind 'cloud'"):
        synthesize("cloud", H)
    with pytest.raises(SyntheticMapError, match="takes no parameter s0; its parameters: value"):
        synthesize("constant", H, s0=1.5)
    with pytest.raises(SyntheticMapError, match="at least 2"):
        synthesize("gp", 1)
    with pytest.raises(ValueError):
        synthesize("gp", H, s0=2.5)
