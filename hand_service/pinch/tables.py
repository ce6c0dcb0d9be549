"""The pinch run's markdown: Tables 3 and 4 beside the paper's, the pooled rates with
their 95 % Wilson intervals, and the paired comparison (McNemar's exact test, Newcombe's
interval on the difference) beside the paper's counts with Fisher's exact test."""

from __future__ import annotations

from hand_service.pinch.experiment import PAPER_PINCH, PinchResult, paper_counts
from hand_service.pinch.objects import OBJECT_NAMES, PAPER_LABELS
from hand_service.pinch.stats import wilson_interval
from hand_service.pinch.trials import CONTROLLERS, PAIRS

TITLES = {"force": "Table 3: PRBM+LDM force control", "pressure": "Table 4: constant pressure"}


def _row(cells: list[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def _pct(successes: int, trials: int) -> str:
    return f"{100.0 * successes / trials:.0f} % ({successes}/{trials})" if trials else "-"


def _ci(successes: int, trials: int) -> str:
    low, high = wilson_interval(successes, trials)
    return f"[{100 * low:.0f}, {100 * high:.0f}]"


def controller_table(result: PinchResult, controller: str) -> str:
    fingers = [pair[1] for pair in PAIRS if any(c.pair == pair for c in result.cells)]
    header = ["finger pair"] + [f"{PAPER_LABELS[o]}: sim (95 % CI) / paper" for o in OBJECT_NAMES]
    lines = [f"### {TITLES[controller]} ({result.trials_per_cell} trials a cell)", "",
             _row(header), _row(["---"] * len(header))]
    for finger in fingers:
        cells = []
        for obj in OBJECT_NAMES:
            c = result.cell(controller, finger, obj)
            paper = PAPER_PINCH[controller][(finger, obj)]
            cells.append(f"{_pct(c.successes, c.trials)} {_ci(c.successes, c.trials)} / {_pct(*paper)}")
        lines.append(_row([f"thumb & {finger}", *cells]))
    pooled = []
    for obj in OBJECT_NAMES:
        s, n = result.pooled(controller, obj)
        paper = [PAPER_PINCH[controller][(f, obj)] for f in fingers]
        paper_pooled = _pct(sum(p[0] for p in paper), sum(p[1] for p in paper))
        pooled.append(f"{_pct(s, n)} {_ci(s, n)} / {paper_pooled}")
    lines.append(_row(["all pairs", *pooled]))
    return "\n".join(lines)


def comparison_table(result: PinchResult) -> str:
    header = ["object", "force control", "constant pressure", "difference (points)", "setpoints (N; kPa)",
              "failures: force; pressure"]
    lines = ["### Force control against constant pressure, all pairs pooled", "", _row(header),
             _row(["---"] * len(header))]
    for obj in OBJECT_NAMES:
        (sf, nf), (sp, np_) = result.pooled("force", obj), result.pooled("pressure", obj)
        failures = []
        for controller in CONTROLLERS:
            counts: dict[str, int] = {}
            for c in result.cells:
                if c.controller == controller and c.obj == obj:
                    for name, k in c.failures.items():
                        counts[name] = counts.get(name, 0) + k
            failures.append(", ".join(f"{k} {name}" for name, k in sorted(counts.items())) or "none")
        diff = 100.0 * (sf / nf - sp / np_) if nf and np_ else float("nan")
        fingers = [pair[1] for pair in PAIRS if any(c.pair == pair and c.obj == obj for c in result.cells)]
        force = dict.fromkeys(f"{result.tuned[(f, obj, 'force')].setpoint_n:g}" for f in fingers)
        pressure = dict.fromkeys(f"{result.tuned[(f, obj, 'pressure')].setpoint_kpa:g}" for f in fingers)
        setpoints = f"{'/'.join(force)}; {'/'.join(pressure)}"
        lines.append(_row([PAPER_LABELS[obj], f"{_pct(sf, nf)} {_ci(sf, nf)}",
                           f"{_pct(sp, np_)} {_ci(sp, np_)}",
                           f"{diff:+.1f}",
                           setpoints,
                           "; ".join(failures)]))
    return "\n".join(lines)


def _p(p: float) -> str:
    return f"{p:.2g}" if p >= 1e-4 else "< 1e-4"


def paired_table(result: PinchResult) -> str:
    header = ["object", "finger pair", "both held", "force only", "pressure only", "neither",
              "difference (points, 95 % CI)", "McNemar exact p", "paper: force / pressure", "Fisher exact p"]
    lines = ["### Paired: both controllers on the same placements", "", _row(header),
             _row(["---"] * len(header))]
    for obj in OBJECT_NAMES:
        fingers = [pair[1] for pair in PAIRS if any(c.pair == pair and c.obj == obj for c in result.cells)]
        for finger in [*fingers, None] if fingers else []:
            paired = result.paired(obj, finger)
            low, high = paired.interval
            paper = paper_counts(obj, finger)
            paper_cells = (["-", "-"] if paper is None else
                           [f"{_pct(*paper['force'])} / {_pct(*paper['pressure'])}",
                            _p(paper["fisher_exact_p"])])
            lines.append(_row([PAPER_LABELS[obj], f"thumb & {finger}" if finger else "all pairs",
                               str(paired.both), str(paired.force_only), str(paired.pressure_only),
                               str(paired.neither),
                               f"{100 * paired.difference:+.1f} [{100 * low:+.1f}, {100 * high:+.1f}]",
                               _p(paired.mcnemar_p), *paper_cells]))
    return "\n".join(lines)


def tuning_table(result: PinchResult) -> str:
    header = ["object", "tuned on", "controller", "holds from", "to", "set to"]
    lines = [f"### Setpoints tuned ({result.rule.where}; {result.rule.describe()})",
             "", _row(header), _row(["---"] * len(header))]
    for t in sorted(result.tuned_once(), key=lambda t: (OBJECT_NAMES.index(t.obj), t.finger != "index")):
        low, high, chosen = t.in_own_unit()
        span = [f"{low:g} {t.unit}", f"{high:g} {t.unit}"] if t.holds else ["none held", "-"]
        lines.append(_row([PAPER_LABELS[t.obj], f"thumb & {t.finger}", t.controller, *span,
                           f"{chosen:g} {t.unit}"]))
    return "\n".join(lines)


def estimate_line(result: PinchResult) -> str:
    m = result.mismatch
    valves = ("the profile's valves" if m.valves is None else
              f"the board's valves (fill {min(t for _, t in m.valves.fill_tau_s) * 1e3:g} to "
              f"{max(t for _, t in m.valves.fill_tau_s) * 1e3:g} ms, vent x {m.valves.vent_over_fill:g}, "
              f"dead time {m.valves.dead_time_s * 1e3:g} ms)")
    plant = (f"stiffening c = {m.stiffening:g} at {m.reference_kpa:g} kPa, contact drift a = "
             f"{m.lever_drift_per_rad:g}/rad, sensor bow {m.sensor_bow_deg:g} deg, hysteresis "
             f"{m.hysteresis_deg:g} deg, {valves}")
    errors = "; ".join(f"{c} {v:.3f} N" for c, v in result.estimate_rmse_n.items())
    return (f"Force estimate against the plant's true normal force, RMS over the fingers in contact: "
            f"{errors} (paper 0.324 N). Plant: {plant}.")


def markdown(result: PinchResult) -> str:
    return "\n\n".join([estimate_line(result), controller_table(result, "force"),
                        controller_table(result, "pressure"),
                        comparison_table(result), paired_table(result), tuning_table(result)]) + "\n"
