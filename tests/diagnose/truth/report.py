"""The battery's tables: top-1 per effect, excitation, rate and family, concealed and
evident apart; the clean and out-of-library answers; the failures grouped; the time per
recording (battery.py writes them into its JSON and prints them)."""

from __future__ import annotations

import math
import statistics
from collections import Counter, defaultdict

from tests.diagnose.truth import cases as cs


def _frac(hits: int, n: int) -> str:
    return f"{hits}/{n} ({100.0 * hits / n:.0f}%)" if n else "-"


def tables(rows: list[dict]) -> dict:
    lib = [r for r in rows if r["effect"] in cs.LIBRARY]
    obs = [r for r in lib if r["observable"]]
    unobs = [r for r in lib if not r["observable"]]
    clean = [r for r in rows if r["effect"] == cs.CLEAN]
    outside = (*cs.OUT_OF_LIBRARY, *cs.ON_REQUEST)  # the on-request ones: not searched here
    ool = [r for r in rows if r["effect"] in outside]

    def top1(group: list[dict]) -> dict:
        return {"n": len(group), "top1": sum(r["outcome"] == "top1" for r in group)}

    def by(key: str) -> dict:
        out: dict = {}
        for value in sorted({r[key] for r in lib}, key=str):
            sel = [r for r in obs if r[key] == value]
            out[str(value)] = {
                m: top1([r for r in sel if r["magnitude"] == m]) for m in ("concealed", "evident")
            }
            un = [r for r in unobs if r[key] == value]
            out[str(value)]["unobservable"] = {"n": len(un), "right": sum(r["right"] for r in un)}
        return out

    errors = defaultdict(list)
    for r in obs:
        if r["param_error"] is not None:
            errors[r["effect"]].append(r["param_error"])
    failures = Counter()
    for r in obs:
        if r["outcome"] != "top1":
            failures[(r["effect"], r["outcome"], r["named"][0] if r["named"] else r["verdict"])] += 1
    for r in unobs:
        if not r["right"]:
            failures[
                (r["effect"] + " (unobservable)", r["outcome"], r["named"][0] if r["named"] else r["verdict"])
            ] += 1
    return {
        "overall": {m: top1([r for r in obs if r["magnitude"] == m]) for m in ("concealed", "evident")}
        | {"all": top1(obs), "unobservable": {"n": len(unobs), "right": sum(r["right"] for r in unobs)}},
        "per_effect": by("effect"),
        "per_excitation": by("excitation"),
        "per_rate": by("rate_hz"),
        "per_family": by("family"),
        "median_param_error": {e: statistics.median(v) for e, v in errors.items()},
        "clean": dict(Counter(r["outcome"] for r in clean)) | {"n": len(clean)},
        "clean_named": dict(Counter(r["named"][0] for r in clean if r["named"])),
        "out_of_library": {
            e: dict(Counter(r["outcome"] for r in ool if r["effect"] == e))
            for e in outside
            if any(r["effect"] == e for r in ool)
        },
        "out_of_library_structure": {e: _structure(r for r in ool if r["effect"] == e)
                                     for e in outside if any(r["effect"] == e for r in ool)},
        "out_of_library_named": dict(Counter(r["named"][0] for r in ool if r["named"])),
        "failures": [
            {"effect": k[0], "outcome": k[1], "said": k[2], "count": v} for k, v in failures.most_common()
        ],
        "off_target_magnitudes": sum(1 for r in obs if r["on_target"] is False),
        "seconds": {
            "generate_mean": _mean([r["generate_s"] for r in rows if r["generate_s"] > 0]),
            "diagnose_mean": _mean([r["diagnose_s"] for r in rows]),
            "diagnose_max": max((r["diagnose_s"] for r in rows), default=0.0),
            "diagnose_mean_per_rate": {
                str(rate): _mean([r["diagnose_s"] for r in rows if r["rate_hz"] == rate]) for rate in cs.RATES
            },
        },
    }


# what an out-of-library case must leave, over the sensor's noise, for issue 44's point: never
# `consistent` or `parameters_only` there, never a library name graded `complete`
STRUCTURE_RATIO = 3.0


def _structure(rows) -> dict:
    """Out-of-library cases whose plain refit leaves STRUCTURE_RATIO × the noise or more
    (`visibility`): their answers (verdict, first name, grade) and the ones the point denies."""
    big = [r for r in rows if r["visibility"] >= STRUCTURE_RATIO]
    said = Counter(" ".join(str(x) for x in (r["verdict"], r["named"][0] if r["named"] else None,
                                              r.get("grade")) if x) for r in big)
    wrong = [r["id"] for r in big if r["verdict"] in ("consistent", "parameters_only")
             or (r["named"] and r.get("grade") == "complete")]
    return {"n": len(big), "said": dict(said), "violations": wrong}


def _mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else math.nan


def render(t: dict) -> str:
    lines = []
    o = t["overall"]
    lines.append("== library effects, observable cases: top-1 (the true effect is effects[0])")
    lines.append(
        f"overall   all {_frac(o['all']['top1'], o['all']['n'])}   concealed "
        f"{_frac(o['concealed']['top1'], o['concealed']['n'])}   "
        f"evident {_frac(o['evident']['top1'], o['evident']['n'])}"
        f"   unobservable answered right {_frac(o['unobservable']['right'], o['unobservable']['n'])}"
    )
    for title, key in (
        ("effect", "per_effect"),
        ("excitation", "per_excitation"),
        ("rate (Hz)", "per_rate"),
        ("family", "per_family"),
    ):
        lines.append(f"-- per {title}")
        lines.append(f"{'':24s}{'concealed':>16s}{'evident':>16s}{'unobservable ok':>18s}")
        for name, row in t[key].items():
            c, e, u = row["concealed"], row["evident"], row["unobservable"]
            lines.append(
                f"{name:24s}{_frac(c['top1'], c['n']):>16s}{_frac(e['top1'], e['n']):>16s}"
                f"{_frac(u['right'], u['n']):>18s}"
            )
    lines.append("-- median parameter error of the named effect (|est − true| / |true − neutral|)")
    lines += [f"{e:24s}{v:8.3f}" for e, v in t["median_param_error"].items()]
    c = t["clean"]
    lines.append(
        f"== clean ({c['n']}): "
        + ", ".join(f"{k} {v}" for k, v in c.items() if k != "n")
        + (f"; named: {t['clean_named']}" if t["clean_named"] else "")
    )
    for e, counts in t["out_of_library"].items():
        lines.append(f"== out of library, {e}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    for e, big in t.get("out_of_library_structure", {}).items():
        lines.append(f"   {e} at >= {STRUCTURE_RATIO:g} x the noise ({big['n']}): "
                     + ", ".join(f"{k} {v}" for k, v in big["said"].items())
                     + f"; consistent, parameters_only or named complete: {len(big['violations'])}")
    if t["out_of_library_named"]:
        lines.append(f"   named with a library name: {t['out_of_library_named']}")
    lines.append("== failures grouped (effect, outcome, what diagnose said: count)")
    lines += [f"{f['effect']:34s}{f['outcome']:26s}{f['said']:26s}{f['count']:4d}" for f in t["failures"]]
    s = t["seconds"]
    lines.append(
        f"== seconds per recording: generate {s['generate_mean']:.2f} (mean, uncached), diagnose "
        f"{s['diagnose_mean']:.2f} mean, {s['diagnose_max']:.1f} max; diagnose per rate "
        + ", ".join(f"{k}: {v:.2f}" for k, v in s["diagnose_mean_per_rate"].items())
    )
    return "\n".join(lines)
