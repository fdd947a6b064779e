"""Golden frames for the RRC board and the LOBOT controller: every worked example of the
transports reference (computed from the vendors' SDK packing, three RRC ones are the vendor's
own), copied verbatim, so the codecs are checked independently of our emulator."""

from __future__ import annotations

import pytest

from choreo.bus.protocol import BROADCAST_ID, Command
from choreo.bus.transports import lobot, rrc


def h(text: str) -> bytes:
    return bytes.fromhex(text)


# --- RRC: host -> board ------------------------------------------------------------------------
RRC_REQUESTS = [
    (
        "move 1000 ms: 1->500, 2->300",
        lambda: rrc.move_frame([(1, 500), (2, 300)], 1000),
        "AA 55 05 0A 01 E8 03 02 01 F4 01 02 2C 01 36",
    ),
    ("stop 1,2", lambda: rrc.stop_frame([1, 2]), "AA 55 05 04 03 02 01 02 4B"),
    ("read position 1", lambda: rrc.read_frame(Command.POS_READ, 1), "AA 55 05 02 05 01 6F"),
    ("read voltage 1", lambda: rrc.read_frame(Command.VIN_READ, 1), "AA 55 05 02 07 01 FE"),
    ("read temperature 1", lambda: rrc.read_frame(Command.TEMP_READ, 1), "AA 55 05 02 09 01 22"),
    (
        "unload 1 (0B)",
        lambda: rrc.write_frame(Command.LOAD_OR_UNLOAD_WRITE, 1, {"loaded": 0}),
        "AA 55 05 02 0B 01 B3",
    ),
    (
        "load 1 (0C)",
        lambda: rrc.write_frame(Command.LOAD_OR_UNLOAD_WRITE, 1, {"loaded": 1}),
        "AA 55 05 02 0C 01 DD",
    ),
    (
        "read load state 1",
        lambda: rrc.read_frame(Command.LOAD_OR_UNLOAD_READ, 1),
        "AA 55 05 02 0D 01 19",
    ),
    (
        "ID write 1 -> 2",
        lambda: rrc.write_frame(Command.ID_WRITE, 1, {"new_id": 2}),
        "AA 55 05 03 10 01 02 68",
    ),
    (
        "ID read broadcast",
        lambda: rrc.read_frame(Command.ID_READ, BROADCAST_ID),
        "AA 55 05 02 12 FE D8",
    ),
    (
        "offset adjust 1 by -10",
        lambda: rrc.write_frame(Command.ANGLE_OFFSET_ADJUST, 1, {"offset_units": -10}),
        "AA 55 05 03 20 01 F6 A3",
    ),
    ("read offset 1", lambda: rrc.read_frame(Command.ANGLE_OFFSET_READ, 1), "AA 55 05 02 22 01 C0"),
    (
        "save offset 1",
        lambda: rrc.write_frame(Command.ANGLE_OFFSET_WRITE, 1, {}),
        "AA 55 05 02 24 01 6A",
    ),
    (
        "angle limits 1: 100..900",
        lambda: rrc.write_frame(Command.ANGLE_LIMIT_WRITE, 1, {"min_units": 100, "max_units": 900}),
        "AA 55 05 06 30 01 64 00 84 03 90",
    ),
    (
        "read angle limits 1",
        lambda: rrc.read_frame(Command.ANGLE_LIMIT_READ, 1),
        "AA 55 05 02 32 01 2C",
    ),
    (
        "voltage limits 1: 4500..14000",
        lambda: rrc.write_frame(Command.VIN_LIMIT_WRITE, 1, {"min_mv": 4500, "max_mv": 14000}),
        "AA 55 05 06 34 01 94 11 B0 36 4B",
    ),
    (
        "read voltage limits 1",
        lambda: rrc.read_frame(Command.VIN_LIMIT_READ, 1),
        "AA 55 05 02 36 01 17",
    ),
    (
        "temperature limit 1: 85",
        lambda: rrc.write_frame(Command.TEMP_MAX_LIMIT_WRITE, 1, {"temp_c": 85}),
        "AA 55 05 03 38 01 55 81",
    ),
    (
        "read temperature limit 1",
        lambda: rrc.read_frame(Command.TEMP_MAX_LIMIT_READ, 1),
        "AA 55 05 02 3A 01 5A",
    ),
]


@pytest.mark.parametrize("what, encode, golden", RRC_REQUESTS, ids=[r[0] for r in RRC_REQUESTS])
def test_rrc_requests_match_the_worked_examples(what, encode, golden):
    assert encode() == h(golden)


# --- RRC: board -> host ------------------------------------------------------------------------
RRC_REPLIES = [
    (Command.POS_READ, 1, "AA 55 05 05 01 05 00 F4 01 92", {"pos_units": 500}),
    (Command.POS_READ, 1, "AA 55 05 05 01 05 FF 00 00 BC", {}),  # servo silent: status FF
    (Command.VIN_READ, 1, "AA 55 05 05 01 07 00 E8 1C 54", {"vin_mv": 7400}),
    (Command.TEMP_READ, 1, "AA 55 05 04 01 09 00 20 D6", {"temp_c": 32}),
    (Command.LOAD_OR_UNLOAD_READ, 1, "AA 55 05 04 01 0D 00 01 35", {"loaded": 1}),
    (Command.ID_READ, BROADCAST_ID, "AA 55 05 04 FE 12 00 01 CB", {"servo_id": 1}),
    (Command.ANGLE_OFFSET_READ, 1, "AA 55 05 04 01 22 00 F6 09", {"offset_units": -10}),
    (
        Command.ANGLE_LIMIT_READ,
        1,
        "AA 55 05 07 01 32 00 64 00 84 03 00",
        {"min_units": 100, "max_units": 900},
    ),
    (Command.TEMP_MAX_LIMIT_READ, 1, "AA 55 05 04 01 3A 00 55 2B", {"temp_c": 85}),
]


@pytest.mark.parametrize("command, servo_id, golden, fields", RRC_REPLIES)
def test_rrc_replies_decode_as_the_worked_examples(command, servo_id, golden, fields):
    (frame,) = rrc.FrameDecoder().feed(h(golden))
    board = rrc.RrcBoard(port=None)
    sub = rrc.READ_SUBS[command]
    assert board._answer(frame, command, sub, servo_id) == fields
    assert len(h(golden)) == rrc.reply_total(command)


def test_rrc_battery_frame_is_told_apart_from_replies():
    battery = h("AA 55 00 03 04 E8 1C 2B")
    reply = h("AA 55 05 05 01 05 00 F4 01 92")
    frames = rrc.FrameDecoder().feed(battery + reply)
    assert [rrc.battery_mv(f) for f in frames] == [7400, None]
    board = rrc.RrcBoard(port=None)
    assert board._answer(frames[0], Command.POS_READ, 0x05, 1) is None
    assert board.battery_mv == 7400
    assert rrc.encode_frame(0, bytes.fromhex("04 E8 1C")) == battery


def test_rrc_crc_check_value_and_resynchronisation():
    assert rrc.crc8(b"123456789") == 0xA1
    decoder = rrc.FrameDecoder()
    corrupt = bytearray(h("AA 55 05 05 01 05 00 F4 01 92"))
    corrupt[-2] ^= 0x10
    good = h("AA 55 05 04 01 09 00 20 D6")
    frames = decoder.feed(b"\xaa\x55\x0f" + bytes(corrupt) + good)  # FUNC 15: resynchronise
    assert frames == [rrc.Frame(5, h("01 09 00 20"))]
    assert decoder.bad_checksums == 1


def test_rrc_reply_for_another_request_is_not_taken():
    (frame,) = rrc.FrameDecoder().feed(h("AA 55 05 05 01 05 00 F4 01 92"))
    board = rrc.RrcBoard(port=None)
    assert board._answer(frame, Command.POS_READ, 0x05, 2) is None  # another servo's
    assert board._answer(frame, Command.VIN_READ, 0x07, 1) is None  # another sub-command's


# --- LOBOT -------------------------------------------------------------------------------------
def test_lobot_requests_match_the_worked_examples():
    assert lobot.move_frame([(1, 500), (2, 300)], 1000) == h(
        "55 55 0B 03 02 E8 03 01 F4 01 02 2C 01"
    )
    assert lobot.battery_frame() == h("55 55 02 0F")
    assert lobot.unload_frame([1, 2, 3, 4, 5, 6]) == h("55 55 09 14 06 01 02 03 04 05 06")
    assert lobot.read_positions_frame([1, 2]) == h("55 55 05 15 02 01 02")


def test_lobot_replies_decode_as_the_worked_examples():
    decoder = lobot.FrameDecoder()
    battery, positions = decoder.feed(
        h("55 55 04 0F E8 1C") + h("55 55 09 15 02 01 F4 01 02 2C 01")
    )
    assert battery == lobot.Frame(0x0F, h("E8 1C"))
    assert int.from_bytes(battery.params, "little") == 7400
    assert lobot.positions(positions) == {1: 500, 2: 300}


def test_lobot_hid_report_port_adds_the_report_id_and_drops_the_padding():
    class FakeHid:
        """Answers a position read of servo 1 with one padded 64-byte input report."""

        def __init__(self):
            self.written, self.reports = [], [h("55 55 04 0F E8 1C") + bytes(58)]  # stale

        def write(self, data):
            self.written.append(bytes(data))
            self.reports.append(h("55 55 06 15 01 01 F4 01") + bytes(56))

        def read(self, size, timeout_ms):
            assert timeout_ms > 0  # hidapi would block for good on 0
            return self.reports.pop(0) if self.reports else b""

    device = FakeHid()
    board = lobot.LobotBoard(lobot.HidReportPort(device, timeout_s=0.05), lobot.hid_capabilities())
    assert board.request(Command.POS_READ, 1, 0.05).fields == {"pos_units": 500}
    assert device.written == [b"\x00" + h("55 55 04 15 01 01")]


def test_lobot_hid_without_hidapi_names_the_extra(monkeypatch):
    import sys

    from choreo.bus.transports import connect
    from choreo.errors import PortError

    monkeypatch.setitem(sys.modules, "hid", None)
    with pytest.raises(PortError, match=r"pip install 'choreo\[lobot\]'"):
        connect("lobot://hid", 0.05)


@pytest.mark.parametrize("servos", [1, 2, 6, 18])
def test_a_lobot_move_frame_is_7_plus_3n_bytes(servos):
    frame = lobot.move_frame([(i, 500) for i in range(1, servos + 1)], 1000)
    assert len(frame) == 7 + 3 * servos  # 55 55 LEN 03 n time:u16, then id pos:u16 each
    assert lobot.CAPABILITIES.move_frame_bytes + 3 * servos == len(frame)


def test_an_18_servo_lobot_move_frame_takes_63_5_ms_at_9600_baud():
    link_s = (lobot.CAPABILITIES.move_frame_bytes + 3 * 18) * lobot.CAPABILITIES.host_byte_time_s
    assert link_s == pytest.approx(61 * 10 / 9600)
    assert round(link_s * 1000, 1) == 63.5


def test_the_lobot_hid_report_interval_is_a_setting():
    assert lobot.report_ms("lobot://hid") == lobot.DEFAULT_REPORT_MS == 1.0
    assert lobot.report_ms("lobot://hid?report_ms=32") == 32
    # one frame (at most one report) per interval
    assert lobot.hid_capabilities(32).host_byte_time_s * lobot.HID_REPORT == pytest.approx(0.032)
    from choreo.errors import PortError

    for bad in ("lobot://hid?report_ms=0", "lobot://hid?report_ms=x", "lobot://hid?rate=32"):
        with pytest.raises(PortError, match=r"report_ms=N .* 1 to 255 ms"):
            lobot.report_ms(bad)


def test_lobot_hid_connect_takes_the_report_interval(monkeypatch):
    monkeypatch.setattr(lobot.HidReportPort, "open_first", classmethod(lambda cls, t: cls(None, t)))
    connection = lobot.connect("lobot://hid?report_ms=32", 0.05)
    assert connection.capabilities.host_byte_time_s == pytest.approx(0.032 / lobot.HID_REPORT)
