"""How a renderer draws: map samplers, BSDF sampling and MIS, sources, rules."""
