"""The renderer advice's spp search (``envfit.advisor._renderer_search.search_spp``) on a
stand-in model with a known law: the crossing it answers, and the passes it spends (the coarse
spp above ``first_cap`` only for the strategies none below it meets)."""
from __future__ import annotations

import math

import pytest

from envfit.advisor._renderer_search import search_spp

LAWS = {"mis": 0.5, "map": 2.0, "brdf": 40.0}           # rmse = c / N^0.75


class _Law:
    """The parts of CachedRendererModel the search reads: predictions by a closed form."""

    def __init__(self):
        self.asked: dict[str, set] = {s: set() for s in LAWS}
        self.passes: list[list] = []

    def predict(self, cells) -> None:
        cells = sorted(set(cells))
        if cells:
            self.passes.append(cells)
        for s, n in cells:
            self.asked[s].add(int(n))

    def asked_spp(self, strategy: str) -> list[int]:
        return sorted(self.asked[strategy])

    def rmse(self, strategy: str, n: int) -> float:
        return LAWS[strategy] / n ** 0.75


def test_first_cap_defers_the_spp_above_it_to_the_open_strategies():
    runnable = [4 ** k for k in range(1, 7)]                   # ldsampler: 4 ... 4096
    target = 0.01
    cm = _Law()
    ans = search_spp(cm, list(LAWS), runnable, target, first_cap=256)
    want = {s: next((n for n in runnable if c / n ** 0.75 <= target), None)
            for s, c in LAWS.items()}
    assert want == {"mis": 256, "map": 4096, "brdf": None}
    assert {s: a.spp for s, a in ans.items()} == want
    assert max(n for _, n in cm.passes[0]) == 256                 # the first pass stops there
    assert {s for s, _ in cm.passes[1]} == {"map", "brdf"}       # then only the open ones
    assert max(cm.asked_spp("mis")) == 256
    assert ans["map"].below == 1024 and math.isclose(ans["map"].below_rmse,
                                                       2.0 / 1024 ** 0.75)
    assert ans["brdf"].searched_max == 4096 and not ans["brdf"].reached


def test_without_first_cap_one_pass_takes_every_coarse_spp():
    runnable = [4 ** k for k in range(1, 7)]
    cm = _Law()
    ans = search_spp(cm, list(LAWS), runnable, 0.01)
    assert len(cm.passes) == 1 and max(cm.asked_spp("mis")) == 4096
    assert ans["mis"].spp == 256


def test_rough_plastic_searches_ldsampler_as_far_as_a_conductor():
    """A rough plastic's lobe choice is sampled above the grid like a conductor's nets, so its
    ``ldsampler`` search goes to the same cap (4096 spp) and its cells stay at the model's
    grid level at any spp (before, the lobe grid had to hold N points: 4096 spp needed level
    12, 16 M points a part, and was refused)."""
    import numpy as np
    from envfit.advisor import RendererAdviseOptions
    from envfit.maps import EnvMap
    from envfit.predict.renderer import MicrofacetModel, band_frames
    from envfit.predict.renderer import RendererModelOptions
    from envfit.renderers import get_renderer
    from envfit.shading.microfacet import RoughPlastic
    kw = dict(renderer="mitsuba3", sampler="ldsampler", roughness=0.2)
    assert RendererAdviseOptions(bsdf="roughplastic", **kw).spp_cap() == 4096
    assert RendererAdviseOptions(bsdf="ggx", **kw).spp_cap() == 4096
    # strata are drawn above the grid on the diffuse surface and over a one-lobe BSDF's
    # frames (level 7, to the strata cap); a two-lobe BSDF's multijitter keeps the level-9
    # grid's exact reach, where its lobe choice is modelled
    mj = dict(kw, sampler="multijitter")
    o = RendererAdviseOptions(bsdf="ggx", **mj)
    assert (o.level, o.spp_cap()) == (7, 4096)
    o = RendererAdviseOptions(bsdf="roughplastic", **mj)
    assert (o.level, o.spp_cap()) == (9, 512)
    assert RendererAdviseOptions(renderer="mitsuba3", sampler="multijitter").spp_cap() == 4096
    m = MicrofacetModel(EnvMap(np.full((8, 16, 3), 2.0)), get_renderer("mitsuba3"),
                        RoughPlastic("ggx", 0.2), band_frames(2, seed=0),
                        options=RendererModelOptions(max_level=4))
    for strategy in ("mis", "brdf", "map"):
        assert m.request(strategy, "ldsampler", 4096).level == 4


@pytest.mark.parametrize("runnable", [[4 ** k for k in range(1, 7)],
                                      [2 ** k for k in range(0, 13)],
                                      list(range(1, 4097)), range(1, 2 ** 31)])
@pytest.mark.parametrize("shift", [0.25, 0.7, 1.0, 1.3, 4.0])
def test_a_search_around_an_earlier_answer_finds_the_full_searchs_crossing(runnable, shift):
    """Started at an earlier model's answer (a sized search's pilot), the search finds the
    crossing the full search finds, with the same predictions at it and at the span's powers
    of two, wherever the new law has moved it (``shift``: the new model's RMSE over the
    earlier one's), and asks fewer spp where it has not moved far."""
    from envfit.advisor._renderer_search import StrategyAnswer
    target = 0.002
    pilot = search_spp(_Law(), ["mis"], runnable, target)["mis"]
    assert pilot.reached

    class _Moved(_Law):
        def rmse(self, strategy, n):
            return shift * super().rmse(strategy, n)

    full_cm, near_cm = _Moved(), _Moved()
    full = search_spp(full_cm, ["mis"], runnable, target)["mis"]
    near = search_spp(near_cm, ["mis"], runnable, target,
                      around={"mis": (pilot, 0.05)})["mis"]
    assert (near.spp, near.below, near.predicted_rmse, near.below_rmse) == \
        (full.spp, full.below, full.predicted_rmse, full.below_rmse)
    assert near.searched_max == full.searched_max
    if full.reached:
        p = 1 << (full.spp.bit_length() - 1)
        for x in (p // 2, p, 2 * p):
            assert (x in full_cm.asked["mis"]) <= (x in near_cm.asked["mis"])
    if shift in (1.0, 1.3):
        assert len(near_cm.asked["mis"]) < len(full_cm.asked["mis"])
    assert isinstance(pilot, StrategyAnswer)
