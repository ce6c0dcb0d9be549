"""The library effects diagnose searches only on request, on the independent truth, in the
truth's own forms (plant.py: pressure stiffening a power of the pressure, or on odd seeds
an exponential; creep two Maxwell branches at T and 4·T; hysteresis Bouc-Wen's loop with
β = γ; contact Hunt-Crossley's, with its damping), through `hand-service diagnose --search`:

    python -m tests.diagnose.truth.on_request --out on_request.json [--seeds 1] [--first-seed 0]
        [--classes ...]
        [--effects pressure_stiffening creep hysteresis contact] [--shape-known]
        [--cases-of clean gravity ...] [--skip-own]

Hysteresis and contact are the battery's cases outside the library (cases.OUT_OF_LIBRARY:
the same recordings), here searched for by name. Each case is scored as a library effect
(scoring.py): named first where observable (observability.py); the estimate's error against the
truth's library equivalent (cases.library_equivalent) and, for contact and pressure
stiffening, against the library form's best fit to the truth (library_form.py), which also
says where the library's form explains the truth's contact only in part (`beyond_form`)."""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from tests.diagnose.truth import cases as cs  # noqa: E402
from tests.diagnose.truth.battery import diagnose_argv  # noqa: E402
from tests.diagnose.truth.excitation import CLASSES  # noqa: E402
from tests.diagnose.truth.library_form import (  # noqa: E402
    ContactForm,
    best_form,
    contact_form,
    contact_torque_nm,
)
from tests.diagnose.truth.observability import OBSERVABLE_LEFT, observable  # noqa: E402

EFFECTS = (*cs.ON_REQUEST, *cs.OUT_OF_LIBRARY)


def truth_shape(case: cs.Case) -> dict[str, float]:
    """What the library holds at its defaults when it fits the first parameter alone."""
    if case.spec.effect == "contact":
        return {"onset_deg": case.truth.contact_deg, "exponent": 1.5}
    if case.spec.effect == "hysteresis":
        return {"travel_deg": case.truth.hysteresis_zmax_deg}
    if case.spec.effect == "creep":
        return {"time_s": case.truth.creep_time_s}
    return {}


def contact_scores(case: cs.Case, form: ContactForm, estimate: dict[str, float] | None,
                   partial: list[str]) -> dict:
    """A contact case against the library's form at its best (library_form.py): what that form
    leaves (`library_form_left`; at OBSERVABLE_LEFT or more the library explains only part of
    the truth's contact, and `partial`, the contact reported first in partial_effects, is the
    truthful answer), and the named estimate's error against it: of its torque at the deepest
    angle recorded (`torque_error`) and of its K (`form_error`, comparable only near its n)."""
    deepest_deg = float(np.max(case.trajectory.theta_deg))
    out = {"library_form": dataclasses.asdict(form), "library_form_left": form.left,
           "beyond_form": form.left >= OBSERVABLE_LEFT,
           "partial_first": bool(partial) and partial[0] == "contact",
           "torque_error": None, "form_error": None}
    if estimate is not None:
        torque = contact_torque_nm(estimate["stiffness_nm_per_radn"], estimate["onset_deg"],
                                   estimate["exponent"], deepest_deg)
        out["torque_error"] = abs(torque - form.torque_nm(deepest_deg)) / form.torque_nm(deepest_deg)
        out["form_error"] = abs(estimate["stiffness_nm_per_radn"] - form.stiffness_nm_per_radn) \
            / form.stiffness_nm_per_radn
    return out


def stiffening_scores(case: cs.Case, estimate: dict[str, float] | None) -> dict:
    """A pressure stiffening case against the library's k·(1 + c·p/p_ref) at its best
    (library_form.best_form): what it leaves and the estimate's error against its c."""
    values, left, _ = best_form(case, "pressure_stiffening", case.library_equivalent["gain"], [{}])
    error = None if estimate is None else abs(estimate["gain"] - values["gain"]) / values["gain"]
    return {"library_form": values, "library_form_left": left, "beyond_form": left >= OBSERVABLE_LEFT,
            "form_error": error}


def run_case(spec: cs.CaseSpec, folder: Path, shape_known: bool = False, search: str | None = None) -> dict:
    """`shape_known`: the lab's model file gives the effect's other parameters (truth_shape),
    its first at "none", as a lab that knows where its object sits would write it."""
    from hand_service.cli import main
    from hand_service.config.effects import BY_NAME

    case = cs.build(spec)
    if shape_known and truth_shape(case):
        library = BY_NAME[spec.effect]
        case.nominal_effects = {**case.nominal_effects,
                                spec.effect: {library.param: library.neutral, **truth_shape(case)}}
    rec, model = cs.write(case, folder)
    out = folder / f"{spec.id}.diagnose.json"
    started = time.perf_counter()
    code = main([*diagnose_argv(rec, model, out), "--search", search or spec.effect])
    result = json.loads(out.read_text()) if code == 0 else {"verdict": f"exit {code}"}
    names = [e.get("name") for e in result.get("effects") or []]
    first = (result.get("effects") or [{}])[0]
    true = next(iter(case.library_equivalent.values()), None)
    error = None
    if names and names[0] == spec.effect and true:
        error = abs(next(iter(first["params"].values())) - true) / abs(true)
    contact = contact_form(case) if spec.effect == "contact" else None
    seen, reason = observable(case, contact)
    form = contact_scores(case, contact, first.get("params") if names and names[0] == "contact" else None,
                          [e.get("name") for e in result.get("partial_effects") or []]) \
        if contact is not None and (search or spec.effect) == "contact" else {}
    if spec.effect == "pressure_stiffening" and (search or spec.effect) == spec.effect and seen:
        form = stiffening_scores(case, first.get("params") if names and names[0] == spec.effect else None)
    return {**case.summary(), "shape_known": shape_known, "searched": search or spec.effect,
            "observable": seen, "reason": reason, "truth_shape": truth_shape(case), **form,
            "estimate": first.get("params") if names and names[0] == spec.effect else None,
            "verdict": result.get("verdict"), "grade": result.get("grade"), "named": names,
            "top1": bool(names) and names[0] == spec.effect, "parameter_error": error,
            "seconds": time.perf_counter() - started}


def summarise(rows: list[dict]) -> dict:
    out = {}
    for effect in dict.fromkeys(r["effect"] for r in rows if r["searched"] == r["effect"]):
        mine = [r for r in rows if r["effect"] == effect and r["searched"] == effect]
        seen = [r for r in mine if r["observable"]]
        errors = [r["parameter_error"] for r in seen if r["parameter_error"] is not None]
        out[effect] = {"cases": len(mine), "observable": len(seen), "top1": sum(r["top1"] for r in seen),
                       "wrong_names": sum(bool(r["named"]) and not r["top1"] for r in mine),
                       "median_parameter_error": float(np.median(errors)) if errors else None}
        form_errors = [r["form_error"] for r in seen if r.get("form_error") is not None]
        out[effect]["median_error_against_form"] = float(np.median(form_errors)) if form_errors else None
        if effect == "contact":
            within = [r for r in seen if not r["beyond_form"]]
            beyond = [r for r in seen if r["beyond_form"]]
            torque = [r["torque_error"] for r in seen if r["torque_error"] is not None]
            out[effect] |= {
                "observable_within_form": len(within), "top1_within_form": sum(r["top1"] for r in within),
                "observable_beyond_form": len(beyond),
                "partial_first_beyond_form": sum(r["partial_first"] for r in beyond),
                "named_complete_beyond_form": sum(r["top1"] and r["grade"] == "complete" for r in beyond),
                "partial_first_within_form": sum(r["partial_first"] for r in within),
                "median_torque_error": float(np.median(torque)) if torque else None}
    for row in rows:  # another truth searched for an effect: how often it is named
        if row["searched"] != row["effect"]:
            key = f"{row['searched']} on {row['effect']}"
            seen = out.setdefault(key, {"cases": 0, "named_first": 0, "named": 0})
            seen["cases"] += 1
            seen["named_first"] += bool(row["named"]) and row["named"][0] == row["searched"]
            seen["named"] += row["searched"] in row["named"]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True)
    parser.add_argument("--seeds", type=int, default=1)
    parser.add_argument("--first-seed", type=int, default=0,
                        help="the effects' seeds run from this one (--seeds of them): more seeds without "
                             "running the first again")
    parser.add_argument("--classes", nargs="*", default=list(CLASSES))
    parser.add_argument("--magnitudes", nargs="*", default=["concealed"])
    parser.add_argument("--shape-known", action="store_true",
                        help="the model file gives each effect's parameters beyond the first, the truth's")
    parser.add_argument("--cases-of", nargs="*", default=[], choices=cs.ALL_EFFECTS,
                        help="also the truth's cases of these (clean, the eight, ...), each searched for "
                             "the --effects: their false names")
    parser.add_argument("--skip-own", action="store_true", help="only the --cases-of")
    parser.add_argument("--effects", nargs="*", default=list(cs.ON_REQUEST), choices=EFFECTS)
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="on-request-") as scratch:
        for effect in [] if args.skip_own else args.effects:
            for seed in range(args.first_seed, args.first_seed + args.seeds):
                for cls in args.classes:
                    for magnitude in args.magnitudes:
                        row = run_case(cs.CaseSpec(effect, cls, seed, magnitude), Path(scratch),
                                       args.shape_known)
                        rows.append(row)
                        print(f"{row['id']}: observable {row['observable']}, named {row['named']}, "
                              f"error {row['parameter_error']}", file=sys.stderr, flush=True)
        for truth in args.cases_of:
            for effect in args.effects:
                for cls in args.classes:
                    row = run_case(cs.CaseSpec(truth, cls, 0, "concealed"), Path(scratch), search=effect)
                    rows.append(row)
                    print(f"{row['id']} searched for {effect}: named {row['named']}", file=sys.stderr,
                          flush=True)
    Path(args.out).write_text(json.dumps({"summary": summarise(rows), "cases": rows}, indent=1))
    print(json.dumps(summarise(rows), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
