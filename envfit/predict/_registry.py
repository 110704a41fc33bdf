r"""The registry of predictors (as colour-science's method registries) and its dispatcher.

Every entry has the one signature ``f(ctx: PredictionContext, rule: Rule) -> Prediction``
and reads one kind of :class:`envfit.sampling.Rule` (its ``rule_type``, set by
:func:`envfit.predict._context.reads`):

===============  ====================================  ==============  ========================
name             function                              reads           formula
===============  ====================================  ==============  ========================
plain            :func:`predict_plain`                 QuadratureRule  (b) :math:`\hat\sigma
                                                                       E(\hat s)`
bandlimited      :func:`predict_bandlimited`           QuadratureRule  (b′) :math:`(\hat\sigma'^2
                                                                       \sum_{l\le H-1}
                                                                       a_l(\hat s')\tau_l e_l
                                                                       + (\sum w-1)^2
                                                                       \overline{m^2})^{1/2}`
spectral         :func:`predict_spectral`              QuadratureRule  (c) :math:`(\frac1C
                                                                       \sum_{c,l}\hat P_{l,c}
                                                                       e_l)^{1/2}`
random-variance  :func:`predict_random_variance`       RendererRule    :math:`(\sum_i
                                                                       V_i/n_i)^{1/2}`
warped-spectrum  :func:`predict_warped_spectrum`       RendererRule    :math:`(\sum_{k\ne0}
                                                                       |\sum_i\hat h_i(k)
                                                                       S_i(k)|^2)^{1/2}`
renderer         :func:`predict_renderer`              SamplerRule     the exact MSE of the
                                                                       sampler's randomisation
                                                                       of the renderer's own
                                                                       estimator, over normals
===============  ====================================  ==============  ========================

:func:`predict` is the one way to a prediction: ``envfit validate`` (its quadrature rules and
``--renderer``) and ``envfit advise`` (its quadrature rows and renderer rows) both call it, and ``envfit advise
--renderer NAME`` calls :func:`predict_many` of ``renderer``: a real renderer's model
(:class:`~envfit.predict.renderer.DiffuseModel`, or its microfacet twin) in the context's
``renderer``, one :class:`SamplerRule` (strategy, the renderer's sampler, spp) per cell, all
cells of a search pass in one pass of the model.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from envfit.base import ParameterError

from envfit.predict._bandlimited import predict_bandlimited
from envfit.predict._context import Prediction, PredictionContext, Rule, reads
from envfit.predict._plain import predict_plain
from envfit.predict._spectral import predict_spectral
from envfit.predict.warped._predictor import (predict_random_variance,
                                                predict_warped_spectrum, renderer_predictor)

__all__ = ["PREDICTORS", "Predictor", "predict", "predict_many", "predictors_for",
           "predict_rule", "SamplerRule", "SamplerPrediction", "predict_renderer"]


@dataclass(frozen=True)
class SamplerRule(Rule):
    """A real renderer's cell: a strategy (``mis``, ``map``, ``brdf``), the renderer's sampler
    by its own name, and ``n`` the spp asked (the sampler rounds it as it runs).

    >>> SamplerRule("mis", "independent", 64).label
    'mis/independent'
    """

    strategy: str = ""
    sampler: str = ""

    def __init__(self, strategy: str, sampler: str, n: int):
        object.__setattr__(self, "strategy", str(strategy))
        object.__setattr__(self, "sampler", str(sampler))
        object.__setattr__(self, "n", int(n))

    @property
    def label(self) -> str:
        return f"{self.strategy}/{self.sampler}"


@dataclass(frozen=True)
class SamplerPrediction(Prediction):
    """A :class:`Prediction` of a :class:`SamplerRule`, with the model's whole cell
    (``cell``: its MSE per channel, its parts and its own error,
    :class:`~envfit.predict.renderer.RendererPrediction`)."""

    cell: object = None


def _renderer_cells(ctx: PredictionContext, rules: Sequence[SamplerRule]) -> list:
    """The predictions of ``rules`` by the renderer model of ``ctx``, in one pass of it."""
    ctx.need("renderer", who="renderer")
    cells = ctx.renderer.predict_many([(r.strategy, r.sampler, r.n) for r in rules])
    return [SamplerPrediction("renderer", float(c.rmse), cell=c) for c in cells]


@reads(SamplerRule)
def predict_renderer(ctx: PredictionContext, rule: SamplerRule) -> SamplerPrediction:
    """The RMSE of a real renderer's own estimator at one cell: ``ctx.renderer`` (a
    :class:`~envfit.predict.renderer.DiffuseModel` or
    :class:`~envfit.predict.renderer.MicrofacetModel`) predicts the exact MSE of the sampler's
    randomisation over its normals (frames); :func:`predict_many` predicts many cells in one
    pass."""
    return _renderer_cells(ctx, [rule])[0]


#: the batch form: every cell of a search pass in one pass of the model
predict_renderer.many = _renderer_cells

#: the signature every predictor has
Predictor = Callable[[PredictionContext, Rule], Prediction]

#: the predictors by name, in the order the report lists them
PREDICTORS: dict[str, Predictor] = {
    "plain": predict_plain,
    "bandlimited": predict_bandlimited,
    "spectral": predict_spectral,
    "random-variance": predict_random_variance,
    "warped-spectrum": predict_warped_spectrum,
    "renderer": predict_renderer,
}


def _reads(f: Predictor) -> type:
    """The kind of rule predictor ``f`` reads (any :class:`Rule` when it does not say)."""
    return getattr(f, "rule_type", Rule)


def predictors_for(rule_type: type) -> dict[str, Predictor]:
    """The predictors of :data:`PREDICTORS` that read a ``rule_type`` (in their order).

    >>> from envfit.sampling import QuadratureRule, RendererRule
    >>> list(predictors_for(QuadratureRule)), list(predictors_for(RendererRule))
    (['plain', 'bandlimited', 'spectral'], ['random-variance', 'warped-spectrum'])
    """
    return {k: f for k, f in PREDICTORS.items() if issubclass(rule_type, _reads(f))}


def predict(name: str, ctx: PredictionContext, rule: Rule) -> Prediction:
    """The prediction of the predictor ``name`` of :data:`PREDICTORS` for ``rule`` on ``ctx``.

    Raises
    ------
    envfit.base._errors.ParameterError
        for a name not in :data:`PREDICTORS` (the message lists the names), or a rule of a
        kind the predictor does not read.

    Examples
    --------
    >>> from envfit.sampling import QuadratureRule, RendererRule
    >>> predict("plain", PredictionContext(s=1.5, sigma=3.0), QuadratureRule(n=16, wce=0.5)).rmse
    1.5
    >>> predict("exact", PredictionContext(s=1.5, sigma=3.0), QuadratureRule(n=16))
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: unknown predictor 'exact'; choose from plain, bandlimited, spectral, random-variance, warped-spectrum, renderer
    >>> predict("plain", PredictionContext(s=1.5, sigma=3.0), RendererRule("map", "sf", 16))
    Traceback (most recent call last):
    ...
    envfit.base._errors.ParameterError: predictor 'plain' reads a QuadratureRule, not a RendererRule
    """
    f = _lookup(name, [rule])
    return f(ctx, rule)


def _lookup(name: str, rules) -> Predictor:
    """The predictor ``name`` of :data:`PREDICTORS`, checked against the kind of ``rules``."""
    try:
        f = PREDICTORS[name]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown predictor {name!r}; choose from "
                             f"{', '.join(PREDICTORS)}") from None
    for rule in rules:
        if not isinstance(rule, _reads(f)):
            raise ParameterError(f"predictor {name!r} reads a {_reads(f).__name__}, not a "
                                 f"{type(rule).__name__}")
    return f


def predict_many(name: str, ctx: PredictionContext, rules) -> list[Prediction]:
    """The predictions of the predictor ``name`` of :data:`PREDICTORS` for every rule of
    ``rules`` on ``ctx``: in one call of its batch form where it has one (its ``many``: a
    renderer model's pass serves every cell), else one :func:`predict` each.

    >>> from envfit.sampling import QuadratureRule
    >>> [p.rmse for p in predict_many("plain", PredictionContext(s=1.5, sigma=3.0),
    ...                               [QuadratureRule(n=16, wce=0.5), QuadratureRule(n=64, wce=0.25)])]
    [1.5, 0.75]
    """
    rules = list(rules)
    f = _lookup(name, rules)
    many = getattr(f, "many", None)
    return list(many(ctx, rules)) if many is not None else [f(ctx, r) for r in rules]


def predict_rule(model, rule, *, seed: int = 0) -> Prediction:
    """Shorthand: :func:`predict` of :func:`~envfit.predict.renderer.renderer_predictor`
    (``rule``, a :class:`~envfit.sampling.RendererRule`) on a context holding ``model`` (a
    :class:`~envfit.predict.renderer.RendererModel`; ``seed``: the point seed, as
    :func:`envfit.sampling._rules.rule_points`)."""
    ctx = PredictionContext(renderer=model, point_seed=int(seed))
    return predict(renderer_predictor(rule), ctx, rule)
