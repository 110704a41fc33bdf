r"""The 2-D digital nets renderers randomise, by their generator matrices, and their dual nets.

A digital net in base 2 with 2^m points: point j has coordinate d with binary digits
:math:`\xi^{(d)} = C_d\,\vec\jmath` (mod 2), :math:`\vec\jmath` the bits of j. Column t of
:math:`C_d` is stored as a 32-bit *direction integer* :math:`v_t` whose top bit is the first
digit, so :math:`x^{(d)}_j = 2^{-32}\,\mathrm{XOR}_{t:\,j_t = 1} v_t`.

* ``"sobol"`` — the (0, 2)-sequence of Sobol's first two dimensions: :math:`u_1` van der
  Corput (:math:`v_t = 2^{31-t}`, the identity columns 0x80000000, 0x40000000, …) and
  :math:`u_2` Sobol's second dimension, the Pascal matrix mod 2 (:math:`v_0 = 2^{31}`,
  :math:`v_{t+1} = v_t \oplus (v_t \gg 1)`: 0x80000000, 0xc0000000, 0xa0000000, 0xf0000000,
  0x88000000, … — Joe & Kuo's table), the columns XORed as here. Its first 2^m points are a
  (0, m, 2)-net. Which renderers' samplers draw it, and where their sources hold these
  columns, their folders say.

The dual net (Dick & Pillichshammer 2010, Def. 4.76): with :math:`\mathrm{tr}_m(k)` the digit
vector of :math:`k \bmod 2^m`,

.. math::  D^* = \{k\in\mathbb N_0^2:\; C_1^\top\mathrm{tr}_m(k_1) \oplus
           C_2^\top\mathrm{tr}_m(k_2) = 0\},

and :math:`\frac1N\sum_j \mathrm{wal}_k(x_j) = 1` on :math:`D^*`, 0 elsewhere (the character
sum over the subgroup). Membership depends on the low m bits of each index only.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envfit.base import ParameterError

from ._walsh import bit_reverse

__all__ = ["DigitalNet", "NETS", "net_exponent"]

_BITS = 32


def _van_der_corput() -> np.ndarray:
    return (np.uint64(1) << (np.uint64(31) - np.arange(_BITS, dtype=np.uint64))).astype(np.uint64)


def _sobol_second() -> np.ndarray:
    v = [1 << 31]
    for _ in range(_BITS - 1):
        v.append(v[-1] ^ (v[-1] >> 1))
    return np.array(v, dtype=np.uint64)


@dataclass(frozen=True)
class DigitalNet:
    """A 2-D digital sequence in base 2 by its direction integers (32 per coordinate)."""

    name: str
    directions: tuple[np.ndarray, np.ndarray]

    def digits(self, m: int) -> np.ndarray:
        """The first 2^m points as 32-bit integers (x = value / 2^32), shape (2^m, 2)."""
        j = np.arange(1 << m, dtype=np.uint64)
        out = np.zeros((j.size, 2), dtype=np.uint64)
        for d in range(2):
            for t in range(m):
                bit = (j >> np.uint64(t)) & np.uint64(1)
                out[:, d] ^= bit * self.directions[d][t]
        return out

    def points(self, m: int) -> np.ndarray:
        """The first 2^m points in [0, 1)², shape (2^m, 2)."""
        return self.digits(m).astype(np.float64) / 2.0 ** _BITS

    def dual_residues(self, m: int) -> np.ndarray:
        r"""Boolean (2^m, 2^m): residues :math:`(r_1, r_2)` (mod 2^m) of :math:`D^*`."""
        r = np.arange(1 << m, dtype=np.int64)
        rev = bit_reverse(r, _BITS).astype(np.uint64)      # digit s of k at bit 31 − s
        c = []
        for d in range(2):
            code = np.zeros(r.size, dtype=np.int64)
            for t in range(m):
                word = rev & self.directions[d][t]
                parity = np.zeros(r.size, dtype=np.int64)
                for s in range(_BITS):
                    parity ^= ((word >> np.uint64(s)) & np.uint64(1)).astype(np.int64)
                code |= parity << t
            c.append(code)
        return c[0][:, None] == c[1][None, :]

    def dual_mask(self, m: int, size: int) -> np.ndarray:
        """Boolean (size, size): the indices below ``size`` that are in :math:`D^*` (read only,
        made once per net, m and size)."""
        key = (self.name, int(m))
        if (key, int(size)) in _MASKS:
            return _MASKS[key, int(size)]
        if key not in _RESIDUES:              # the nets are fixed: their residues once
            _RESIDUES[key] = self.dual_residues(m)
        res = _RESIDUES[key]
        k = np.arange(size) % (1 << m)
        mask = res[np.ix_(k, k)]
        mask.flags.writeable = False          # shared: read only
        _MASKS[key, int(size)] = mask
        return mask


#: dual-net residues per (net, m), computed once (:meth:`DigitalNet.dual_mask`)
_RESIDUES: dict = {}
#: the masks :meth:`DigitalNet.dual_mask` gave, per ((net, m), size) (a few: the grid sizes)
_MASKS: dict = {}

NETS = {"sobol": DigitalNet("sobol", (_van_der_corput(), _sobol_second()))}


def net_exponent(n: int, grid_size: int | None) -> int:
    """m with N = 2^m, checked against the grid: digital nets need N a power of two and
    N ≤ M (the grid must resolve the net's elementary intervals) unless ``grid_size`` is None
    (the power above the grid is sampled: :mod:`._shift_samples`)."""
    if n < 1 or n & (n - 1):
        raise ParameterError(f"digital nets take N = 2^m points, got N = {n} (a sampler of "
                             f"such nets rounds its spp up to a power of two)")
    m = n.bit_length() - 1
    if grid_size is not None and n > grid_size:
        raise ParameterError(f"N = {n} points need a grid of at least {n} cells per side, "
                             f"got M = {grid_size}")
    return m


def get_net(name: str) -> DigitalNet:
    """The net called ``name`` (a key of :data:`NETS`)."""
    if name not in NETS:
        raise ParameterError(f"unknown net {name!r}; known: {', '.join(sorted(NETS))}")
    return NETS[name]
