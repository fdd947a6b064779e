"""The servo's law at each physics step (``ServoDrive``): delay, offset, gear play, dead band; and
when two servo states go on alike (what lets a simulation take the rest of an earlier one)."""

from __future__ import annotations

import numpy as np
import pytest

from choreo.errors import OptionError
from choreo.plan.ticks import Tick
from choreo.preview.actuator import (
    ActuatorParams,
    CommandStream,
    ServoBank,
    ServoDrive,
    actuator_params,
)
from choreo.robot.robot_file import load_robot

ARM6 = load_robot("arm6")
DT_S = 0.002


def one_servo(**figures: float) -> ActuatorParams:
    return actuator_params(ARM6, {"base_yaw": figures})[0]


def drive_of(params: ActuatorParams) -> ServoDrive:
    return ServoDrive([params], DT_S, np.zeros(1))


def test_a_position_inside_the_dead_band_makes_no_pull_and_outside_it_pulls_the_excess():
    drive = drive_of(one_servo(deadband_deg=1.0, backlash_deg=0.0))
    aim = np.radians([2.0])
    inside = drive.ctrl(aim, np.radians([1.6]))  # 0.4° short: inside half of the 1° band
    assert inside == pytest.approx(np.radians([1.6]))  # ctrl == position: no torque
    outside = drive.ctrl(aim, np.radians([1.0]))  # 1° short: 0.5° past the band
    assert np.degrees(outside - np.radians([1.0])) == pytest.approx([0.5])


def test_gear_play_takes_up_a_reversal_before_the_aim_turns_back():
    drive = drive_of(one_servo(deadband_deg=0.0, backlash_deg=2.0))
    for angle in np.linspace(0, 10, 50):  # going up: the aim trails 1° behind
        drive.ctrl(np.radians([angle]), np.radians([angle]))
    assert np.degrees(drive.aim_rad) == pytest.approx([9.0])
    drive.ctrl(np.radians([8.5]), np.radians([9.0]))  # 1.5° back: inside the 2° play
    assert np.degrees(drive.aim_rad) == pytest.approx([9.0])
    drive.ctrl(np.radians([7.0]), np.radians([9.0]))  # 3° back: turned back by 1°
    assert np.degrees(drive.aim_rad) == pytest.approx([8.0])


def test_a_response_delay_acts_on_set_points_that_many_steps_old_and_an_offset_shifts_them():
    drive = drive_of(
        one_servo(deadband_deg=0.0, backlash_deg=0.0, response_delay_s=0.01, offset_deg=2.0)
    )
    seen = [
        float(np.degrees(drive.ctrl(np.radians([float(k)]), np.zeros(1))[0])) for k in range(1, 9)
    ]
    # five steps (10 ms) late, and 2° further: the set-points 1, 2, 3 come out from step 6 on
    assert seen == pytest.approx([2.0] * 5 + [3.0, 4.0, 5.0])


def test_a_response_delay_between_two_steps_acts_on_the_set_point_between_theirs():
    delay_s = 2.5 * DT_S  # rounded to whole steps it would act 0.5 step early or late
    drive = drive_of(one_servo(deadband_deg=0.0, backlash_deg=0.0, response_delay_s=delay_s))
    seen = [
        float(np.degrees(drive.ctrl(np.radians([float(k)]), np.zeros(1))[0])) for k in range(1, 7)
    ]
    # the set-points 1, 2, 3 ... two and a half steps late: 0 until then, 0.5, 1.5, 2.5 after
    assert seen == pytest.approx([0.0, 0.0, 0.5, 1.5, 2.5, 3.5])


def test_damping_follows_the_stall_torque_and_speed_unless_given():
    given = one_servo(stall_torque_nm=1.0, no_load_speed_deg_s=200.0)
    assert given.damping_nm_s_rad == pytest.approx(1.0 / np.radians(200.0))  # back-EMF
    fixed = one_servo(stall_torque_nm=1.0, damping_nm_s_rad=0.5)
    assert fixed.damping_nm_s_rad == 0.5


def test_figures_out_of_range_are_refused_naming_the_field():
    with pytest.raises(OptionError, match="base_yaw's response_delay_s 0.5; it must be a numb"):
        one_servo(response_delay_s=0.5)
    with pytest.raises(OptionError, match="base_yaw's friction_nm -1.0; it must be a number >= 0"):
        one_servo(friction_nm=-1.0)
    assert one_servo(offset_deg=-3.0).offset_deg == -3.0


def test_two_servo_banks_are_the_same_but_for_rounding_and_a_rested_servos_old_preset_time():
    def bank(first_ms: int, nudge=(0.0, 0.0), second: int = 1) -> ServoBank:
        """Both servos sent to 600 over ``first_ms``; at 0.8 s, the first alone on to 700."""
        stream = CommandStream.from_ticks(
            [
                Tick(0, first_ms, (600, 600), (True, True)),
                Tick(800, 400, (700, 600), (True, False)),
            ],
            2,
        )
        servos = ServoBank(np.array([500.0, 500.0]), max_speed_units_s=None)
        servos.start(stream, 0, 0.0, np.array([500.0, 500.0]))
        servos.start(stream, second, 0.8, servos.setpoint_units(0.8) + nudge)
        return servos

    ours = bank(500)
    assert ours.same_as(bank(500, nudge=(1e-12, 0.0)), 1.0)  # a bit apart
    # the second servo, at 600 since 0.5 s (or 0.7 s), re-runs its preset at 0.8 s going
    # nowhere: how long the preset was to take no longer matters
    assert ours.same_as(bank(700), 1.0)
    # one not there yet at 0.8 s (due at 0.9 s) re-runs it over its whole time again
    assert not ours.same_as(bank(900), 1.0)
    assert not ours.same_as(bank(500, nudge=(0.1, 0.0)), 1.0)  # the first moving from elsewhere
    assert not ours.same_as(bank(500, second=0), 1.0)  # the first re-staged otherwise


def test_two_servo_drives_go_on_alike_with_aims_within_tolerance_and_the_same_delayed_set_points():
    def drive_after(setpoints_deg, **figures: float) -> ServoDrive:
        drive = drive_of(one_servo(deadband_deg=0.0, **figures))
        for angle in setpoints_deg:
            drive.ctrl(np.radians([angle]), np.zeros(1))
        return drive

    # going up, the aim trails by the half play; 1e-4° further and back leaves it that far on
    ours = drive_after([1.0, 2.0, 3.0], backlash_deg=2.0)
    assert ours.same_as(drive_after([1.0, 2.0, 3.0], backlash_deg=2.0), 1e-9)
    nudged = drive_after([1.0, 2.0, 3.0001, 3.0], backlash_deg=2.0)
    assert not ours.same_as(nudged, 1e-9) and ours.same_as(nudged, np.radians(1e-3))
    # a set-point still waiting out the delay differs: not the same, at any tolerance
    late = drive_after([1.0, 2.0, 3.0], backlash_deg=0.0, response_delay_s=0.01)
    other = drive_after([1.5, 2.0, 3.0], backlash_deg=0.0, response_delay_s=0.01)
    assert np.array_equal(late.aim_rad, other.aim_rad) and not late.same_as(other, 1.0)


class ReferenceDrive:
    """The servo's law written plainly, as ``ServoDrive`` had it before it was made lean: the
    set-point ``delay`` steps late (between two steps, the set-point between theirs), plus the
    offset, turned back only past the half play, less the error inside the half band."""

    def __init__(self, params: list[ActuatorParams], initial_rad: np.ndarray):
        self.offset = np.radians([p.offset_deg for p in params])
        self.half_play = np.radians([p.backlash_deg for p in params]) / 2
        self.half_band = np.radians([p.deadband_deg for p in params]) / 2
        self.delay_steps = np.array([p.response_delay_s / DT_S for p in params])
        self.seen = [np.array(initial_rad, dtype=float)]
        self.aim = np.array(initial_rad, dtype=float) + self.offset

    def ctrl(self, setpoint: np.ndarray, position: np.ndarray) -> np.ndarray:
        self.seen.append(np.array(setpoint, dtype=float))
        late = np.empty(len(setpoint))
        for j, delay in enumerate(self.delay_steps):
            whole = round(delay) if np.isclose(delay, round(delay)) else int(np.floor(delay))
            part = 0.0 if np.isclose(delay, round(delay)) else delay - np.floor(delay)
            newer = self.seen[max(len(self.seen) - 1 - whole, 0)][j]
            older = self.seen[max(len(self.seen) - 2 - whole, 0)][j]
            late[j] = newer + (older - newer) * part
        wanted = late + self.offset
        self.aim = np.minimum(
            np.maximum(self.aim, wanted - self.half_play), wanted + self.half_play
        )
        error = np.minimum(np.maximum(self.aim - position, -self.half_band), self.half_band)
        return self.aim - error


@pytest.mark.parametrize("delays_s", [(0.0, 0.0, 0.0, 0.0), (0.0, 0.004, 0.0037, 0.011)])
def test_the_drive_gives_exactly_what_the_plain_law_gives_over_random_set_points(delays_s):
    rng = np.random.default_rng(7)
    figures = {
        name: {
            "response_delay_s": delay,
            "backlash_deg": float(rng.uniform(0.0, 3.0)),
            "deadband_deg": float(rng.uniform(0.0, 1.0)),
            "offset_deg": float(rng.uniform(-5.0, 5.0)),
        }
        for name, delay in zip(ARM6.joint_names, delays_s)
    }
    params = list(actuator_params(ARM6, figures)[: len(delays_s)])
    initial = rng.uniform(-1.0, 1.0, len(params))
    drive, reference = ServoDrive(params, DT_S, initial), ReferenceDrive(params, initial)
    out = np.empty(len(params))
    # a random walk of set-points (so the gear play turns back and forth) and positions near them
    setpoint = initial.copy()
    for step in range(400):
        setpoint = setpoint + rng.normal(0.0, 0.01, len(params))
        position = setpoint + rng.normal(0.0, 0.01, len(params))
        expected = reference.ctrl(setpoint, position)
        if step % 2:  # into a given array, or a new one
            assert drive.ctrl(setpoint, position, out=out) is out
            got = out
        else:
            got = drive.ctrl(setpoint, position)
        assert np.array_equal(got, expected), f"step {step}"
        assert np.array_equal(drive.aim_rad, reference.aim), f"step {step}"


def delayed_servos_with_play(rng):
    """Four of arm6's servos with gear play and offsets, delayed by no step, two whole steps,
    1.85 steps and 5.5 steps: their parameters and random start angles (rad)."""
    figures = {
        name: {"response_delay_s": delay, "backlash_deg": 1.0, "offset_deg": 0.5}
        for name, delay in zip(ARM6.joint_names, (0.0, 0.004, 0.0037, 0.011))
    }
    return list(actuator_params(ARM6, figures)[:4]), rng.uniform(-1.0, 1.0, 4)


def test_set_points_known_for_a_stretch_of_steps_give_what_one_step_at_a_time_gives():
    """The step loop works out a stretch's delayed set-points and play edges at once
    (``play_edges``), then follows them step by step: the plain law's controls and aims, and
    the delay line ``ctrl`` leaves one step at a time, with delays of whole steps and between
    two."""
    rng = np.random.default_rng(11)
    params, initial = delayed_servos_with_play(rng)
    stepped, stretched = ServoDrive(params, DT_S, initial), ServoDrive(params, DT_S, initial)
    reference = ReferenceDrive(params, initial)
    setpoints = initial + np.cumsum(rng.normal(0.0, 0.01, (300, 4)), axis=0)
    positions = setpoints + rng.normal(0.0, 0.01, (300, 4))
    bounds = [0, 1, 2, 5, 17, 18, 60, 200, 300]  # stretches shorter and longer than the delay
    for begin, end in zip(bounds[:-1], bounds[1:]):
        edges = stretched.play_edges(setpoints[begin:end])
        for k, (low, high) in enumerate(zip(*edges), start=begin):
            expected = reference.ctrl(setpoints[k], positions[k])
            assert np.array_equal(stretched.follow(low, high, positions[k]), expected), k
            stepped.ctrl(setpoints[k], positions[k])
        assert np.array_equal(stretched.aim_rad, reference.aim)
        assert stretched.same_as(stepped, 0.0)  # the same set-points waiting out the delay


def test_edges_worked_out_ahead_and_cut_short_are_what_play_edges_gives():
    """The emulated robot works a stretch's play edges out ahead (``edges_ahead``) and, when
    a servo is driven anew, moves the delay line on by the steps it took (``move_on``): the
    edges ``play_edges`` gives for those steps, and after them the same delay line (the next
    stretch's edges equal), with delays of whole steps and between two."""
    rng = np.random.default_rng(13)
    params, initial = delayed_servos_with_play(rng)
    played, ahead = ServoDrive(params, DT_S, initial), ServoDrive(params, DT_S, initial)
    setpoints = initial + np.cumsum(rng.normal(0.0, 0.01, (400, 4)), axis=0)
    begin = 0
    for used in (3, 0, 1, 20, 64, 150):  # of 64 or more worked out ahead
        low, high, line = ahead.edges_ahead(setpoints[begin : begin + max(used, 64)])
        expected_low, expected_high = played.play_edges(setpoints[begin : begin + used])
        assert np.array_equal(low[:used], expected_low), begin
        assert np.array_equal(high[:used], expected_high), begin
        ahead.move_on(line, used)
        begin += used
