"""The adaptive-sampling answer of a renderer (``envfit advise MAP --renderer cycles
--adaptive-threshold T``): at the user's noise threshold, the predicted RMSE and the samples a
pixel spends; and the threshold that meets the advice's target, with its samples (the time it
costs) — predicted by :class:`envfit.predict.renderer._adaptive.AdaptiveModel` through the
renderer's own :attr:`~envfit.renderers.Renderer.adaptive` rule.

Example
-------
>>> import numpy as np
>>> from envfit.maps import EnvMap
>>> from envfit.advisor import RendererAdviseOptions
>>> o = RendererAdviseOptions("cycles", strategies=["brdf"])
>>> a = advise_adaptive(EnvMap(np.full((8, 16, 3), 0.5)), o, 0.01, target_rmse=0.005,
...                     samples=256, normals=4, realizations=16)
>>> a.asked.mean_spp, a.advised_threshold   # cosine sampling of a constant map: no noise
(80.0, 1.0)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from envfit.base import ParameterError
from envfit.renderers import get_renderer

__all__ = ["AdaptiveAdvice", "advise_adaptive", "check_adaptive"]


@dataclass
class AdaptiveAdvice:
    """The adaptive answer: the prediction at the asked threshold (``asked``), and the
    largest threshold the model finds meeting ``target_rmse`` (``advised_threshold``, None if
    even the most samples miss it) with its prediction (``advised``)."""

    possessive: str
    words: str
    target_rmse: float
    asked: object
    advised_threshold: float | None
    advised: object | None

    def _one(self, p) -> str:
        pct = p.spp_percentiles
        se = f" (±{p.model_se:.0%})" if p.model_se is not None else ""
        return (f"predicted RMSE {p.predicted_rmse:.4g}{se}; a pixel takes {p.mean_spp:.0f} "
                f"samples on average (5–95 %: {pct[5]:.0f}–{pct[95]:.0f}; {p.at_most:.0%} "
                f"reach {p.samples})")

    def lines(self) -> list[str]:
        """What ``envfit advise`` prints."""
        a = self.asked
        head = (f"adaptive sampling ({self.possessive} {self.words} {a.threshold:.4g}, Max "
                f"Samples {a.samples}, Min Samples {a.min_samples}, {a.sampler}; the white "
                f"diffuse sphere, uniform normals): ")
        out = [head + self._one(a)]
        if self.advised_threshold is None:
            out.append(f"no {self.words} meets the target RMSE {self.target_rmse:.4g} within "
                       f"{a.samples} samples a pixel (at most {a.fixed[a.samples]:.4g} with "
                       f"every pixel at {a.samples})")
        else:
            out.append(f"the {self.words} that meets the target RMSE {self.target_rmse:.4g}: "
                       f"{self.advised_threshold:.3g} — " + self._one(self.advised))
        return out

    def to_dict(self) -> dict:
        """``renderer.adaptive`` of the JSON: the asked threshold's prediction (threshold,
        predicted_rmse, mean_spp, …) and ``advised``."""
        d = self.asked.to_dict()
        d["target_rmse"] = self.target_rmse
        d["advised"] = (None if self.advised is None else
                        {"threshold": self.advised_threshold, **self.advised.to_dict()})
        return d


def check_adaptive(renderer: str, sampler: str | None, strategies, threshold: float | None,
                   samples: int | None, min_samples: int) -> None:
    """One line, before any work, where the adaptive answer cannot be given."""
    rec = get_renderer(renderer)
    rule = rec.adaptive
    if rule is None:
        raise ParameterError(f"{rec.display} has no adaptive sampling modelled "
                             f"(--adaptive-threshold)")
    if sampler is not None and sampler not in rule.samplers:
        raise ParameterError(f"{rec.possessive} {rule.name} is modelled for the "
                             f"{' and '.join(rule.samplers)} patterns only, not --sampler {sampler}")
    if strategies and strategies[0] not in ("mis", "brdf"):
        raise ParameterError(f"{rule.name} is modelled for the strategies mis and brdf, not "
                             f"{strategies[0]}")
    rule.settings(rule.default_threshold if threshold is None else threshold,
                  rule.default_samples if samples is None else samples, min_samples)


def advise_adaptive(envmap, opts, threshold: float, *, target_rmse: float,
                    samples: int | None = None, min_samples: int = 0, normals: int = 128,
                    realizations: int = 64, seed: int = 0, quiet: bool = True) -> AdaptiveAdvice:
    """The adaptive answer for the renderer of ``opts`` (a
    :class:`~envfit.advisor.RendererAdviseOptions`: its renderer, sampler, first strategy and
    ``sphere_pixels``: each sample at its film position's normal)
    at ``threshold`` (0: the renderer's automatic one), with the threshold that meets
    ``target_rmse``."""
    from envfit.predict.renderer import AdaptiveModel, AdaptiveOptions
    strategies = list(opts.strategies or ["mis"])
    sampler = opts.sampler                              # resolved: the renderer's default
    check_adaptive(opts.renderer, sampler, strategies, threshold, samples, min_samples)
    rec = get_renderer(opts.renderer)
    if not (isinstance(target_rmse, float) and math.isfinite(target_rmse) and target_rmse > 0):
        raise ParameterError(f"the target RMSE must be > 0, got {target_rmse!r}")
    model = AdaptiveModel(envmap, rec, sampler=sampler, strategy=strategies[0],
                          samples=samples, min_samples=min_samples,
                          sphere_pixels=opts.sphere_pixels,
                          options=AdaptiveOptions(normals=normals, realizations=realizations,
                                                  seed=seed), quiet=quiet)
    asked = model.predict(threshold)
    tau, advised = model.threshold_for(target_rmse)
    return AdaptiveAdvice(rec.possessive, rec.adaptive.words, target_rmse, asked, tau, advised)
