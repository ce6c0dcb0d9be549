"""What diagnose said about a battery case against its truth: the outcome and whether it
counts as right."""

from __future__ import annotations

from hand_service.config import effects as fx
from tests.diagnose.truth.cases import CLEAN, LIBRARY, CaseSpec


def score(spec: CaseSpec, observable: bool, result: dict) -> dict:
    """What diagnose said against the truth. Outcome and whether it counts as right:

    - library effect (the eight, or one diagnose searches by default: contact and hysteresis,
      behind the screen), observable: `top1` (effects[0] is it), else `wrong_name`,
      `unexplained`, `insufficient_excitation` or `missed` (consistent, parameters_only);
    - library effect, unobservable: right unless it names another effect (`wrong_name`) or
      says `unexplained`;
    - clean: right when consistent or parameters_only; `named` and `unexplained` are false
      positives, `insufficient_excitation` is counted apart;
    - out of the library: `named` (a library name) is the worst answer; `unexplained` and
      `insufficient_excitation` (an honest "cannot tell") are right; `missed` (consistent,
      parameters_only) is not."""
    spec = spec.resolved()
    verdict = result.get("verdict")
    names = [e.get("name") for e in result.get("effects") or []]
    first = names[0] if names else None
    if spec.effect in LIBRARY or spec.effect in {e.name for e in fx.SEARCHED}:
        if first == spec.effect:
            outcome = "top1"
        elif first is not None:
            outcome = "wrong_name"
        elif verdict in ("consistent", "parameters_only"):
            outcome = "missed"
        else:
            outcome = str(verdict)
        right = outcome == "top1" if observable else outcome in ("top1", "missed", "insufficient_excitation")
    elif spec.effect == CLEAN:
        outcome = (
            "named" if first else ("ok" if verdict in ("consistent", "parameters_only") else str(verdict))
        )
        right = outcome == "ok"
    else:
        outcome = (
            "named" if first else ("missed" if verdict in ("consistent", "parameters_only") else str(verdict))
        )
        right = outcome in ("unexplained", "insufficient_excitation")
    return {"verdict": verdict, "named": names, "outcome": outcome, "right": right}
