r"""Exact error predictions for every way a renderer randomises the N points of a pixel:
independent, jittered (stratified), correlated multi-jittered, random digital (XOR) shift,
Owen-scrambled nets and Cranley–Patterson shifts, all from one input — the warped integrand h
on the unit square summarised on a dyadic grid (:class:`DyadicGrid`) — and the cross term of
two techniques' streams (MIS).

Modules (private, one per method; each cites its equation and reference):

* ``_grid`` — :class:`DyadicGrid` (cell means of h and h², the variance; from a callable or
  arrays) and :class:`RandomisedMSE` (mse per channel, resolved / above the grid).
* ``_strata`` — moments over the rectangles of a product partition.
* ``_walsh`` — Walsh coefficients by the fast Walsh–Hadamard transform; dyadic block sums.
* ``_nets`` — the digital nets' generator matrices and dual nets (:data:`NETS`).
* ``_independent``, ``_jittered``, ``_cmj``, ``_orthogonal``, ``_digital_shift``, ``_owen``,
  ``_cp_shift`` — the
  methods.
* ``_shift_samples`` — the digital shift's power above the grid sampled over random shifts
  (:func:`shift_sample`, :func:`sampled_above`): the digital shift for any N.
* ``_owen_samples`` — nested uniform scrambles of a net (:func:`owen_sample`), whose power
  above the grid :func:`sampled_above` estimates likewise: Owen scrambling for any N.
* ``_strata_samples`` — correlated multi-jittered and orthogonal-array point sets drawn
  (:func:`strata_points`) and their MSE as the variance over the draws
  (:func:`sampled_strata_mse`): those samplers above their exact models' reach.
* ``_shared_sequence`` — runs of one fixed scrambled sequence shared by every pixel
  (:func:`shared_sequence_mse`): a sampler whose pixels differ only by where they read it.
* ``_registry`` — :data:`RANDOMISATIONS` and the dispatcher :func:`randomised_mse`.
* ``_mis`` — :func:`mis_mse`, two streams, independent or sharing one point set.
* ``_lobe_choice`` — :func:`lobe_choice_mse`, :func:`lobe_choice_mis`: a BSDF that picks
  one of two lobes by a stratified 1-D number of its own (a rough plastic).

A renderer's own variant of a method (its strata's shape, its hashed permutations' law) is
an option value its sampler's record gives (:attr:`envfit.renderers.SamplerSpec.options`);
nothing here knows a renderer.

The names of ``__all__`` are imported lazily, on first use (PEP 562), so that
importing the package loads none of its modules.
"""
from __future__ import annotations

from envfit.base import lazy_exports

_LAZY = {
    "DyadicGrid": "_grid", "RandomisedMSE": "_grid",
    "DigitalNet": "_nets", "NETS": "_nets",
    "cmj_shape": "_cmj", "uniform_pair_table": "_cmj",
    "owen_gains": "_owen",
    "walsh_coefficients": "_walsh",
    "ShiftSample": "_shift_samples", "shift_sample": "_shift_samples",
    "sampled_above_prefixes": "_shift_samples",
    "sampled_above": "_shift_samples",
    "owen_sample": "_owen_samples", "owen_scramble": "_owen_samples",
    "RANDOMISATIONS": "_registry", "Randomisation": "_registry", "randomised_mse": "_registry",
    "STRATA_SAMPLED": "_strata_samples", "strata_points": "_strata_samples",
    "sampled_strata_mse": "_strata_samples", "ALWAYS_DRAWN": "_strata_samples",
    "sampled_mse": "_strata_samples",
    "shared_sequence_mse": "_shared_sequence",
    "MisMSE": "_mis", "mis_mse": "_mis",
    "STRATIFIED_1D": "_lobe_choice", "lobe_choice_mse": "_lobe_choice",
    "lobe_choice_mis": "_lobe_choice",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
