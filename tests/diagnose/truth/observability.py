"""Whether a case of a library effect beyond the eight (contact, hysteresis, pressure
stiffening, creep) is observable, measured on the truth apart from diagnose: the rule
on_request.py scores them by, and the battery's label for them (`labelled`).

The battery's own rule (cases.build: the physics exercised and a visibility of 0.4) was
written for the eight; for an effect beyond them it took the magnitude's name for an
answer where the calibration could not reach its target: an "evident" contact at the
generator's stiffness cap, met past its onset by few of a PRBS's swings, left 0.56 × the
noise over a plain refit and 0.28 × once the eight's state torques were fitted too, and was
counted a miss of diagnose's (docs/results.md §12.60)."""

from __future__ import annotations

import dataclasses

import numpy as np

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.distinct import left_over, library_torques
from tests.diagnose.truth.library_form import ContactForm, contact_form, eight_fit, left_of
from tests.diagnose.truth.recorded import form_fit, parted, rival_fit

# the least time past a contact's onset that shows it, and the least angle range that turns
# a loop over (the on-request rule's 5°)
CONTACT_TIME_S = 0.1
LOOP_RANGE_DEG = 5.0
# the observability bar: what the effect leaves over the noise RMS
OBSERVABLE_LEFT = 0.4
# the effects this rule labels in the battery: the library's beyond the eight
BEYOND_EIGHT = ("contact", "hysteresis", *cs.ON_REQUEST)


def library_left(case: cs.Case) -> float:
    """What the truth's effect leaves of its signature over the sensor's noise RMS once k, B
    and N (a lab's ±25 %), the sensor's offset and drift and the eight's state torques
    (distinct.library_torques: θ³, 1 − cos θ, dry friction, air drag, a backward spring)
    are fitted to it, linearised about the truth's plain finger: its part that neither the
    plain model nor a stand-in among the eight can take (distinct.left_over)."""
    spec = case.spec.resolved()
    _, tau0, delay0 = cs.known_effects(spec.effect, cs.shape_of(spec))
    start = cs.plain_finger(cs.FAMILIES[spec.family], case.truth, tau0, delay0)
    traj = case.trajectory
    return left_over(traj.theta_deg, traj.command_kpa, case.rate_hz, start, case.plan.theta0_deg,
                     case.sensor.noise_rms_deg, library_torques(traj.theta_deg, traj.omega_rad_s))


def observable(case: cs.Case, form: ContactForm | None = None) -> tuple[bool, str]:
    """Observable: the physics exercised (for pressure stiffening and creep the case's own
    rule, cases.exercised; the finger past the contact's onset for CONTACT_TIME_S; the angle
    moved over LOOP_RANGE_DEG for a loop), visibility 0.4 (the plain refit leaves 0.4 × the
    noise), and library_left ≥ OBSERVABLE_LEFT and its nonlinear refit on the noise-free angle
    (library_form.eight_fit) too: measured on the truth, apart from diagnose. Linearised
    about the plain finger, library_left moves the eight's torques through it only as far as a
    linear step does: a pressure stiffening on a ringing slow sine that the eight's state
    effects refitted take to within 0.30 × the noise it counted observable at 0.68
    (docs/results.md §12.66).
    For a contact also the library form's gain (`form`, library_form.contact_form) ≥
    OBSERVABLE_LEFT: what its best fit to the noise-free angle explains beyond k, B and N
    fitted alone. library_left is linearised about the truth's plain finger, so k, B and N
    move in it only as far as a linear step takes them: a contact that a plain refit moving
    k by a third absorbs whole was counted observable by it (docs/results.md §12.31); the
    nonlinear refit on a noise-free copy cannot overcount so.
    And the recording parts them (recorded.py): the library's form at its best and the five
    at theirs, both fitted to the noise-free angle, scored on the recorded angle as diagnose
    scores raw error; the form must follow it closer beyond the fluctuation the sensor gives
    the recording (at raw_difference.LEVEL): a stiffening's form closer than the five by a
    few per cent on the noise-free angle was no closer on the recording, the sensor's
    correlated noise hiding the gap (docs/results.md §12.68), and no tool held to the raw
    signal can name the form there."""
    effect = case.spec.effect
    if effect in cs.ON_REQUEST and not case.observable:
        return False, case.reason
    if case.visibility < 0.4:
        return False, "absorbed by k, B and N at every plausible size tried"
    theta_deg = case.trajectory.theta_deg
    if effect == "contact" and np.sum(theta_deg > case.truth.contact_deg) / case.rate_hz < CONTACT_TIME_S:
        return False, "the finger barely passes the contact's onset"
    if effect == "hysteresis" and np.ptp(theta_deg) < LOOP_RANGE_DEG:
        return False, f"the angle moves under {LOOP_RANGE_DEG:g} deg"
    left = library_left(case)
    if left < OBSERVABLE_LEFT:
        return False, (f"k, B, N, the sensor's offset and drift and the eight's state torques leave "
                       f"{left:.2f} × the noise of it")
    five = eight_fit(case)
    nonlinear = left_of(case, five)
    if nonlinear < OBSERVABLE_LEFT:
        return False, (f"k, B, N and the eight's state effects, fitted to the noise-free angle, leave "
                       f"{nonlinear:.2f} × the noise of it")
    if form is not None and form.gain < OBSERVABLE_LEFT:
        return False, f"the library's contact explains {form.gain:.2f} × the noise beyond a plain refit"
    on_record = parted(case, form_fit(case, form), rival_fit(case, five))
    if not on_record.parted:
        return False, on_record.sentence(effect)
    return True, ""


def labelled(case: cs.Case) -> cs.Case:
    """The case with its observability by `observable` where its effect is beyond the eight
    (BEYOND_EIGHT), else as cases.build labelled it."""
    if case.spec.effect not in BEYOND_EIGHT:
        return case
    seen, reason = observable(case, contact_form(case) if case.spec.effect == "contact" else None)
    return dataclasses.replace(case, observable=seen, reason=reason)
