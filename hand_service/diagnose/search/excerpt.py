"""A long recording searched over the effects its leading excerpt found worth fitting.

The search's cost is its fits times the recording's length: every candidate is fitted from
several starts, each fit a run of simulations over every sample. A recording longer than
BUDGET_SAMPLES, of which those are at most MAX_SHARE, is first diagnosed on its first
BUDGET_SAMPLES samples by the whole of `diagnose` (every effect searched). The whole
recording is then diagnosed by the same rules with the search's candidates restricted to
what that excerpt found worth fitting (`worth_fitting`): its named and partial effects, the
effects accepted or carried in its selection, both of a tie, and every effect that gained
over SIGNIFICANT_BIC in any of its rounds. Every figure of the report is the whole's; only
the candidate list came from the excerpt, and the report says so in one sentence
(`Restricted.sentence`).

Where the excerpt cannot decide what to search (its verdict insufficient_excitation, the
plain model unable to follow it so that nothing was searched, or a recording it cannot be
diagnosed on at all), the whole is searched as it would be without the excerpt. Where it
finds nothing worth fitting, the whole's search has no candidates and its verdict is the
plain model's, by the usual rules; the residual tests run on the whole, so physics that
shows only after the excerpt leaves structure they report as unexplained, not as a name
the excerpt did not test (docs/diagnose-design.md, "Long recordings").

BUDGET_SAMPLES lies above every recording the project measures its answers on below the
long one (the battery's 30 s at up to 1 kHz, the bench's 30 s at 100 Hz, the real rigs),
so that none of them is searched from an excerpt.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.diagnose.search.forward_selection import SIGNIFICANT_BIC, Progress
from hand_service.errors import UserError

BUDGET_SAMPLES = 40_000  # a longer recording is searched over what its first this many samples found
# and only where that excerpt is at most this share of it: the excerpt's own diagnosis costs
# its share of the whole's, which the fewer candidates must win back
MAX_SHARE = 0.4

# one diagnosis of the samples `part` with the search over `names`; `graded` False: without the
# rivals fitted in place of the named effects (rival_check.py, loop_rival.py), which decide
# only the grade and whether the names stand (a withdrawn name is partial), not what an excerpt
# finds worth fitting
Run = Callable[[slice, list[str], bool], Diagnosis]


def worth_fitting(excerpt: Diagnosis) -> set[str]:
    """The effects the excerpt's diagnosis found worth fitting: named, partial, accepted or
    carried (one of a tie) in its selection, the other of a tie, and every candidate of
    every round that gained over SIGNIFICANT_BIC."""
    selection = excerpt.selection
    names = {e.name for e in [*excerpt.effects, *excerpt.partial_effects]}
    names |= {c.name for c in [*selection.accepted, *selection.carried, *(selection.ambiguous or ())]}
    names |= {c.name for round_ in selection.rounds for c in round_.candidates
              if c.delta_bic > SIGNIFICANT_BIC}
    return names


def decides(excerpt: Diagnosis, search: Sequence[str]) -> bool:
    """The excerpt can decide what to search: enough excitation, and a search that ran
    (the plain model followed it) wherever there was something to search."""
    return excerpt.verdict != "insufficient_excitation" and (bool(excerpt.selection.rounds) or not search)


@dataclass(frozen=True)
class Restricted:
    """The whole's search, restricted to what the excerpt's first `excerpt_s` found."""

    names: list[str]  # in the search's own order
    excerpt_s: float
    asked: tuple[str, ...] = ()  # of `names`, those asked for by name that did not gain there

    def sentence(self) -> str:
        gained = [name for name in self.names if name not in self.asked]
        found = ", ".join(gained) if gained else "none"
        if self.asked:
            found += f" (and {', '.join(self.asked)}, asked for)"
        elif not gained:
            found += ", so only the plain model was fitted"
        return (f"a long recording: searched over the effects that gained on the first "
                f"{self.excerpt_s:.3g} s: {found}")


def restricted(excerpt: Diagnosis, search: Sequence[str], asked: Sequence[str], rate_hz: float) -> Restricted:
    """The search's names the excerpt found worth fitting, and those asked for by name."""
    worth = worth_fitting(excerpt)
    names = [name for name in search if name in worth or name in asked]
    return Restricted(names, BUDGET_SAMPLES / rate_hz, tuple(name for name in names if name not in worth))


def searched_from_excerpt(run: Run, n_samples: int, rate_hz: float, search: list[str],
                          asked: Sequence[str], progress: Progress | None = None) -> Diagnosis:
    """`run` over the whole (`n_samples`), its search over `search` restricted to what the
    leading excerpt found where the excerpt (BUDGET_SAMPLES) is at most MAX_SHARE of the
    recording and `decides`; else over `search`, as without the excerpt."""
    whole = slice(0, n_samples)
    if MAX_SHARE * n_samples < BUDGET_SAMPLES:  # not long enough for the excerpt to pay
        return run(whole, search, True)
    if progress:
        progress(f"a long recording: diagnosing its first {BUDGET_SAMPLES / rate_hz:.3g} s "
                 "to choose the effects to search for")
    try:
        excerpt = run(slice(0, BUDGET_SAMPLES), search, False)
    except UserError:
        return run(whole, search, True)  # the excerpt alone cannot be diagnosed: no restriction
    if not decides(excerpt, search):
        return run(whole, search, True)
    chosen = restricted(excerpt, search, asked, rate_hz)
    if progress:
        progress(chosen.sentence())
    result = run(whole, chosen.names, True)
    result.warnings.append(chosen.sentence())
    result.seconds += excerpt.seconds
    return result
