"""The RRC board and the LOBOT controller, emulated in front of the emulated servos, driven
through ServoBus and the player on a virtual clock: what works, what is refused, start skew."""

from __future__ import annotations

import numpy as np
import pytest
from emulated import home_specs, recorded_writes

from choreo.bus.protocol import BYTE_TIME_S, Command, decode_request
from choreo.bus.servo_bus import Presence, ServoBus
from choreo.core.clock import VirtualClock
from choreo.emulator import connection
from choreo.emulator.boards import BOARDS, SERVO_REPLY_TIMEOUT_S
from choreo.errors import BusTimeoutError, UnsupportedByTransport
from choreo.motion.motion_file import load_motion
from choreo.plan.performance import prepare
from choreo.plan.pipeline import compile_motion
from choreo.play.path_errors import path_errors_deg
from choreo.play.player import Player
from choreo.play.preflight import preflight, unchecked
from choreo.play.report import Outcome

LX_MOVE_S = 10 * BYTE_TIME_S  # one 10-byte MOVE_TIME_WRITE on the servo bus
TRANSPORT = {"rrc": "RRC board", "lobot": "LOBOT controller"}


def board_bus(board: str, ids: str = "1-6") -> ServoBus:
    return ServoBus(f"sim://?board={board}&ids={ids}&clock=virtual")


def moves_of(emulator, command=Command.MOVE_TIME_WRITE):
    return [p for p in list(emulator.log.packets) if p.packet.command == command]


@pytest.mark.parametrize("board", BOARDS)
def test_scan_and_status_through_the_board(board):
    with board_bus(board) as bus:
        assert bus.capabilities.transport == TRANSPORT[board]
        assert bus.scan(range(0, 9)) == [1, 2, 3, 4, 5, 6]
        status = bus.read_status(3)
        assert status.pos_units == 500
        expected = (7200, 30) if board == "rrc" else (None, None)
        assert (status.vin_mv, status.temp_c) == expected


def test_rrc_answers_status_ff_for_a_silent_servo_after_its_5_ms():
    with board_bus("rrc") as bus:
        emulator = bus.emulator
        sent_s = emulator.clock.now()
        assert bus.presence(9) is Presence.SILENT
        # the board's FF reply arrived: the host did not wait its own 50 ms timeout
        assert emulator.clock.now() - sent_s < SERVO_REPLY_TIMEOUT_S + 0.002
        assert emulator.clock.now() - sent_s >= SERVO_REPLY_TIMEOUT_S


@pytest.mark.parametrize("board, writes", [("rrc", 1), ("lobot", 3)])
def test_several_writes_go_out_in_order_in_as_few_port_writes_as_the_link_carries(board, writes):
    # The RRC board parses frames back to back: one port write. The LOBOT controller's HID
    # report holds one frame: one port write each. Either way the frames of one send each.
    unload = {"loaded": 0}
    with board_bus(board) as bus:
        written = recorded_writes(bus)
        for servo_id in (2, 5, 3):
            bus.backend.send(Command.LOAD_OR_UNLOAD_WRITE, servo_id, unload)
        one_by_one = list(written)
        written.clear()
        count = bus.backend.send_many(
            Command.LOAD_OR_UNLOAD_WRITE, [(i, unload) for i in (2, 5, 3)]
        )
        assert count == len(b"".join(one_by_one)) and b"".join(written) == b"".join(one_by_one)
        assert len(written) == writes
        bus.drain()
        bus.emulator.clock.advance(0.1)
        unloads = moves_of(bus.emulator, Command.LOAD_OR_UNLOAD_WRITE)
        assert [p.packet.servo_id for p in unloads] == [2, 5, 3, 2, 5, 3]


@pytest.mark.parametrize(
    "board, action",
    [
        ("rrc", lambda bus: bus.set_led(1, True)),
        ("rrc", lambda bus: bus.stage_move(1, 300, 100)),
        ("rrc", lambda bus: bus.stage_many([(1, 300), (2, 400)], 100)),
        ("lobot", lambda bus: bus.stage_many([(1, 300), (2, 400)], 100)),
        ("rrc", lambda bus: bus.start()),
        ("rrc", lambda bus: bus.read_mode(1)),
        ("lobot", lambda bus: bus.read_vin(1)),
        ("lobot", lambda bus: bus.stop(1)),
        ("lobot", lambda bus: bus.set_id(1, 2)),
        ("lobot", lambda bus: bus.load(1)),
    ],
)
def test_a_command_the_board_cannot_carry_is_refused_naming_it(board, action):
    with board_bus(board) as bus:
        before = len(list(bus.emulator.log.packets))
        with pytest.raises(UnsupportedByTransport, match=TRANSPORT[board]) as refused:
            action(bus)
        assert "\n" not in str(refused.value)
        assert "raw LX bus" in str(refused.value)  # what to use instead
        assert "--" not in str(refused.value)  # in the library's words: no flags
        assert len(list(bus.emulator.log.packets)) == before  # nothing sent


def test_rrc_battery_frames_are_demultiplexed_and_stale_replies_skipped():
    with board_bus("rrc") as bus:
        emulator = bus.emulator
        opened_s = emulator.clock.now()  # the board sends its battery once a second from here
        emulator.battery_mv = 7100
        emulator.clock.sleep_until(opened_s + 3.0 - 0.00001)  # during the request
        assert bus.read_vin(2) == 7200  # the battery frame arrives before this reply
        assert bus.backend.battery_mv == 7100
        emulator.clock.sleep_until(opened_s + 4.0 - 0.0002)
        with pytest.raises(BusTimeoutError):  # the reply comes after this tiny timeout...
            bus.request(Command.POS_READ, 1, retries=0, timeout_s=0.0001)
        assert bus.read_temperature(5) == 30  # ...and is not taken for this one's
        assert bus.read_position(4) == 500


@pytest.mark.parametrize("board", BOARDS)
def test_a_move_frame_is_forwarded_one_servo_at_a_time(board):
    with board_bus(board, "1-18") as bus:
        emulator = bus.emulator
        bus.move_many([(i, 400) for i in range(1, 19)], 200)
        bus.drain()
        bus.read_position(1)
        starts = [m.time_s for m in moves_of(emulator)]
        assert [m.packet.servo_id for m in moves_of(emulator)] == list(range(1, 19))
        assert np.allclose(np.diff(starts), LX_MOVE_S)
        assert starts[-1] - starts[0] == pytest.approx(bus.capabilities.start_skew_s(18), abs=1e-9)


MOTIONS = [
    "motions/arm6/wave.yaml",
    "motions/hexapod18/tripod_gait.yaml",
    "motions/tonypi/bow.yaml",
]


@pytest.mark.parametrize("board", BOARDS)
@pytest.mark.parametrize("path", MOTIONS)
def test_the_player_plays_through_the_board(board, path):
    motion = load_motion(path)
    robot = motion.robot
    emulator = BOARDS[board](home_specs(robot), clock=VirtualClock())
    with ServoBus(connection(emulator, timeout_s=0.05)) as bus:
        assert "motor mode" in unchecked(bus)
        pose, limits = preflight(bus, robot)
        performance = prepare(compile_motion(motion), pose)
        report = Player(bus, robot, emulator.clock, limits).play(performance.ticks, pose)
    assert report.outcome is Outcome.COMPLETED, report.reason
    assert report.transport == TRANSPORT[board]
    n = len(robot.joints)
    assert report.start_skew_ms == pytest.approx((n - 1) * LX_MOVE_S * 1000)
    # one move frame per tick, nothing staged, no START
    assert not moves_of(emulator, Command.MOVE_TIME_WAIT_WRITE)
    assert not moves_of(emulator, Command.MOVE_START)
    # the servos followed the plan, give or take the skew's and the slow link's worth of motion
    # (benchmarks/bench_transports.py measures it)
    times = np.arange(0.0, report.planned_s, 0.002)
    errors = path_errors_deg(
        emulator.log.moves,
        robot,
        [j.to_units(a) for j, a in zip(robot.joints, pose)],
        report.start_time_s,
        times,
        performance.planned_deg(times),
    )
    assert max(errors) < 8.0


def test_rrc_stop_is_one_stop_frame_for_the_robots_servos():
    with board_bus("rrc") as bus:
        emulator = bus.emulator
        bus.move_many([(i, 200) for i in range(1, 7)], 2000)
        bus.stop_servos(range(1, 7))
        bus.drain()
        bus.read_position(1)
        stops = moves_of(emulator, Command.MOVE_STOP)
        assert [s.packet.servo_id for s in stops] == [1, 2, 3, 4, 5, 6]
        assert all(emulator.servo(i).position_units > 200 for i in range(1, 7))  # held midway


def test_lobot_stop_holds_the_servos_where_they_are():
    with board_bus("lobot") as bus:
        emulator = bus.emulator
        bus.move_many([(i, 200) for i in range(1, 7)], 2000)
        emulator.clock.sleep_until(emulator.clock.now() + 0.5)
        bus.stop_servos(range(1, 7))
        bus.drain()
        emulator.clock.sleep_until(emulator.clock.now() + 3.0)
        held = moves_of(emulator)[6:]
        assert [m.packet.servo_id for m in held] == [1, 2, 3, 4, 5, 6]
        for servo_id in range(1, 7):
            assert 250 < emulator.servo(servo_id).position_units < 450  # stopped on its way


def test_a_lobot_stop_whose_read_times_out_holds_the_last_commanded_targets():
    from choreo.emulator.reply_faults import ReplyFaults

    with board_bus("lobot", ids="1-3") as bus:
        emulator = bus.port.emulator
        bus.move_many([(1, 200), (2, 300), (3, 800)], 2000)
        emulator.clock.sleep_until(emulator.clock.now() + 0.5)
        emulator.servo(2).reply_faults = ReplyFaults(drop_probability=1.0)  # its reads time out
        bus.stop_servos([1, 2, 3])
        bus.drain()
        held = moves_of(emulator)[3:]
        targets = {m.packet.servo_id: decode_request(m.packet) for m in held}
        assert set(targets) == {1, 2, 3}
        assert targets[2] == {"pos_units": 300, "time_ms": 0}  # its last commanded target
        assert 200 < targets[1]["pos_units"] < 500  # read: where it was on its way
        assert targets[1]["time_ms"] == 0


def test_recording_by_hand_through_the_rrc_board(tmp_path):
    from choreo.play.recorder import Ending, Recorder
    from choreo.play.recording import Recording
    from choreo.robot.robot_file import load_robot

    robot = load_robot("arm6")
    emulator = BOARDS["rrc"](home_specs(robot), clock=VirtualClock())
    bus = ServoBus(connection(emulator))
    recording = Recording.start(tmp_path / "taught.yaml", robot)

    def typing():
        assert [emulator.servo(i).loaded for i in (1, 2, 3)] == [True, False, True]
        emulator.servo(2).move_by_hand(600)  # shoulder: 24°
        yield ""
        yield "q"

    with Recorder(bus, recording, emulator.clock, taught=["shoulder"]) as recorder:
        assert recorder.run_keyframes(typing()) is Ending.QUIT
    recording.save()
    assert "24" in (tmp_path / "taught.yaml").read_text()
    assert emulator.servo(2).loaded  # held again (0C through the board)


def test_recording_through_the_lobot_controller_is_refused_naming_it(tmp_path):
    from choreo.play.recorder import Recorder
    from choreo.play.recording import Recording
    from choreo.robot.robot_file import load_robot

    robot = load_robot("arm6")
    emulator = BOARDS["lobot"](home_specs(robot), clock=VirtualClock())
    bus = ServoBus(connection(emulator))
    recording = Recording.start(tmp_path / "taught.yaml", robot)
    for taught in (["shoulder"], None):  # None: every joint
        with pytest.raises(UnsupportedByTransport, match="refused through the LOBOT controller"):
            with Recorder(bus, recording, emulator.clock, taught=taught):
                pass
    # refused before anything was sent to a servo: nothing unloaded
    assert not [p for p in emulator.log.packets if p.packet.command != Command.POS_READ]


def test_choreo_record_through_the_lobot_controller_unloads_nothing(tmp_path, capsys):
    from choreo.cli import main

    state = tmp_path / "servos.json"
    port = f"sim://?board=lobot&clock=virtual&state={state}"
    out = tmp_path / "taught.yaml"
    assert main(["record", "--robot", "arm6", "--port", port, str(out)]) == 1
    err = capsys.readouterr().err
    assert "refused through the LOBOT controller" in err and err.count("\n") == 1
    assert "unloaded, pose by hand" not in capsys.readouterr().out


def test_the_rrc_port_opens_at_1_mbaud_with_rts_and_dtr_low(monkeypatch):
    import serial

    opened = []
    real = serial.serial_for_url

    def spy(url, **settings):
        port = real("sim://?board=rrc&ids=1&clock=virtual", **settings)
        opened.append((url, settings))
        port_open = port.open

        def open_and_record():
            opened.append(("lines at open", port.rts, port.dtr))
            port_open()

        port.open = open_and_record
        return port

    monkeypatch.setattr(serial, "serial_for_url", spy)
    with ServoBus("rrc:///dev/ttyAMA0") as bus:
        assert bus.read_position(1) == 500
    (url, settings), lines = opened
    assert url == "/dev/ttyAMA0" and settings["baudrate"] == 1_000_000
    assert lines == ("lines at open", False, False)


def test_direction_control_is_refused_for_a_board():
    from choreo.errors import PortError

    with pytest.raises(PortError, match="the RRC board drives its own servo bus"):
        ServoBus("sim://?board=rrc&ids=1&clock=virtual", direction="tonypi")
