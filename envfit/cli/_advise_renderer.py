"""``envfit advise MAP --renderer NAME``: the answer in the renderer's own terms (spp of its
sampler, its integrator's settings, the scene text): its arguments, its checked options
(:class:`~envfit.advisor.RendererAdviseOptions`), its run through
:func:`envfit.advisor.advise_with` and its print.

Without ``--renderer`` none of this runs and ``envfit advise`` is unchanged; the options of
this module given without it are one-line errors (:func:`reject_without_renderer`).
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from envfit.base import ParameterError
from envfit.cli._advise_rules import options_from_args, rules_lines
from envfit.cli._common import load_map_from_args, out_dir
from envfit.cli._parse import finite_float
from envfit.cli._output import CommandOutput
from envfit.cli._ranges import Ranged, name_words
from envfit.defaults import MICROFACET_BSDFS

#: the renderer model's ranges of --renderer-level, --renderer-normals and --sphere-pixels
#: (RendererModelOptions.__post_init__'s; tests/test_advise_options_sweep.py checks both ends)
_MODEL_RANGES = {"max_level": (1, 11), "normals": (1, 4096), "sphere_pixels": (4, 1 << 16)}

__all__ = ["add_renderer_arguments", "bsdf_param", "bsdf_param_words", "bsdf_params_of",
           "reject_without_renderer", "renderer_options_from_args", "run_renderer"]

#: options that only make sense with --renderer (dest → flag)
_RENDERER_ONLY = {"sampler": "--sampler", "spp": "--spp", "snippet": "--snippet",
                "mis_compensation": "--mis-compensation", "rules": "--rules",
                "renderer_level": "--renderer-level", "renderer_normals": "--renderer-normals",
                "renderer_model_error": "--renderer-model-error",
                "roughness": "--roughness", "bsdf_param": "--bsdf-param",
                "sphere_pixels": "--sphere-pixels",
                "adaptive_threshold": "--adaptive-threshold",
                "adaptive_samples": "--adaptive-samples",
                "adaptive_min_samples": "--adaptive-min-samples"}
#: options of envfit's generic renderer rows, which --renderer replaces
_GENERIC_ROWS = {"no_renderer": "--no-renderer", "renderer_pointsets": "--renderer-pointsets",
                 "renderer_grid": "--renderer-grid",
                 "renderer_spectrum_axes": "--renderer-spectrum-axes",
                 "renderer_axes_start": "--renderer-axes-start",
                 "renderer_max_axes": "--renderer-max-axes"}


def add_renderer_arguments(p) -> None:
    """The ``--renderer`` group of ``envfit advise`` (its name lists read from the renderer
    registry and :data:`envfit.defaults.MICROFACET_BSDFS`, so that they cannot drift)."""
    from envfit.renderers import RENDERERS
    g = p.add_argument_group("advice in a renderer's terms (--renderer)")
    g.add_argument("--renderer", default=None, metavar="|".join(RENDERERS),
                   help="answer in this renderer's terms: the spp its sampler must run for the "
                        "target, with its integrator's settings, predicted for its own "
                        "estimator (emitter density and warp, BSDF sampling, MIS, sampler); "
                        "the first lines printed; envfit's generic tables only with --rules")
    g.add_argument("--sampler", default=None, metavar="NAME", help=sampler_help())
    spp = Ranged(1, None, "N", many=True)
    g.add_argument("--spp", type=spp, default=None, metavar="16,64,256",
                   help=f"also list the predicted RMSE of every strategy at these spp (as the "
                        f"sampler rounds them); distinct, each {spp}, at most --nmax")
    g.add_argument("--snippet", action="store_true",
                   help="print the scene text of the recommendation, in the renderer's own "
                        "terms (its scene description or script settings)")
    g.add_argument("--mis-compensation", action="store_true",
                   help=f"{_or([r.display for r in RENDERERS.values() if r.mis_compensation])}"
                        f": the envmap's mis_compensation (its sampling density minus the "
                        f"mean luminance)")
    g.add_argument("--rules", action="store_true",
                   help="with --renderer: also envfit's table of quadrature rules and SH/HSH "
                        "truncations (the fit and its search: slower)")
    _add_model_arguments(g)
    _add_adaptive_arguments(g)


def _add_adaptive_arguments(g) -> None:
    """The adaptive sampling of a renderer that has it (Cycles' Noise Threshold)."""
    from envfit.renderers import RENDERERS
    having = _or([r.display for r in RENDERERS.values() if r.adaptive is not None])
    tau = Ranged(0, None, "T", integer=False)
    g.add_argument("--adaptive-threshold", type=tau, default=None, metavar="T",
                   help=f"{having}: also predict adaptive sampling at this noise threshold, "
                        f"{tau} (Blender's Noise Threshold; 0: its automatic one), the RMSE "
                        f"and the samples a pixel takes, and advise the threshold that meets "
                        f"the target")
    most, least = Ranged(1, 1 << 24, "N"), Ranged(0, 1 << 24, "M")
    g.add_argument("--adaptive-samples", type=most, default=None, metavar="N",
                   help=f"with --adaptive-threshold: the most samples a pixel takes, {most} "
                        f"(Blender's Max Samples; default 4096)")
    g.add_argument("--adaptive-min-samples", type=least, default=None, metavar="M",
                   help=f"with --adaptive-threshold: Blender's Min Samples, {least} (default "
                        f"0: its automatic rule)")


def sampler_help() -> str:
    """``--sampler``'s help: each renderer's samplers from the renderer registry."""
    from envfit.renderers import RENDERERS
    lists = "; ".join(f"{p.display}: {name_words(p.samplers, p.default_sampler)}"
                      for p in RENDERERS.values())
    return (f"the renderer's sampler by its own name ({lists}); default: the renderer's "
            f"default; one the noise model cannot predict is refused with the reason")


def roughness_help() -> str:
    """``--roughness``'s help: each renderer's unit and range (its record's roughness
    convention, :meth:`envfit.renderers.RoughnessConvention.words`)."""
    from envfit.renderers import RENDERERS
    words = "; ".join([r.roughness.words() for r in RENDERERS.values() if r.roughness]
                      + [c.words() for r in RENDERERS.values()
                         for c in r.bsdf_roughness.values()])
    return (f"with a microfacet --brdf: the renderer's own roughness, in its range ("
            f"{words}; checked with --renderer)")


def bsdf_param(text: str) -> tuple[str, float]:
    """``NAME=VALUE`` → (name, value): the name checked by the renderer's BSDF, the value a
    finite number."""
    name, eq, value = text.partition("=")
    if not eq or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name.strip(), finite_float(value)


def bsdf_param_words() -> str:
    """``--bsdf-param``'s help: each renderer's BSDFs with parameters, and their defaults."""
    from envfit.renderers import RENDERERS
    return "; ".join(f"{r.possessive} {b}: " + ", ".join(f"{k} {v:g}" for k, v in d.items()
                                                         if k != "roughness")
                     for r in RENDERERS.values() for b, d in r.bsdf_params.items())


def _add_model_arguments(g) -> None:
    """The renderer model's grid level, normals, roughness and pixels."""
    level, normals, pixels = (Ranged(*_MODEL_RANGES[k], name) for k, name in
                              (("max_level", "L"), ("normals", "K"), ("sphere_pixels", "D")))
    g.add_argument("--renderer-level", type=level, default=None, metavar="L",
                   help=f"the renderer model's finest grid level, M = 2^L cells per side, "
                        f"{level} (default 7 for independent and stratified samplers, 9 "
                        f"for the others; the digital nets - {_net_words()} - are searched to "
                        f"4^(L+1)/256 spp, their power above the grid sampled beyond 2^(L-1) "
                        f"spp; each level costs 4x the time and memory). Without it and "
                        f"--renderer-normals, the digital nets on the diffuse surface are "
                        f"modelled at level 7, sized to --renderer-model-error (independent "
                        f"and stratified samplers: their normals sized)")
    g.add_argument("--renderer-normals", type=normals, default=None, metavar="K",
                   help=f"normals of the renderer model's importance sample, {normals} "
                        f"(default 48, or sized); with a microfacet --brdf the frames "
                        f"(normal, view)")
    error = Ranged(0, 1, "E", integer=False, lo_open=True, hi_open=True)
    g.add_argument("--renderer-model-error", type=error, default=None, metavar="E",
                   help=f"the sized renderer model's own error, the relative standard error "
                        f"of its predicted RMSE from its normals and scrambles, {error} "
                        f"(default 0.05): "
                        f"a pilot (48 normals, 16 scrambles) and, where its error at the "
                        f"answer is larger, more of either")
    g.add_argument("--roughness", type=finite_float, default=None, metavar="R",
                   help=roughness_help())
    g.add_argument("--bsdf-param", type=bsdf_param, action="append", default=None,
                   metavar="NAME=VALUE",
                   help=f"a parameter of a --brdf that has its own, by the renderer's name "
                        f"(repeat for several; the rest keep the renderer's defaults): "
                        f"{bsdf_param_words()}")
    g.add_argument("--sphere-pixels", type=pixels, default=None, metavar="D",
                   help=f"the sphere's diameter on screen in pixels, {pixels}; adds the "
                        f"error of each pixel's footprint (the normals a pixel spans: large for "
                        f"sharp lobes and grazing views on small objects, and at high spp for "
                        f"QMC samplers; 4x the model's work). Default: every pixel a point")


def _net_words() -> str:
    """``--renderer-level``'s help: the samplers of the digital nets whose power above the
    grid is sampled, by renderer (from the renderer registry)."""
    from envfit.advisor import SIZED_RANDOMISATIONS
    from envfit.renderers import RENDERERS
    words = {"owen": "Owen-scrambled", "digital_shift": "digitally shifted"}
    out = []
    for rand in SIZED_RANDOMISATIONS:
        each = [f"{r.possessive} {', '.join(names)}" for r in RENDERERS.values()
                if (names := [n for n, s in r.samplers.items() if s.randomisation == rand])]
        if each:
            out.append(f"{words.get(rand, rand)} ({'; '.join(each)})")
    return " and ".join(out)


def reject_without_renderer(args: argparse.Namespace) -> None:
    """A --renderer option given without --renderer: one line."""
    from envfit.renderers import RENDERERS
    for dest, flag in _RENDERER_ONLY.items():
        if getattr(args, dest, None) not in (None, False):
            raise ParameterError(f"{flag} needs --renderer ({', '.join(RENDERERS)})")
    if getattr(args, "brdf", "diffuse") in MICROFACET_BSDFS:
        raise ParameterError(f"--brdf {args.brdf} needs --renderer "
                             f"({', '.join(r.name for r in RENDERERS.values() if r.microfacet)}): "
                             f"the microfacet model predicts a renderer's own estimator")


def bsdf_params_of(pairs) -> dict:
    """The ``--bsdf-param`` pairs as a dict; a name given twice is one line."""
    out = {}
    for name, value in pairs or ():
        if name in out:
            raise ParameterError(f"--bsdf-param {name} is given twice")
        out[name] = value
    return out


def renderer_options_from_args(args: argparse.Namespace):
    """The checked :class:`RendererAdviseOptions` and, with --rules, :class:`AdviseOptions`
    (every conflict a one-line error, before the map is read)."""
    from envfit.advisor import RendererAdviseOptions
    _reject_negative(args)
    for dest, flag in _GENERIC_ROWS.items():
        if getattr(args, dest, None) not in (None, False):
            raise ParameterError(f"{flag} is an option of envfit's generic renderer rows, "
                                 f"which --renderer replaces")
    if args.brdf not in ("diffuse", *MICROFACET_BSDFS):
        raise ParameterError(f"--renderer predicts a renderer's BSDF: --brdf diffuse, "
                             f"{', '.join(MICROFACET_BSDFS)} (the paper's {args.brdf} lobe is "
                             f"no renderer's BSDF)")
    if args.brdf in MICROFACET_BSDFS and args.snippet and not _writes_microfacet(args.renderer):
        raise ParameterError(f"--snippet with --brdf {args.brdf}: the scene text of a rough "
                             f"conductor is written for {_or(_microfacet_snippets())} only so far")
    if args.scale != "linear":
        raise ParameterError("--renderer predicts the renderer's noise in radiance: --scale "
                             "must be linear")
    if args.check and not args.rules:
        raise ParameterError("--check measures envfit's own rules: with --renderer give "
                             "--rules too (bench/render_check.py renders the renderer itself)")
    if args.nmin is not None and args.nmax is not None and args.nmax < args.nmin:
        raise ParameterError(f"--nmax {args.nmax} is below --nmin {args.nmin}")
    if args.nmin is not None and not args.rules:     # the renderer search starts at 1 spp
        raise ParameterError("--nmin sizes envfit's rules (--rules); with --renderer the "
                             "search starts at the sampler's smallest spp")
    _check_adaptive_args(args)
    popts = RendererAdviseOptions(
        args.renderer, sampler=args.sampler, strategies=args.strategies, spp=args.spp or (),
        mis_compensation=args.mis_compensation, max_spp=args.nmax,
        level=args.renderer_level,
        normals=args.renderer_normals, bsdf=args.brdf, roughness=args.roughness,
        bsdf_params=bsdf_params_of(args.bsdf_param), sphere_pixels=args.sphere_pixels,
        quiet=args.quiet,
        model_error=args.renderer_model_error, target_rmse=args.target_rmse,
        target_relative=args.target_relative, snippet=args.snippet,
        cache=not args.no_cache, cache_dir=args.cache_dir)
    rules = None
    if args.rules:
        args.strategies, args.no_renderer = None, True
        rules = options_from_args(args)
    return popts, rules


def _microfacet_snippets() -> list[str]:
    """The renderers whose snippet writes a microfacet BSDF, by their display names."""
    from envfit.renderers import RENDERERS
    return [r.display for r in RENDERERS.values() if "microfacet" in r.snippet_options()]


def _writes_microfacet(name) -> bool:
    """Whether renderer ``name``'s snippet writes a microfacet BSDF (unknown: True, the name
    is refused with the registry's own line)."""
    from envfit.renderers import RENDERERS
    rec = RENDERERS.get(str(name).lower())
    return rec is None or "microfacet" in rec.snippet_options()


def _or(names) -> str:
    """``a, b or c``."""
    names = list(names)
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"


def _reject_negative(args: argparse.Namespace) -> None:
    """--allow-negative with --renderer: one line naming what that renderer does with negative
    radiance (the renderer models are for non-negative maps)."""
    if getattr(args, "allow_negative", False):
        from envfit.renderers import RENDERERS
        rec = RENDERERS.get(str(args.renderer).lower())
        why = (rec.negative_radiance if rec is not None else
               "the renderer models are for non-negative maps")
        raise ParameterError(f"--allow-negative with --renderer {args.renderer}: {why}; drop "
                             f"--allow-negative (negative values are then clamped to 0, "
                             f"as noted)")


def _file_rows(path) -> int | None:
    """The rows of the image file ``path`` from its header (None if it cannot be read: loading
    it then says why)."""
    try:
        import OpenImageIO as oiio
        inp = oiio.ImageInput.open(str(path))
        if not inp:
            return None
        rows = int(inp.spec().height)
        inp.close()
        return rows
    except Exception:       # noqa: BLE001 - any reader failure: load_envmap reports it
        return None


def _changes(args: argparse.Namespace, env=None) -> list[str]:
    """What makes the map the model sees differ from MAP's file as the renderer reads it (the
    built-in map, --convention, --max-height, cleaned values; before the map is read, ``env``
    None, the first three); [] when the model sees the file's own pixels."""
    if args.map is None:
        return ["the built-in map (no MAP given)"]
    out = []
    if args.convention is not None:
        out.append(f"converted from the {args.convention} layout (--convention)")
    rows = _file_rows(args.map)
    if args.max_height is not None and rows is not None and rows > args.max_height:
        size = (f"{rows} rows to {args.max_height}" if env is None else
                f"to {env.width} x {env.height}")
        out.append(f"downscaled {size} (--max-height)")
    if env is not None:
        out += [n for n in env.notes if n.startswith(("clamped ", "replaced "))]
    return out


def _snippet_file(args: argparse.Namespace, env, out) -> tuple[str, str | None]:
    """(the file the snippet names, a note or None): MAP itself, or — where the model sees
    other pixels (:func:`_changes`) — the map it sees, written to --out; without --out, one
    line (a snippet names the file whose pixels were predicted). ``env`` None: only that
    check, before the map is read."""
    changes = _changes(args, env) if args.snippet else []
    if not changes:
        return (str(args.map) if args.map is not None else "envmap.exr"), None
    if out is None:
        raise ParameterError(f"--snippet: the model sees another map than MAP's file "
                             f"({'; '.join(changes)}); give --out DIR to have that map "
                             f"written there for the snippet")
    if env is None:
        return "", None
    from envfit.maps import save_envmap
    stem = "envfit-default" if args.map is None else Path(args.map).stem
    path = save_envmap(Path(out) / f"{stem}-as-modelled.exr", env)
    return str(path), (f"the snippet reads {path}, the map the model saw "
                       f"({'; '.join(changes)}), written there")


def _check_adaptive_args(args: argparse.Namespace) -> None:
    """The adaptive options: one line before any work where they cannot be answered."""
    if getattr(args, "adaptive_threshold", None) is None:
        for dest in ("adaptive_samples", "adaptive_min_samples"):
            if getattr(args, dest, None) is not None:
                raise ParameterError(f"{_RENDERER_ONLY[dest]} needs --adaptive-threshold")
        return
    if getattr(args, "library", False):
        raise ParameterError("--adaptive-threshold answers one map at a time so far")
    from envfit.advisor import check_adaptive
    check_adaptive(args.renderer, args.sampler, args.strategies, args.adaptive_threshold,
                   args.adaptive_samples, args.adaptive_min_samples or 0)


def _adaptive(args: argparse.Namespace, env, ropts, adv, output: CommandOutput):
    """The adaptive answer (:func:`envfit.advisor._renderer_adaptive.advise_adaptive`) at the
    advice's target, printed; its JSON, or None without --adaptive-threshold."""
    if args.adaptive_threshold is None:
        return None
    from envfit.advisor import advise_adaptive
    a = advise_adaptive(env, ropts, args.adaptive_threshold, target_rmse=adv.target_rmse,
                        samples=args.adaptive_samples,
                        min_samples=args.adaptive_min_samples or 0, quiet=args.quiet)
    output.say(*a.lines())
    return {**a.to_dict(), "seconds": a.asked.seconds if a.advised is None else
            a.advised.seconds}


def _result(env, adv, rules, notes: list) -> dict:
    """The JSON: the rules' (with --rules) or the map's summary, with the renderer section."""
    if rules is not None:
        d = rules.to_dict()
    else:
        d = {"map": env.name, "map_size": [env.width, env.height], "channels": env.channels,
             "target_rmse": adv.target_rmse, "target_relative": adv.target_relative,
             "mean_shading": adv.mean_radiance, "notes": notes}
    d["renderer"] = adv.to_dict()
    return d


def run_renderer(args: argparse.Namespace, output: CommandOutput, ropts, rules,
                 t0: float) -> int:
    """``envfit advise MAP --renderer NAME`` with its checked options
    (:func:`renderer_options_from_args`; ``rules``: envfit's rules' with ``--rules``, else
    None): map (its notes said) → :func:`envfit.advisor.advise_with` → print → JSON."""
    from envfit.advisor import advise_with
    from envfit.base import atomic_write_json
    _snippet_file(args, None, args.out)   # --snippet of another map without --out: one line
    env = load_map_from_args(args)
    out = out_dir(args)
    filename, snip_note = _snippet_file(args, env, out)
    output.say(*(f"note: {n}" for n in [*env.notes, *([snip_note] if snip_note else [])]))
    adv = advise_with(env, ropts.asking(filename=filename))
    output.say(*(f"note: {n}" for n in adv.notes))      # the run's notes, before the answer
    output.say(*adv.lines())
    output.answer(adv.lines()[0])                        # --quiet: the answer alone
    rules = advise_with(env, rules) if rules is not None else None
    if rules is not None:
        output.say(*rules_lines(rules))
    m = adv.model
    output.say(f"({time.perf_counter() - t0:.1f} s: renderer model {m['seconds_model']:.1f}"
               + (f", rules {rules.timings['total']:.1f}" if rules is not None else "")
               + f"; cache {m['cache_hits']} hit(s), {m['cache_writes']} write(s))")
    adaptive = _adaptive(args, env, ropts, adv, output)
    d = _result(env, adv, rules, [*env.notes, *([snip_note] if snip_note else []), *adv.notes])
    if adaptive is not None:
        d["renderer"]["adaptive"] = adaptive
        d["timings"] = {**d.get("timings", {}), "adaptive_model": adaptive.pop("seconds")}
    if args.snippet:
        d["renderer"]["snippet_map"] = filename
    d["timings"] = {**d.get("timings", {}), "renderer_model": m["seconds_model"],
                    "total": time.perf_counter() - t0}
    if out is not None:
        path = output.guarded_write(out / "advise.json", atomic_write_json,
                                    out / "advise.json", d)
        if path is not None:
            output.say(f"wrote {path}")
    output.emit_json(d)
    return 0
