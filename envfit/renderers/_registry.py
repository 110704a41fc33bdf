"""The registry of renderers: :data:`RENDERERS` and :func:`get_renderer`; one line per renderer
(its folder's record)."""
from __future__ import annotations

from envfit.base import ParameterError
from envfit.renderers._base import Renderer
from envfit.renderers.cycles import CYCLES
from envfit.renderers.envfit import ENVFIT
from envfit.renderers.mitsuba3 import MITSUBA3
from envfit.renderers.pbrt4 import PBRT4

__all__ = ["RENDERERS", "get_renderer", "renderer_names"]

#: name → :class:`Renderer` (``mitsuba3``, ``pbrt4``, ``cycles``, ``envfit``)
RENDERERS: dict[str, Renderer] = {p.name: p for p in (MITSUBA3, PBRT4, CYCLES, ENVFIT)}


def renderer_names() -> tuple[str, ...]:
    """The accepted ``--renderer`` names."""
    return tuple(RENDERERS)


def get_renderer(name) -> Renderer:
    """The renderer called ``name`` (case-insensitive); ParameterError otherwise.

    >>> get_renderer("Mitsuba3").heuristic, get_renderer("envfit").heuristic
    ('power', 'balance')
    """
    key = name.lower() if isinstance(name, str) else name
    try:
        return RENDERERS[key]
    except (KeyError, TypeError):
        raise ParameterError(f"--renderer must be one of {', '.join(RENDERERS)}; "
                             f"got {name!r}") from None
