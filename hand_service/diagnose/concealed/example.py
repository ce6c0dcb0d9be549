"""The worked example of docs/results.md §10: one concealed recording per effect, diagnosed, in a table,
and the plots of one of them.

    python -m hand_service.diagnose.concealed.example --out docs/img
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hand_service.config import effects as fx
from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.excitations import REPRESENTATIVE as EXCITATION
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="docs/img", help="folder for the plots")
    parser.add_argument("--plot-effect", default="coulomb_friction")
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--conceal", type=float, default=0.8)
    parser.add_argument("--noise", type=float, default=0.5)
    args = parser.parse_args(argv)
    model = load_profile(None).finger("index").model
    rows = ["| effect | excitation | concealment (residual/noise) | verdict | named first | true | found "
            "| parameter error | held-out RMSE refit → augmented (deg) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for spec in fx.SEARCHED:
        c = generate(model, {spec.name: None}, EXCITATION[spec.name], noise_deg=args.noise, seed=args.seed,
                     conceal_ratio=args.conceal)
        d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
        true = c.hidden[spec.name][spec.param]
        found = next((e for e in d.effects if e.name == spec.name), None)
        first = d.effects[0].name if d.effects else "–"
        error = f"{100 * abs(found.value - true) / abs(true - spec.neutral):.1f} %" if found else "–"
        estimate = f"{found.value:.4g} ± {found.std:.2g}" if found else "–"
        rows.append(f"| {spec.name} | {EXCITATION[spec.name]} | {c.concealment:.2f} | {d.verdict} | "
                    f"{first} | {true:.4g} | {estimate} | {error} | {d.rmse_deg['refit']:.3f} → "
                    f"{d.rmse_deg['augmented']:.3f} |")
        print(rows[-1], file=sys.stderr, flush=True)
        if spec.name == args.plot_effect:
            from hand_service.diagnose.report.html import overview_figure, residual_figure

            out = Path(args.out)
            out.mkdir(parents=True, exist_ok=True)
            a, b, _ = d.windows[0]
            middle = 0.5 * (a + b)
            overview_figure(d).savefig(out / "diagnose_overview.png", dpi=80, bbox_inches="tight")
            overview_figure(d, (middle - 1.5, middle + 1.5)).savefig(out / "diagnose_zoom.png", dpi=80,
                                                                      bbox_inches="tight")
            residual_figure(d).savefig(out / "diagnose_residual.png", dpi=80, bbox_inches="tight")
            print(f"{spec.name}: {d.effects[0].evidence if d.effects else d.verdict}", file=sys.stderr)
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
