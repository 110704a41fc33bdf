"""The registry of renderer presets: :data:`PRESETS` and :func:`preset`."""
from __future__ import annotations

from envfit.base import ParameterError
from envfit.sampling.presets._base import RendererPreset
from envfit.sampling.presets._cycles import CYCLES
from envfit.sampling.presets._envfit import ENVFIT
from envfit.sampling.presets._mitsuba3 import MITSUBA3
from envfit.sampling.presets._pbrt4 import PBRT4

__all__ = ["PRESETS", "preset", "preset_names"]

#: name → :class:`RendererPreset` (``mitsuba3``, ``pbrt4``, ``cycles``, ``envfit``)
PRESETS: dict[str, RendererPreset] = {p.name: p for p in (MITSUBA3, PBRT4, CYCLES, ENVFIT)}


def preset_names() -> tuple[str, ...]:
    """The accepted ``--renderer`` names."""
    return tuple(PRESETS)


def preset(name) -> RendererPreset:
    """The preset called ``name`` (case-insensitive); ParameterError otherwise.

    >>> preset("Mitsuba3").heuristic, preset("envfit").heuristic
    ('power', 'balance')
    """
    key = name.lower() if isinstance(name, str) else name
    try:
        return PRESETS[key]
    except (KeyError, TypeError):
        raise ParameterError(f"--renderer must be one of {', '.join(PRESETS)}; "
                             f"got {name!r}") from None
