"""Which members of a set stand out of the structure it leaves, on the raw angle.

When the model with every effect found still leaves structure (the residual follows the
command), a later effect may be absorbing physics outside the library (an even spring
taken for gravity, sharp friction's shape for air drag), so the engine names the first
alone. But a set of library effects whose forms are each a little off the physics (dry
friction with a static peak, which no library form has) leaves structure too, and naming
the first alone drops effects the recording shows plainly: dry friction, gravity and an
asymmetric spring on steps, where gravity alone, dropped from the three, raises the raw
RMS error from 0.46 to 1.07 deg while the three leave 0.4 deg above the sensor's noise.

A member stands out when the set without it, the others refitted, simulated from the
recorded command and scored on the raw angle with a constant offset (raw_error.py),
misses the recording by more, in squared error, than everything the full set leaves
above the sensor's white noise: what the member explains alone is more than all that is
left outside the library, the standard a single effect meets to be named the dominant
one over structure left (report/verdict.py). A stand-in for outside physics explains
part of that physics and leaves the rest; it stands out only where it takes most of it.
The set is named (graded `dominant`, the structure reported) only when every member
stands out; the checks that follow (posture, outside the library, the raw-signal gate)
judge it as any other.

Where the set follows the raw angle to the sensor's noise, nothing is left to compare a
member with: there a member stands out only when the set without it does not tie with the
set on the raw angle (raw_error's tie: both at the noise, within TIE_SHARE), so an effect
that moves the raw error by a percent beside one that takes it to the noise is not named
with it. The white noise is the least of three figures, each the noise plus something: the
robust spread of the recorded angle's sample-to-sample differences (plus the motion's own
differences), the same of the set's residual (plus what the set leaves of a fast motion)
and the set's raw error (plus its misfit). A motion with much of its power near the
Nyquist frequency makes the first large (a Duffing oscillator at 610 Hz; the paper's
finger, ringing at 9.5 Hz, at 100 Hz), and where the set follows that motion its
residual's differences are the sensor's alone. Where the set leaves a fast motion (a
second mode at 20 Hz) every figure stays above the noise; the least is still the
nearest, and each member then has more left to beat, not less.

Where some members stand out and others do not (dead time, dry friction and a dead zone on
steps at 500 Hz: left out, the dead zone raises the raw error from 0.32 to 1.38 deg and
friction to 0.56, the 5 ms dead time only to 0.42, less than the 0.32 deg the set leaves
above the noise), the members that stand out are fitted again without the others, one by
one from the plain refit (each must pass the forward selection's own gate beside those
before it), and named as the set when each of them still stands out there: what explains
more of the recording than all that is left is said, rather than the greedy path's first
effect alone (the dead time, which explains 5 % of it). The members that do not stand out
are reported apart, as the later effects of a set that does not stand out are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import Fit, fit
from hand_service.diagnose.fitting.raw_error import TIE_SHARE
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.recording.response_onset import white_noise_deg
from hand_service.diagnose.search.forward_selection import Round, Selection, beside


@dataclass(frozen=True)
class Member:
    name: str
    without_deg: float  # the set's raw RMS error with this member left out, the others refitted


@dataclass(frozen=True)
class Standing:
    """The set's raw RMS error, the sensor's white noise, and each member's figure."""

    set_deg: float
    noise_deg: float
    members: tuple[Member, ...]

    @property
    def left_deg2(self) -> float:
        """What the set leaves above the sensor's white noise (mean squared, deg²)."""
        return max(self.set_deg**2 - self.noise_deg**2, 0.0)

    def unique_deg2(self, member: Member) -> float:
        """What the member explains beside the others (mean squared, deg²)."""
        return member.without_deg**2 - self.set_deg**2

    def ties_without(self, member: Member) -> bool:
        """The set and the set without `member` tie on the raw angle: both at the noise."""
        return (raw_error.at_noise(self.set_deg, self.noise_deg)
                and member.without_deg <= (1.0 + TIE_SHARE) * self.set_deg)

    def stands_out(self, member: Member) -> bool:
        return not self.ties_without(member) and self.unique_deg2(member) > self.left_deg2

    @property
    def all_stand_out(self) -> bool:
        return bool(self.members) and all(self.stands_out(m) for m in self.members)

    def each_without(self) -> str:
        """The set's raw error with each member left out, as the sentences print it."""
        return ", ".join(f"without {m.name} {m.without_deg:.3g}" for m in self.members)

    def sentence(self) -> str:
        each = self.each_without()
        left = float(np.sqrt(self.left_deg2))
        return (f"structure is left beside {', '.join(m.name for m in self.members)}, but each explains "
                f"more of the recorded angle than all that is left: simulated from the command, the set "
                f"misses the raw angle by {self.set_deg:.3g} deg RMS ({left:.3g} deg above the sensor's "
                f"white noise, at most {self.noise_deg:.3g}), and with one left out, the others refitted, by "
                f"more ({each} deg)")


def without(problem: Problem, final: Fit, name: str) -> Fit:
    """`final` refitted with the effect `name` left out (at its neutral value)."""
    keep = [i for i, p in enumerate(final.params) if p.label != name]
    return fit(problem, [final.params[i] for i in keep], final.values[keep],
               base=final.without(problem, [name]))


def standing(problem: Problem, final: Fit, names: list[str], fitting: np.ndarray,
             held: np.ndarray) -> Standing:
    """Each of `names` (effects in `final`) left out in turn, the rest refitted, on the raw angle."""
    scored = fitting | held

    def raw_deg(angle_deg: np.ndarray) -> float:
        return raw_error.raw_rms_deg(problem, angle_deg, fitting, scored)

    members = tuple(Member(name, raw_deg(without(problem, final, name).angle_deg)) for name in names)
    set_deg = raw_deg(final.angle_deg)
    noise_deg = min(white_noise_deg(problem.measured_deg), white_noise_deg(problem.residual(final.angle_deg)),
                    set_deg)
    return Standing(set_deg, noise_deg, members)


@dataclass(frozen=True)
class StandOut:
    """The members of a set that stand out, fitted again without the others."""

    selection: Selection
    standing: Standing  # the kept members', in their own fit
    dropped: tuple[str, ...]  # the members that did not stand out

    def sentence(self) -> str:
        them = "it" if len(self.dropped) == 1 else "them"
        each = self.standing.each_without()
        kept = ", ".join(m.name for m in self.standing.members)
        return (f"structure is left beside the effects found, and {', '.join(self.dropped)} explains less of "
                f"the recorded angle than all that is left; {kept}, fitted again without {them}, each "
                f"explain more than what is left (simulated from the command, the raw angle missed by "
                f"{self.standing.set_deg:.3g} deg RMS, the sensor's white noise at most "
                f"{self.standing.noise_deg:.3g}; {each} deg), so they are kept without {them} (the checks "
                "that follow decide what is named)")


def stand_out(problem: Problem, refit: Fit, found: Standing, fitting: np.ndarray,
              held: np.ndarray) -> StandOut | None:
    """The members of `found` that stand out, fitted again from the plain `refit` without the
    others, when some but not all stand out, each passes the forward selection's gate beside
    those before it, and each still stands out in their own fit; else None."""
    keep = [m.name for m in found.members if found.stands_out(m)]
    if not keep or len(keep) == len(found.members):
        return None
    rounds, accepted, base = [], [], refit
    for name in keep:
        candidate = beside(problem, base, name)
        if not candidate.significant:
            return None
        rounds.append(Round(base, [candidate]))
        accepted.append(candidate)
        base = candidate.fit
    again = standing(problem, base, keep, fitting, held)
    if not again.all_stand_out:
        return None
    dropped = tuple(m.name for m in found.members if m.name not in keep)
    return StandOut(Selection(rounds=rounds, accepted=accepted, final=base), again, dropped)
