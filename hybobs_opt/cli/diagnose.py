"""``hybobs diagnose SYSTEM [--range psi=0:360] [--out-dir DIR] [--json]``: is there a constant
observer gain on the range (paper 004, LMI (8))?  Any scalar-nonlinear system: the paper's
examples use their published settings, every other system settings read from the model
(:mod:`hybobs_opt.lmi.auto_design`, reported under ``settings``).

Writes a Markdown and an HTML report (verdict, certificate, Jacobian-bound plots, what to do
next) into ``DIR`` and prints the verdict: the hierarchy of conditions (:mod:`hybobs_opt.lmi.hierarchy`),
undetectable points and indistinguishable mirror states (:mod:`hybobs_opt.lmi.impossibility`).
``--json`` prints ``feasible`` (some condition gave a gain), ``paper_lmi_feasible``, ``verdict``,
``hierarchy``, ``undetectable_points``, ``indistinguishable`` and, when the paper LMI is infeasible,
``certificate`` with ``verified``, ``reason`` and ``theorem``.  Ranges are in the preset's
display unit of the coordinate (degrees for ``psi``, mm for ``z``); ``psi=0:6.28rad`` gives
radians explicitly.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_force_argument, add_system_argument, announce, bound_entries, check_output_dir, file_slug, print_json
from ._vocabulary import add_hidden_alias
from ._schedule import add_design_arguments, design_setup, parse_range

HELP = "does a constant observer gain exist? verdict, certificate, report (paper 004)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    add_design_arguments(p)
    p.add_argument("--out-dir", dest="out", metavar="DIR", default=None,
                   help="write the Markdown and HTML reports into DIR (created if missing; none without it)")
    add_hidden_alias(p, "--out-dir", "--out")
    p.add_argument("--noise-bound", action="append", metavar="NAME=VALUE", dest="noise_bound",
                   help="bound on an output's noise in its units (repeatable; a bare VALUE bounds every output): "
                        "also design the gain with the smallest certified ultimate error bound under that noise")
    p.add_argument("--exact-bound-search", action="store_true", dest="exact_bound_search",
                   help="with a gain bound, also search the polytopic condition under the exact bound ||L||_2 <= "
                        "GAIN_BOUND (a local search, seconds; on ill-conditioned systems the local optimum it reaches "
                        "can depend on the BLAS kernels, so its rate is proven but not reproducible to the last digit)")
    add_force_argument(p)
    p.add_argument("--json", action="store_true", help="machine-readable verdict and certificate")


def cmd_diagnose(args: argparse.Namespace) -> int:
    """``hybobs diagnose``: verdict, certificate and report for one range."""
    announce(args, "loading the LMI solvers (numpy, cvxpy, Clarabel)")
    from ..lmi.diagnose import diagnose
    from ..lmi.solve import counting_solves
    from ..progress import counter_bar
    from ..report.lmi_section import write_diagnosis_report
    from ..studies.paper004_nonmonotonic.presets import scaling_for

    out_dir = None if args.out is None else Path(args.out)
    check_output_dir("--out-dir", out_dir, args.force, None)
    named, preset, settings = design_setup(args)
    check_output_dir("--out-dir", out_dir, args.force, f"diagnose_{file_slug(named.label)}.md")  # before any LMI
    system = named.system
    noise = None if not args.noise_bound else bound_entries(args.noise_bound, tuple(system.output_names), "--noise-bound",
                                                            "noise_bound", "output")
    update, close = counter_bar(not args.json, "LMI solves", "solve")
    try:
        with counting_solves(None if update is None else (lambda n: update(n, None))):
            if preset is not None:
                lo, hi = parse_range(args.range, preset, system.state_names, system) if args.range else preset.diagnose_range
                coordinate, unit = preset.coordinate, preset.unit
                diag = diagnose(system, preset.coordinate, preset.to_model(lo), preset.to_model(hi), unit=preset.unit,
                                factor=preset.factor, gain_bound=preset.gain_bound, min_decay=preset.min_decay,
                                overlap=preset.to_model(preset.overlap), sigma_cap=preset.sigma_cap,
                                scaling=scaling_for(preset, system), noise_bound=noise,
                                exact_bound_search=args.exact_bound_search)
            else:
                lo, hi, coordinate, unit = settings.lo, settings.hi, settings.coordinate, ""
                diag = diagnose(system, settings.coordinate, settings.lo, settings.hi, gain_bound=settings.gain_bound,
                                min_decay=settings.min_decay, overlap=settings.overlap, sigma_cap=settings.sigma_cap,
                                scaling=settings.scaling, condition=settings.condition, required_decay=args.min_decay,
                                noise_bound=noise, exact_bound_search=args.exact_bound_search)
    finally:
        close()
    paths = None if out_dir is None else write_diagnosis_report(diag, out_dir, file_slug(named.label))
    out = diag.to_dict()
    out["example"] = named.label
    out["system"] = named.label
    out["settings"] = {"source": "paper"} if settings is None else {"source": "model", **settings.to_dict()}
    out["report"] = paths
    if args.json:
        print_json(out)
        return 0
    h = diag.hierarchy
    if diag.design is not None:
        verdict = diag.design.headline(f"{coordinate} in [{lo:g}, {hi:g}] {unit}".strip())
    elif h.strongest_infeasible is not None:
        verdict = f"INFEASIBLE up to the {h.strongest_infeasible} condition (certified)"
    else:
        verdict = "UNDECIDED"
    print(f"{named.label}: {verdict}" if diag.design is not None else
          f"{named.label}, {coordinate} in [{lo:g}, {hi:g}] {unit}: {verdict}".replace("  ", " "))
    searched = {} if diag.design is None else {c.condition: c for c in diag.design.by_condition}
    bound = "" if diag.gain_bound is None else f" with ||L||_2 <= {diag.gain_bound:g}"
    for c in h.conditions:
        if c.feasible:
            state = "feasible without a gain bound" + (f" (implied by {c.implied_by})" if c.implied_by else "")
            best = searched.get(c.key)
            if best is not None and best.feasible:
                state += f"; largest decay rate{bound}: {best.sigma_verified:.4g} 1/s (vertex-checked)"
            elif best is not None:
                state += f"; no gain{bound}"
        else:
            state = "infeasible, certificate verified in numpy" if c.verified else f"not decided ({c.skipped or c.status})"
        print(f"  {c.name}: {state}")
    nd = diag.noise_design
    if nd is not None and nd.feasible:
        noise_text = ", ".join(f"{n} {v:.4g}" for n, v in zip(system.output_names, nd.noise.tolist()))
        print(f"  under output noise {noise_text}: ||L||_2 = {nd.gain_norm:.4g}, "
              f"decay rate {nd.alpha:.4g} 1/s, certified ultimate bound "
              + ", ".join(f"|e_{n}| <= {b:.4g}" for n, b in zip(system.state_names, nd.bound)))
    elif diag.noise_error:
        print(f"  no certified error bound under the stated noise: {diag.noise_error}")
    for p_ in diag.undetectable:
        print(f"  undetectable point: {p_.claim}")
    for q in diag.symmetries:
        print(f"  {q.claim}")
    if diag.certificate is not None:
        c = diag.certificate
        print(f"paper LMI certificate ({c.theorem}): verified in numpy = {c.verify()}; structural = {c.structural_verified}")
        print(f"  {c.reason}")
    print(f"Theorem 5 (linear subtraction): original {diag.theorem5.original_feasible}, transformed {diag.theorem5.shifted_feasible}")
    print("next:")
    for step in diag.next_steps:
        print(f"  - {step}")
    if paths is not None:
        print(f"report: {paths['markdown']} and {paths['html']}")
    return 0


run = cmd_diagnose
