"""The pinch run's figure: force and slip over one trial of each object, both controllers
on the same placement (the first recorded trial where they differ, else the first)."""

from __future__ import annotations

from pathlib import Path

from hand_service.identification.plots import pyplot, save
from hand_service.pinch.experiment import PinchResult
from hand_service.pinch.objects import OBJECT_NAMES, PAPER_LABELS
from hand_service.pinch.trials import CLOSING_S, PAIRS


def pinch_figure(result: PinchResult, path: Path) -> Path:
    plt = pyplot()
    objects = [o for o in OBJECT_NAMES if (o, "force") in result.traces]
    fig, axes = plt.subplots(2, len(objects), figsize=(4.2 * len(objects), 6.5), sharex=True, squeeze=False)
    for col, obj in enumerate(objects):
        top, bottom = axes[0][col], axes[1][col]
        shown = result.shown_trial(obj)
        for controller, color in (("force", "C0"), ("pressure", "C3")):
            tr = result.traces[(obj, controller)][shown]
            held = "held" if result.trace_held[(obj, controller)][shown] else "lost"
            label = ("force control" if controller == "force" else "constant pressure") + f" ({held})"
            top.plot(tr.t_s, tr.normal_n, color=color, label=f"{label}: true")
            if controller == "force":
                top.plot(tr.t_s, tr.estimate_n, color=color, ls="--", lw=0.8,
                         label="force control: its estimate")
            bottom.plot(tr.t_s, 1000.0 * tr.slip_m, color=color, label=label)
        for ax in (top, bottom):
            ax.axvline(CLOSING_S, color="0.6", lw=0.8)
        top.set_title(f"{PAPER_LABELS[obj]}, thumb & {PAIRS[0][1]}, trial {shown + 1}", fontsize=9)
        top.set_ylabel("normal force (N)")
        bottom.set_ylabel("slip in the grip (mm)")
        bottom.set_xlabel("time (s); grey: the person lets go")
        top.legend(fontsize=7)
        bottom.legend(fontsize=7)
    fig.tight_layout()
    return save(fig, path)


def write_pinch_plots(result: PinchResult, directory: Path) -> list[Path]:
    return [pinch_figure(result, directory / "pinch_force_slip.png")]
