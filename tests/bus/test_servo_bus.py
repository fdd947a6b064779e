"""ServoBus against the emulator: every read with echo on and off, retries, faults, refusals."""

from __future__ import annotations

import pytest
import serial
from emulated import recorded_writes
from servo_bus_helpers import ECHO_SETUPS, make_bus

from choreo.bus.protocol import BROADCAST_ID, Command, encode_request
from choreo.bus.servo_bus import EchoMode, Presence, ScanResult, ServoBus
from choreo.bus.settings import BUILT_IN_PORT, BusSettings
from choreo.bus.transports import Connection, lobot, raw, rrc
from choreo.core.clock import VirtualClock
from choreo.emulator import BusEmulator, ReplyFaults, ServoSpec, SimSerial, connection
from choreo.errors import BusTimeoutError, OptionError, PortError, ProtocolError

BYTE_TIME_S = 10 / 115200  # start + 8 data + stop bits at 115200 baud


def test_scan_finds_every_servo_and_only_them(bus_and_emulator):
    bus, _ = bus_and_emulator
    assert bus.scan(range(0, 10)) == [1, 2, 3]


def test_scan_tries_each_id_once_with_the_bus_timeout():
    bus, emulator = make_bus(timeout_s=0.03)
    before = emulator.clock.now()
    assert bus.scan(range(0, 10)) == [1, 2, 3]
    answer_s = (6 + 7) * BYTE_TIME_S + emulator.turnaround_s  # ID_READ and its reply
    assert emulator.clock.now() - before == pytest.approx(7 * 0.03 + 3 * answer_s, abs=1e-4)


def test_servos_sharing_an_id_are_garbled_not_absent():
    emulator = BusEmulator([ServoSpec(1), ServoSpec(1), ServoSpec(2)], clock=VirtualClock())
    bus = ServoBus(connection(emulator))
    assert [bus.presence(i) for i in (1, 2, 3)] == [
        Presence.GARBLED,
        Presence.ANSWERS,
        Presence.SILENT,
    ]
    assert bus.scan_presence(range(0, 5)) == ScanResult(found=(2,), garbled=(1,))
    assert bus.scan(range(0, 5)) == [2]
    with pytest.raises(ProtocolError, match="two servos may share ID 1"):
        bus.ping(1)
    assert bus.ping(2) and not bus.ping(3)


def test_probe_raises_a_wrong_echo_setting_instead_of_calling_every_id_garbled():
    bus, _ = make_bus(echo=False, mode=EchoMode.DISCARD)
    with pytest.raises(ProtocolError, match="expected the echo of the request"):
        bus.scan(range(0, 4))


def test_staged_moves_start_together_on_broadcast():
    bus, emulator = make_bus()
    for servo_id, pos in ((1, 200), (2, 400), (3, 600)):
        bus.stage_move(servo_id, pos, 300)
    bus.port.flush()
    emulator.clock.advance(0.002)
    bus.start()
    bus.port.flush()
    starts = [m for m in emulator.log.moves if m.command == Command.MOVE_START]
    assert {m.servo_id for m in starts} == {1, 2, 3}
    assert len({m.time_s for m in starts}) == 1
    emulator.clock.advance(0.5)
    assert [bus.read_position(i) for i in (1, 2, 3)] == [200, 400, 600]


def test_stage_many_writes_the_staged_moves_in_order_at_once_after_checking_them_all():
    bus, emulator = make_bus()
    writes = recorded_writes(bus)
    moves = [(3, 600), (1, 200), (2, 400)]
    assert bus.stage_many(moves, 300) == 3 * 10
    # one write (one system call; behind direction lines one transmit window), the same
    # packets stage_move sends, in the order given
    assert writes == [
        b"".join(
            encode_request(Command.MOVE_TIME_WAIT_WRITE, i, pos_units=p, time_ms=300)
            for i, p in moves
        )
    ]
    with pytest.raises(ValueError, match="pos_units must be in 0..1000, got 5000"):
        bus.stage_many([(1, 100), (2, 5000)], 300)
    with pytest.raises(ValueError, match="servo_id"):
        bus.stage_many([(1, 100), (BROADCAST_ID + 1, 100)], 300)
    assert len(writes) == 1  # not even the first, valid move of either was sent
    assert bus.stage_many([], 300) == 0
    bus.port.flush()
    emulator.clock.advance(0.002)
    bus.start()
    emulator.clock.advance(0.5)
    assert [bus.read_position(i) for i in (1, 2, 3)] == [200, 400, 600]


def test_dropped_replies_are_retried():
    bus, emulator = make_bus(retries=2)
    emulator.servo(1).reply_faults = ReplyFaults(drop_next=2)
    assert bus.read_position(1) == 500


def test_corrupted_replies_are_retried():
    bus, emulator = make_bus(retries=2)
    emulator.servo(1).reply_faults = ReplyFaults(corrupt_next=2)
    assert bus.read_vin(1) > 0


def test_absent_servo_times_out_after_every_try_in_virtual_time():
    bus, emulator = make_bus(retries=2, timeout_s=0.05)
    before = emulator.clock.now()
    with pytest.raises(BusTimeoutError, match="servo 9"):
        bus.read_temperature(9)
    assert emulator.clock.now() - before == pytest.approx(3 * 0.05, abs=0.005)


def test_late_reply_of_a_timed_out_read_is_not_taken_for_the_next_reply():
    # A reply that arrives after the read gave up must be flushed, not read as the next answer.
    bus, emulator = make_bus(retries=0, timeout_s=0.05)
    emulator.turnaround_s = 0.06  # later than the timeout
    with pytest.raises(BusTimeoutError):
        bus.read_position(1)
    emulator.turnaround_s = 0.0006
    emulator.clock.advance(0.1)  # the late POS_READ reply is now in the input buffer
    assert bus.read_vin(1) == emulator.servo(1).vin_mv


def test_echo_is_never_taken_for_a_reply():
    # With echo on and the servo silent, the echoed request (a valid packet) must not count.
    bus, emulator = make_bus(echo=True, mode=EchoMode.AUTO, retries=0)
    emulator.servo(1).connected = False
    with pytest.raises(BusTimeoutError):
        bus.read_id(1)


def test_an_echoing_adapter_costs_wire_time_not_a_timeout_in_auto_mode():
    # The echo fills part of the first read; the rest of the reply must be asked for exactly, or
    # the read waits its whole timeout for bytes that never come.
    bus, emulator = make_bus(echo=True, mode=EchoMode.AUTO, retries=0, timeout_s=0.05)
    for read, reply_len in ((bus.read_position, 8), (bus.read_id, 7), (bus.read_distance, 10)):
        before = emulator.clock.now()
        read(1)
        wire_s = (6 + reply_len) * BYTE_TIME_S + emulator.turnaround_s
        assert emulator.clock.now() - before == pytest.approx(wire_s, abs=BYTE_TIME_S / 2)


ALL_ECHO_SETUPS = ECHO_SETUPS + [(True, EchoMode.NONE), (False, EchoMode.DISCARD)]


@pytest.mark.parametrize("echo", [False, True], ids=["quiet-bus", "echoing-bus"])
@pytest.mark.parametrize("mode", list(EchoMode), ids=lambda m: m.value)
def test_a_read_right_after_many_staged_writes_is_answered(echo, mode):
    # The player stages up to 18 moves and then reads health: on an echoing bus the echoes of
    # those writes (180 bytes, 15.6 ms of wire) arrive before the reply, in every echo mode.
    bus, emulator = make_bus(ids=range(1, 19), echo=echo, mode=mode, retries=0, timeout_s=0.02)
    for servo_id in range(1, 19):
        bus.stage_move(servo_id, 400 + servo_id, 300)
    if echo or mode is not EchoMode.DISCARD:
        assert bus.read_position(1) == 500
        assert bus.read_vin(18) == emulator.servo(18).vin_mv
    else:  # DISCARD on a bus that does not echo: the set-up is wrong, and it says so
        with pytest.raises(ProtocolError, match="expected the echo of the request"):
            bus.read_position(1)
    assert [p.packet.command for p in emulator.log.packets].count(
        Command.MOVE_TIME_WAIT_WRITE
    ) == 18


def test_moves_sent_as_one_frame_on_a_one_wire_bus_leave_the_next_read_answered():
    # On the raw bus move_many writes all its MOVE_TIME_WRITEs at once; in DISCARD mode their
    # echoes are skipped by the next request, as those of any other write are.
    bus, emulator = make_bus(ids=range(1, 7), echo=True, mode=EchoMode.DISCARD, retries=0)
    assert bus.move_many([(servo_id, 400) for servo_id in range(1, 7)], 200) == 6 * 10
    emulator.clock.advance(0.5)
    assert [bus.read_position(servo_id) for servo_id in range(1, 7)] == [400] * 6


@pytest.mark.parametrize("echo,mode", ALL_ECHO_SETUPS, ids=lambda p: getattr(p, "value", p))
def test_a_silent_servo_after_staged_writes_waits_every_timeout(echo, mode):
    bus, emulator = make_bus(ids=range(1, 19), echo=echo, mode=mode, retries=2, timeout_s=0.02)
    emulator.servo(7).connected = False
    for servo_id in range(1, 19):
        bus.stage_move(servo_id, 450, 300)
    before = emulator.clock.now()
    error = BusTimeoutError if echo or mode is not EchoMode.DISCARD else ProtocolError
    with pytest.raises(error):
        bus.read_position(7)
    staging_s = 18 * 10 * BYTE_TIME_S
    assert emulator.clock.now() - before >= staging_s + 3 * 0.02 * 0.99


class StrayByteBeforeEachRequest(SimSerial):
    """A line that picks up one noise byte as each request starts, so it precedes the echo."""

    def write(self, data):
        if len(data) == 6:  # a read request
            self.emulator._schedule(self.emulator.clock.now(), b"\x00")
        return super().write(data)


class DescheduledAfterFirstRead(SimSerial):
    """The host loses the CPU for 0.5 s right after its first read returns."""

    reads = 0

    def read(self, size=1):
        data = super().read(size)
        self.reads += 1
        if self.reads == 1:
            self.emulator.clock.advance(0.5)
        return data


def test_a_reply_that_arrived_while_the_host_was_descheduled_is_taken():
    # Past its deadline the attempt still looks at what has already arrived: the reply is there.
    emulator = BusEmulator(range(1, 19), clock=VirtualClock(), echo=True)
    port = DescheduledAfterFirstRead.from_emulator(emulator)
    bus = ServoBus(raw.connect(port, 0.02, clock=emulator.clock), retries=0, timeout_s=0.02)
    for servo_id in range(1, 19):
        bus.stage_move(servo_id, 450, 300)
    bus.drain()
    assert bus.read_position(3) == 500


@pytest.mark.parametrize("mode", [EchoMode.DISCARD, EchoMode.AUTO], ids=lambda m: m.value)
def test_a_stray_byte_before_the_echo_is_skipped_not_fatal(mode):
    emulator = BusEmulator((1, 2, 3), clock=VirtualClock(), echo=True)
    port = StrayByteBeforeEachRequest.from_emulator(emulator)
    bus = ServoBus(port, echo=mode, retries=0)
    assert bus.scan_presence(range(0, 6)) == ScanResult(found=(1, 2, 3), garbled=())
    assert bus.read_position(2) == 500


def test_scan_with_retries_finds_a_servo_whose_first_reply_was_corrupted():
    bus, emulator = make_bus()
    emulator.servo(2).reply_faults = ReplyFaults(corrupt_next=1)
    assert bus.scan_presence(range(0, 5), retries=1) == ScanResult(found=(1, 2, 3), garbled=())
    emulator.servo(2).reply_faults = ReplyFaults(corrupt_next=1)
    assert bus.scan_presence(range(0, 5), retries=0) == ScanResult(found=(1, 3), garbled=(2,))


def test_broadcast_rules():
    bus, _ = make_bus(ids=(7,))
    assert bus.read_id() == 7  # broadcast ID_READ with one servo: its real ID
    with pytest.raises(ValueError, match="only ID_READ is answered on broadcast"):
        bus.request(Command.POS_READ, BROADCAST_ID)
    with pytest.raises(ValueError, match="refusing to broadcast ID_WRITE"):
        bus.set_id(BROADCAST_ID, 3)
    with pytest.raises(ValueError, match="refusing to broadcast ID_WRITE"):
        bus.send(Command.ID_WRITE, BROADCAST_ID, new_id=3)
    assert bus.read_id(7) == 7  # nothing was sent


def test_out_of_range_arguments_are_value_errors():
    bus, _ = make_bus()
    with pytest.raises(ValueError, match="pos_units must be in 0..1000, got 1200"):
        bus.move(1, 1200, 100)
    with pytest.raises(ValueError, match="has no reply"):
        bus.request(Command.MOVE_STOP, 1)


class WrittenPort:
    """A port that keeps what is written and never answers."""

    name, timeout = "written", 0.01

    def __init__(self):
        self.writes: list[bytes] = []

    def write(self, data: bytes) -> int:
        self.writes.append(bytes(data))
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def flush(self) -> None: ...

    reset_input_buffer = reset_output_buffer = close = flush


def test_each_packet_is_checked_once_and_encoded_once(monkeypatch):
    """The real-time path: ServoBus checks a command's values, its transport encodes the packet
    once, and it goes out as one write."""
    from choreo.bus import protocol

    encoded = []
    encode_packet = protocol.encode_packet
    monkeypatch.setattr(
        protocol, "encode_packet", lambda *a: encoded.append(a) or encode_packet(*a)
    )
    port = WrittenPort()
    bus = ServoBus(port)
    bus.stage_move(3, 512, 40)
    bus.start()
    assert len(encoded) == 2
    assert port.writes == [
        encode_packet(3, Command.MOVE_TIME_WAIT_WRITE, bytes.fromhex("00 02 28 00")),
        encode_packet(BROADCAST_ID, Command.MOVE_START),
    ]
    encoded.clear()
    assert bus.move_many([(i, 500) for i in range(1, 19)], 40) == 18 * 10
    assert len(encoded) == 18 and len(port.writes) == 3


@pytest.mark.parametrize(
    "call",
    [
        lambda bus: bus.move(1, 1001, 40),
        lambda bus: bus.move(255, 500, 40),
        lambda bus: bus.move_many([(1, 500), (2, 1001)], 40),
        lambda bus: bus.move_many([(1, 500), (300, 500)], 40),
        lambda bus: bus.read_position(300),
    ],
    ids=["field", "servo_id", "move_many field", "move_many servo_id", "read servo_id"],
)
@pytest.mark.parametrize("board", [raw.RawBus, rrc.RrcBoard, lobot.LobotBoard])
def test_a_bad_value_is_refused_the_same_on_every_transport_before_anything_is_sent(call, board):
    port = WrittenPort()
    bus = ServoBus(Connection(port, board(port), VirtualClock()), retries=0)
    with pytest.raises(OptionError, match=r"^(pos_units|servo_id) must be in 0\.\.(1000|254)"):
        call(bus)
    assert port.writes == []


def test_open_by_url_and_exclusive_access():
    with ServoBus("sim://?ids=4-5&clock=virtual") as bus:
        assert bus.scan(range(0, 8)) == [4, 5]


def test_from_settings_opens_the_port_they_name_with_their_timeout_retries_and_echo():
    settings = BusSettings(port="sim://?ids=4-5&clock=virtual", timeout_s=0.02, retries=1)
    emulator = BusEmulator([9], clock=VirtualClock())
    with ServoBus.from_settings(settings, emulated=connection(emulator)) as bus:
        assert (bus.name, bus.timeout_s, bus.retries) == (settings.port, 0.02, 1)
        assert bus.scan(range(0, 10)) == [4, 5]
    discarding = ServoBus.from_settings(BusSettings(port="sim://?clock=virtual", echo="discard"))
    assert discarding.backend.echo is EchoMode.DISCARD


def test_from_settings_without_a_port_is_the_one_built_in_emulated_bus_unless_given_another():
    with ServoBus.from_settings(BusSettings()) as bus:
        assert bus.name == BUILT_IN_PORT == "sim://?ids=1-6"
        assert [s.servo_id for s in bus.emulator.servos] == [1, 2, 3, 4, 5, 6]
    emulator = BusEmulator([9], clock=VirtualClock())
    with ServoBus.from_settings(BusSettings(retries=0), emulated=connection(emulator)) as bus:
        assert bus.emulator is emulator and bus.scan(range(0, 10)) == [9]


def test_from_settings_takes_only_settings():
    with pytest.raises(OptionError, match="settings must be a BusSettings, e.g. BusSettings"):
        ServoBus.from_settings({"port": "sim://"})


def test_unopenable_port_is_a_port_error():
    with pytest.raises(PortError, match="cannot open /dev/does-not-exist.*sim://"):
        ServoBus("/dev/does-not-exist")
    with pytest.raises(PortError, match="unknown option"):
        ServoBus("sim://?idz=1")
    # pyserial 3.5's loop:// fails on an unknown option with a KeyError: a PortError still
    with pytest.raises(PortError, match=r"^cannot open loop://\?bogus=1: [^\n]+$"):
        ServoBus("loop://?bogus=1")


def test_a_real_serial_loop_echoes_and_times_out():
    # pyserial's loop:// is a wire that only echoes: every read must time out, not return the echo.
    with ServoBus(serial.serial_for_url("loop://", timeout=0.01), retries=0, timeout_s=0.01) as bus:
        with pytest.raises(BusTimeoutError):
            bus.read_position(1)


class UnpluggedPort:
    """A port whose USB adapter was pulled after it was opened: every I/O call fails."""

    name = "/dev/ttyUSB0"
    timeout = 0.05

    def __init__(self, error: Exception):
        self.error = error

    def _fail(self, *args):
        raise self.error

    write = read = flush = reset_input_buffer = reset_output_buffer = close = _fail


@pytest.mark.parametrize(
    "error",
    [
        serial.SerialException("write failed: [Errno 5] Input/output error"),
        OSError(19, "No such device"),
    ],
    ids=["SerialException", "OSError"],
)
@pytest.mark.parametrize(
    "use",
    [
        lambda bus: bus.move(1, 500, 100),
        lambda bus: bus.read_position(1),
        lambda bus: bus.drain(),
        lambda bus: bus.discard_output(),
        lambda bus: bus.close(),
    ],
    ids=["send", "request", "drain", "discard_output", "close"],
)
def test_a_port_lost_after_opening_is_a_port_error(use, error):
    bus = ServoBus(UnpluggedPort(error), retries=2)
    with pytest.raises(
        PortError, match=r"^/dev/ttyUSB0: the port was lost \(.+\): check the USB cable$"
    ):
        use(bus)
