"""The diagnosis as one self-contained HTML file: plots (PNG inlined) and the evidence table."""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.diagnose.report.evidence import estimate, uncertainty
from hand_service.diagnose.report.sentence_checks import facts_of, screened
from hand_service.diagnose.residual import stats
from hand_service.errors import UserError

COLOURS = {"recording": "#9a9a9a", "nominal": "#d62728", "refit": "#1f77b4", "augmented": "#2ca02c"}


def _pyplot():
    """pyplot on the Agg backend (no display here, and none needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _png(figure) -> str:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    _pyplot().close(figure)
    return base64.b64encode(buffer.getvalue()).decode()


def _shade(ax, d: Diagnosis) -> None:
    for start, stop, _ in d.windows:
        ax.axvspan(start, stop, color="#ffbf00", alpha=0.25, lw=0)


def overview_figure(d: Diagnosis, span: tuple[float, float] | None = None):
    plt = _pyplot()
    p = d.problem
    keep = np.ones_like(p.t_s, dtype=bool) if span is None else (p.t_s >= span[0]) & (p.t_s <= span[1])
    t = p.t_s[keep]
    if span is None:
        fig, (ax, axp) = plt.subplots(2, 1, figsize=(11, 5.2), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 1]})
    else:
        fig, (ax, axr, axp) = plt.subplots(3, 1, figsize=(11, 7.0), sharex=True,
                                           gridspec_kw={"height_ratios": [3, 2, 1]})
        axr.plot(t, (p.measured_deg - d.refit.angle_deg)[keep], ".", ms=3, color=COLOURS["recording"],
                 label="recording − refitted plain model")
        if d.effects or d.partial_effects:
            axr.plot(t, (d.final.angle_deg - d.refit.angle_deg)[keep], lw=1.5, color=COLOURS["augmented"],
                     label="augmented − refitted: what the found effect adds")
        axr.axhline(0.0, color="k", lw=0.5)
        axr.set_ylabel("residual (deg)")
        axr.legend(loc="upper right", fontsize=8)
        _shade(axr, d)
    ax.plot(t, p.measured_deg[keep], ".", ms=2.5, color=COLOURS["recording"], label="recording")
    ax.plot(t, d.nominal_angle_deg[keep], lw=1.0, color=COLOURS["nominal"], label="nominal model")
    ax.plot(t, d.refit.angle_deg[keep], lw=1.0, color=COLOURS["refit"], label="refitted plain model")
    shown = d.effects or d.partial_effects
    if shown:
        label = "augmented" if d.effects else "partial (not named)"
        ax.plot(t, d.final.angle_deg[keep], lw=1.0, ls="--", color=COLOURS["augmented"],
                label=f"{label}: " + ", ".join(e.name for e in shown))
    _shade(ax, d)
    ax.set_ylabel("angle (deg)")
    ax.legend(loc="upper right", fontsize=8, ncol=2)
    zoom = "" if span is None else f" ({span[0]:.1f}-{span[1]:.1f} s)"
    ax.set_title("recording against the models" + zoom)
    if span is not None:
        ax.set_xlim(*span)
    axp.plot(t, p.pressure_kpa[keep], color="k", lw=0.8)
    axp.set_ylabel("command (kPa)")
    axp.set_xlabel("t (s)")
    return fig


def residual_figure(d: Diagnosis):
    plt = _pyplot()
    p = d.problem
    valid = p.fit_mask | p.held_mask
    width = max(20, round(0.5 * p.rate_hz))
    fig, axes = plt.subplots(2, 1, figsize=(11, 4.6), sharex=True, sharey=True)
    for ax, (label, angle) in zip(axes, (("before: refitted plain model", d.refit.angle_deg),
                                         ("after: augmented model", d.final.angle_deg)), strict=True):
        residual = np.where(valid, p.measured_deg - angle, np.nan)
        ax.plot(p.t_s, residual, lw=0.4, color="#555555")
        local = np.sqrt(np.convolve(np.nan_to_num(residual) ** 2, np.ones(width) / width, mode="same"))
        ax.plot(p.t_s, local, lw=1.2, color="#d62728", label="RMS over 0.5 s")
        ax.axhline(d.noise_deg, color="#2ca02c", lw=0.8, ls="--",
                   label=f"{d.noise_label} {d.noise_deg:.2f} deg")
        _shade(ax, d)
        ax.set_ylabel("residual (deg)")
        ax.set_title(label, fontsize=10)
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t (s)  (shaded: the windows where the refitted model misses most)")
    return fig


def tests_figure(d: Diagnosis):
    plt = _pyplot()
    p = d.problem
    lags = stats.whiteness_lags(p.rate_hz)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 3.2))
    mask = p.fit_mask
    for label, angle, colour in (("refit", d.refit.angle_deg, COLOURS["refit"]),
                                 ("augmented", d.final.angle_deg, COLOURS["augmented"])):
        rho = stats.autocorrelation((p.measured_deg - angle)[mask], lags)
        a1.plot(np.arange(1, lags + 1) / p.rate_hz, rho, ".-", ms=3, color=colour, label=label)
    band = stats.Z99 / np.sqrt(mask.sum())
    for ax in (a1, a2):
        ax.axhspan(-band, band, color="#dddddd")
        ax.set_xlabel("lag (s)")
    a1.set_title("residual autocorrelation (whiteness)", fontsize=10)
    a1.legend(fontsize=8)
    x = d.input_xcorr
    a2.plot(x.lags_s, x.rho, ".-", ms=3, color=COLOURS["refit"])
    a2.set_title("refit residual against the past command", fontsize=10)
    return fig


def _table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def evidence_rows(d: Diagnosis) -> list[list[str]]:
    rows = []
    accepted = {e.name for e in d.effects}
    for c in (d.selection.rounds[0].candidates if d.selection.rounds else []):
        if c.delta_bic < -math.log(max(d.problem.n_fit, 2)):
            continue  # a fit that came out worse than the model it adds to: no evidence either way
        spec = fx.BY_NAME[c.name]
        partial = {e.name for e in d.partial_effects}
        verdict = ("found" if c.name in accepted else "partial" if c.name in partial
                   else "significant alone" if c.significant else "no")
        rows.append([html.escape(c.name), html.escape(estimate(c.estimate, c.std, spec.unit)),
                     f"{c.delta_bic:.1f}", f"{c.z_heldout:.1f}", f"{c.signature_corr:+.2f}",
                     f"{c.separability:.2f}", f"{c.rmse_heldout_deg:.3f}", verdict])
    return rows


CSS = """body{font-family:sans-serif;max-width:1100px;margin:1em auto;color:#222}
table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #ccc;padding:3px 8px;font-size:13px}
th{background:#f0f0f0}.verdict{font-size:1.4em;font-weight:bold}img{max-width:100%}"""


def render(d: Diagnosis, recording_name: str) -> str:
    j = d.to_json()
    facts = facts_of(d)  # every sentence checked against the recording (sentence_checks.py)
    parts = [f"<html><head><meta charset='utf-8'><title>diagnose {html.escape(recording_name)}</title>"
             f"<style>{CSS}</style></head><body>",
             f"<h1>diagnose: {html.escape(recording_name)}</h1>",
             f"<p class='verdict'>verdict: {j['verdict']}</p>"]
    if d.effects:
        parts.append("<h2>Found effects (strongest first)</h2><ol>")
        said = screened([e.evidence for e in d.effects], facts)
        parts += [f"<li><b>{e.name}</b>: {html.escape(text)}</li>"
                  for e, text in zip(d.effects, said, strict=True)]
        parts.append("</ol>")
    if j["warnings"] or j["notes"]:
        items = "".join(f"<li>{html.escape(w)}</li>" for w in screened(j["warnings"] + j["notes"], facts))
        parts.append(f"<ul>{items}</ul>")
    rm, raw = j["rmse_deg"], j.get("raw_rmse_deg", {})
    parts.append("<h2>Fit on the raw angle (a constant offset each, no drift)</h2>" + _table(
        ["model", "raw RMS error (deg)", "held-out RMS error (deg)"],
        [[k, f"{raw.get(k, float('nan')):.3f}", f"{v:.3f}"] for k, v in rm.items()]))
    parts.append(f"<p>{html.escape(d.noise_label)} {d.noise_deg:.3f} deg; "
                 f"{j['samples']['fit']} samples fitted, "
                 f"{j['samples']['held_out']} held out (interleaved blocks); {d.problem.rate_hz:g} Hz; "
                 f"diagnosed in {d.seconds:.1f} s.</p>")
    model = d.model
    refit = j["refit"]
    rows = [[name, f"{getattr(model, name):.5g}", f"{refit[name]:.5g}",
             uncertainty(j["refit_std"].get(name, float("nan")), value=refit[name])]
            for name in ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa")]
    parts.append(f"<h2>Parameters (A held at {model.inertia_kgm2:.4g} kg·m²)</h2>"
                 + _table(["parameter", "nominal", "refit", "±"], rows))
    parts.append("<h2>Recording and models</h2>")
    parts.append(f"<img src='data:image/png;base64,{_png(overview_figure(d))}'>")
    if d.windows:
        a, b, _ = d.windows[0]
        middle = 0.5 * (a + b)
        zoomed = overview_figure(d, (middle - 1.5, middle + 1.5))
        parts.append(f"<img src='data:image/png;base64,{_png(zoomed)}'>")
    parts.append("<h2>Residual before and after</h2>")
    parts.append(f"<img src='data:image/png;base64,{_png(residual_figure(d))}'>")
    spans = ", ".join(f"{max(0.0, a):.2f} to {b:.2f}" for a, b, _ in d.windows)
    parts.append(f"<p>windows (s): {spans or 'none'}</p>")
    parts.append("<h2>Residual tests</h2>")
    parts.append(f"<img src='data:image/png;base64,{_png(tests_figure(d))}'>")
    white = j["whiteness"]
    parts.append(_table(["residual", "Ljung-Box Q", "lags", "p"],
                        [[k, f"{v['ljung_box_q']:.1f}", str(v["lags"]), f"{v['p_value']:.2g}"]
                         for k, v in white.items()]))
    parts.append("<h2>Evidence: every library effect fitted with k, B, N</h2>")
    parts.append("<p>ΔBIC: information criterion against the refitted plain model (above 10 is very "
                 "strong). z: held-out improvement in standard errors (above 3 counts). Signature "
                 "correlation: of the residual with the effect's signature after removing what k, B "
                 "and N absorb (the score test). Separability: the share of the signature k, B and N "
                 "cannot absorb.</p>")
    parts.append(_table(["effect", "estimate", "ΔBIC", "held-out z", "signature corr.", "separability",
                         "held-out RMSE (deg)", "named"], evidence_rows(d)))
    parts.append("</body></html>")
    return "\n".join(parts)


def write_report(d: Diagnosis, path: str | Path, recording_name: str) -> None:
    try:
        Path(path).write_text(render(d, recording_name))
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
