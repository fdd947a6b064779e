"""Emulated servos in front of a physical world: what they read, hold and report comes from it.

A small fake world (a horn that lags its set-point by a fixed amount, and falls when unloaded)
stands in for the MuJoCo one, so these tests are about the emulator's side of the contract.
"""

from __future__ import annotations

import pytest

from choreo.bus.servo_bus import ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, connection
from choreo.emulator.physics import PhysicalServo, SetPoint

SAG_UNITS = 7.0  # the fake world's horn hangs this far below its set-point when loaded
FALL_UNITS_S = 100.0  # ... and falls this fast when unloaded


class FakeHorn:
    """A servo's horn in a fake world: it follows the set-point SAG_UNITS low while loaded, and
    falls from where it was when it is not."""

    def __init__(self, start_units: float):
        self.drives: list[tuple[float, float, bool]] = []  # (time, set-point start, loaded)
        self._setpoint: SetPoint | None = None
        self._loaded = True
        self._since_s = 0.0
        self._resting_units = start_units
        self.vin = 7400
        self.temp = 30.0

    def drive(self, time_s: float, setpoint: SetPoint, loaded: bool) -> None:
        if not loaded:
            self._resting_units = self.output_units(time_s)
        self.drives.append((time_s, setpoint.start_units, loaded))
        self._setpoint, self._loaded, self._since_s = setpoint, loaded, time_s

    def output_units(self, time_s: float) -> float:
        if self._setpoint is None:
            return self._resting_units
        if not self._loaded:
            return self._resting_units + FALL_UNITS_S * (time_s - self._since_s)
        s = self._setpoint
        moving = max(0.0, min(time_s, s.end_s) - s.start_s)
        return s.start_units + s.velocity_units_s * moving + SAG_UNITS

    def vin_mv(self, time_s: float) -> int:
        return self.vin

    def temp_c(self, time_s: float) -> float:
        return self.temp


class FakeWorld:
    def __init__(self, *positions: float):
        self.horns = [FakeHorn(p) for p in positions]
        self.servos = tuple(
            PhysicalServo(i + 1, "LX-16A", p, horn)
            for i, (p, horn) in enumerate(zip(positions, self.horns))
        )


@pytest.fixture
def world_bus():
    world = FakeWorld(500.0, 300.0)
    emulator = BusEmulator(clock=VirtualClock(), physics=world)
    bus = ServoBus(connection(emulator))
    yield world, emulator, bus
    bus.close()


def test_the_world_puts_its_servos_on_the_bus_loaded_where_it_stands(world_bus):
    world, emulator, bus = world_bus
    assert [s.servo_id for s in emulator.servos] == [1, 2]
    assert bus.read_loaded(1) and bus.read_loaded(2)
    assert bus.read_position(2) == 300  # the world's horn, not yet driven


def test_reads_are_where_the_world_has_the_horn_not_where_the_servo_aims(world_bus):
    world, emulator, bus = world_bus
    bus.move(1, 600, 200)
    bus.clock.sleep_until(bus.clock.now() + 0.5)
    assert bus.read_position(1) == 600 + SAG_UNITS
    assert bus.read_move(1).pos_units == 600  # what it was asked stays what it was asked
    assert emulator.servo(1).output_units == pytest.approx(600 + SAG_UNITS)


def test_supply_and_temperature_come_from_the_world_and_raise_faults(world_bus):
    world, emulator, bus = world_bus
    world.horns[0].vin, world.horns[0].temp = 6900, 41.0
    assert bus.read_vin(1) == 6900
    assert bus.read_temperature(1) == 41
    world.horns[0].temp = 99.0  # past the servo's 85 °C limit: it lets go
    assert bus.read_temperature(1) == 99
    assert not bus.read_loaded(1)
    assert world.horns[0].drives[-1][2] is False


def test_a_stop_holds_where_the_horn_is_and_a_move_after_unloading_starts_there(world_bus):
    world, emulator, bus = world_bus
    horn = world.horns[0]
    bus.move(1, 600, 1000)
    bus.clock.sleep_until(bus.clock.now() + 0.3)
    bus.stop(1)
    reading = bus.read_position(1)  # (after the stop, which it waits for)
    held_at = horn.drives[-1][1]
    # it aims where the horn was (sagged 7 below its set-point then), not at its own set-point
    assert 500 < held_at < 600
    assert held_at == pytest.approx(reading - SAG_UNITS, abs=0.5)
    bus.unload(1)
    bus.clock.sleep_until(bus.clock.now() + 0.5)  # it falls 50 units
    fallen = bus.read_position(1)
    assert fallen == pytest.approx(reading + 50, abs=1)
    bus.move(1, 500, 1000)
    assert bus.read_loaded(1)  # (the move has arrived)
    assert horn.drives[-1][1] == pytest.approx(fallen, abs=1)  # from where it fell to


def test_a_servo_in_a_world_cannot_be_moved_by_hand(world_bus):
    world, emulator, bus = world_bus
    bus.unload(1)
    with pytest.raises(ValueError, match="physics"):
        emulator.servo(1).move_by_hand(400)
