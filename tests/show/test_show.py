"""Show files, clock offsets, staging, endpoints and the messages of a show (no network here but
one session that cannot open)."""

from __future__ import annotations

import json
import os
import re
import signal
import threading
import time
from importlib import resources
from pathlib import Path

import jsonschema
import pytest
import yaml
from paths import DATA, REPO

from choreo import Outcome
from choreo.errors import ChoreoError, OptionError, SourceError
from choreo.motion.motion_file import load_motion
from choreo.show import network as zenoh_network
from choreo.show.clock_offset import (
    MORE_ROUND_TRIPS,
    ROUND_TRIPS,
    ClockOffset,
    RoundTrip,
    estimate,
    exceeds,
    measure,
)
from choreo.show.messages import (
    Answer,
    ClockReading,
    Finished,
    PartOutcome,
    Readiness,
    StagedPart,
    decode,
    encode,
)
from choreo.show.showfile import OnAbort, load_show
from choreo.show.staging import pack, unpack
from choreo.validate import check_file

SHOWS = DATA / "shows"


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "show.yaml"
    path.write_text(text)
    return path


# --- clock offsets: RFC 5905 (NTP) section 8, with the server's receive and transmit times equal
def test_the_offset_of_one_round_trip_is_ntps():
    # T1 = 10.000 sent, T2 = T3 = 15.003 at the performer, T4 = 10.004 received:
    # offset ((T2 - T1) + (T3 - T4)) / 2 = 5.001, delay (T4 - T1) - (T3 - T2) = 0.004
    trip = RoundTrip(sent_s=10.000, remote_s=15.003, received_s=10.004)
    assert trip.offset_s == pytest.approx(5.001)
    assert trip.rtt_s == pytest.approx(0.004)


def test_the_estimate_takes_the_shortest_round_trip():
    trips = [RoundTrip(0.0, 1.010, 0.020), RoundTrip(1.0, 2.0005, 1.001), RoundTrip(2.0, 3.1, 2.2)]
    found = estimate(trips)
    assert found == ClockOffset(pytest.approx(1.0), pytest.approx(0.0005), 3)


def test_measure_counts_only_answered_round_trips():
    times = iter([0.0, 0.002, 1.0, 1.002])  # the conductor's clock, read around each question
    answers = iter([None, 6.001])
    found = measure(lambda: next(answers), rounds=2, clock=lambda: next(times))
    assert found == ClockOffset(pytest.approx(5.0), pytest.approx(0.001), 1)
    assert measure(lambda: None, rounds=3) is None


class Network:
    """Round trips to a performer whose clock is ``offset_s`` ahead: the first ``slow`` take
    6 ms (a busy machine), the rest 0.2 ms; the conductor's clock advances only by them."""

    def __init__(self, offset_s: float, slow: int):
        self.now, self.offset_s, self.slow, self.asked = 0.0, offset_s, slow, 0

    def clock(self) -> float:
        return self.now

    def ask_time(self) -> float:
        self.asked += 1
        leg_s = 0.003 if self.asked <= self.slow else 0.0001
        self.now += leg_s
        answer = self.now + self.offset_s
        self.now += leg_s
        return answer


def test_slow_round_trips_are_followed_by_more_until_the_bound_can_be_shown():
    network = Network(offset_s=0.0, slow=10)
    found = measure(network.ask_time, clock=network.clock, within_s=0.002)
    assert found is not None and not exceeds(found, 0.002)
    assert network.asked == 11  # 8, then one at a time until a fast one came
    assert found.error_s == pytest.approx(0.0001)


def test_clocks_really_apart_are_still_found_apart_after_every_extra_round_trip():
    network = Network(offset_s=0.005, slow=0)
    found = measure(network.ask_time, clock=network.clock, within_s=0.002)
    assert found is not None and exceeds(found, 0.002)
    assert found.offset_s == pytest.approx(0.005)
    assert network.asked == ROUND_TRIPS + MORE_ROUND_TRIPS


def test_without_a_bound_the_measure_takes_its_rounds_only():
    network = Network(offset_s=0.0, slow=100)
    assert exceeds(measure(network.ask_time, clock=network.clock), 0.002)
    assert network.asked == ROUND_TRIPS


@pytest.mark.parametrize(
    "offset_s, error_s, over",
    [(0.0015, 0.0004, False), (0.0015, 0.0006, True), (-0.0021, 0.0, True), (0.0, 0.0, False)],
)
def test_an_offset_exceeds_the_bound_with_its_error(offset_s, error_s, over):
    assert exceeds(ClockOffset(offset_s, error_s, 8), 0.002) is over


# --- show files ---------------------------------------------------------------------------------
def test_the_shipped_show_loads():
    show = load_show(REPO / "shows" / "groove_trio.yaml")
    assert [p.performer for p in show.parts] == ["tony", "hexa", "arm"]
    assert show.music is not None and show.music.bpm == 112
    assert show.parts[2].offset_s == pytest.approx(2 * 60 / 112)  # offset_beats: 2
    assert show.on_abort is OnAbort.STOP
    assert show.max_clock_offset_s == pytest.approx(0.002)


def test_a_show_file_reports_every_problem_at_its_line(tmp_path):
    (tmp_path / "nod.yaml").write_text((SHOWS / "nod.yaml").read_text())
    path = write(
        tmp_path,
        "performers:\n"
        "  - {name: tony 1, motion: nope.yaml}\n"
        "  - {name: a, motion: nod.yaml}\n"
        "  - {name: a, motion: nod.yaml}\n"
        "  - {name: b, motion: nod.yaml, offset_beats: 2}\n"
        "on_abort: maybe\n"
        "tempo: 3\n",
    )
    with pytest.raises(SourceError) as caught:
        load_show(path)
    assert caught.value.problems == [
        f"{path}:2:12: performer name 'tony 1' may only have ASCII letters, digits, - and _",
        f"{path}:2:28: motion: {tmp_path / 'nope.yaml'} does not exist (paths are relative "
        "to this file's folder)",
        f"{path}:4:5: performer 'a' is named twice (first at line 3); each performer dances "
        "one part",
        f"{path}:5:33: offset_beats needs the show's tempo: give music: {{song: ..., bpm: ...}}, "
        "or write the offset in seconds (offset_s)",
        f"{path}:6:11: on_abort 'maybe' is not one of stop, continue",
        f"{path}:7:1: unknown key 'tempo' in the show; valid keys: name, music, on_abort, "
        "max_clock_offset_ms, performers, cues",
    ]


def test_validate_checks_a_show_and_its_performers_motions(tmp_path):
    motion = tmp_path / "bad.yaml"
    motion.write_text("robot: arm6\nkeyframes:\n  - pose: nowhere\n")
    path = write(tmp_path, "performers:\n  - {name: a, motion: bad.yaml}\n")
    result = check_file(path, physics=False)
    assert len(result.problems) == 1
    assert result.problems[0].startswith(f"{motion}:3:")
    assert check_file(REPO / "shows" / "groove_trio.yaml", physics=False).ok


def test_shipped_shows_match_the_schema():
    schema = json.loads((resources.files("choreo") / "schema" / "show.schema.json").read_text())
    jsonschema.Draft202012Validator.check_schema(schema)
    validator = jsonschema.Draft202012Validator(schema)
    files = [
        *(REPO / "shows").glob("*.yaml"),
        *(SHOWS / f for f in ("duo.yaml", "trio.yaml", "duo_continue.yaml", "cues.yaml")),
    ]
    for path in files:
        assert list(validator.iter_errors(yaml.safe_load(path.read_text()))) == [], path


# --- staging and messages -----------------------------------------------------------------------
def test_a_part_travels_with_every_file_it_uses(tmp_path):
    part = pack("show-1", "ticket", load_motion(REPO / "motions" / "tonypi" / "dance.yaml"))
    assert part.motion == "motions/tonypi/dance.yaml"
    assert part.robot_file == "models/tonypi/robot.yaml"
    assert {name for name, _ in part.files} == {
        "motions/tonypi/dance.yaml",
        "motions/tonypi/dance_bounce.yaml",
        "motions/tonypi/dance_wave.yaml",
        "models/tonypi/robot.yaml",
        "models/tonypi/tonypi.xml",
        "models/tonypi/scene.xml",
        "motions/songs/groove.ogg",
    }
    received = decode(StagedPart, encode(part))
    motion = unpack(received, tmp_path)
    assert motion.path == tmp_path / "motions/tonypi/dance.yaml"
    assert motion.robot.path == tmp_path / "models/tonypi/robot.yaml"
    original = load_motion(REPO / "motions" / "tonypi" / "dance.yaml")
    assert [k.targets_deg for k in motion.keyframes] == [k.targets_deg for k in original.keyframes]


@pytest.mark.parametrize("name", ["../evil.yaml", "/etc/passwd", "a/../../b"])
def test_a_staged_file_outside_the_folder_is_refused(tmp_path, name):
    part = StagedPart.of("s", "t", "m.yaml", "robot.yaml", {name: b"x"})
    with pytest.raises(ChoreoError, match="outside the staging folder"):
        unpack(part, tmp_path / "stage")
    assert not (tmp_path / "evil.yaml").exists()


def test_messages_round_trip_and_a_foreign_one_is_one_clear_error():
    ready = Readiness("tony", "tonypi", ("a", "b"), 1.5, 17.0, ("temperature",))
    assert decode(Readiness, encode(ready)) == ready
    finished = Finished("tony", PartOutcome.STOPPED, "", 5, 5, 1.0, 2.0, None, 0.1)
    assert json.loads(encode(finished))["outcome"] == "stopped"  # the wire keeps plain values
    assert decode(Finished, encode(finished)) == finished
    with pytest.raises(ChoreoError, match="a Readiness message could not be read"):
        decode(Readiness, b'{"who": 1}')


def test_an_outcome_this_version_does_not_know_is_one_clear_error():
    sent = json.loads(encode(Finished("tony", PartOutcome.COMPLETED, "", 5, 5, 1.0, 2.0, None, 0)))
    with pytest.raises(ChoreoError, match="a Finished message could not be read"):
        decode(Finished, json.dumps({**sent, "outcome": "vanished"}).encode())


def test_every_way_a_play_ends_is_a_way_a_part_ends():
    """The performer reports its player's Outcome as the PartOutcome of the same value."""
    assert [PartOutcome(o.value).name for o in Outcome] == [o.name for o in Outcome]


def test_without_zenoh_a_show_says_which_extra_to_install(monkeypatch):
    from choreo.show import network

    monkeypatch.setattr(network, "zenoh", None)
    with pytest.raises(ChoreoError, match=r"pip install 'choreo\[show\]'"):
        network.Network()


class SkewedPerformers:
    """Answers the conductor's clock round trips with clocks ``skews_s`` ahead of this one."""

    realm = zenoh_network.Realm()

    def __init__(self, skews_s: dict[str, float]):
        self.skews_s = skews_s

    def ask(self, key: str, payload: bytes = b"", timeout_s: float = 5.0) -> bytes | None:
        name = key.split("/")[-2]
        return encode(ClockReading(time.time() + self.skews_s[name]))


def test_the_conductor_refuses_clocks_past_the_bound_naming_each_performer():
    from choreo.show.conductor import Conductor

    show = load_show(SHOWS / "trio.yaml")  # the default bound: 2 ms
    skews = {"left": 0.0, "right": 0.050, "centre": -0.030}
    conductor = Conductor(SkewedPerformers(skews), show, print)  # type: ignore[arg-type]
    with pytest.raises(ChoreoError) as caught:
        conductor.measure_clocks()
    lines = str(caught.value).splitlines()
    assert lines[0] == "refusing to start the show:"
    assert [line.split(":")[0].strip() for line in lines[1:]] == ["right", "centre"]
    # each measured offset is the true one within the uncertainty it states (real time here:
    # the round trips take what they take), give or take the printed rounding
    for line, direction, true_ms in ((lines[1], "ahead", 50.0), (lines[2], "behind", 30.0)):
        found = re.search(rf"its clock is ([\d.]+) ms {direction} \(± ([\d.]+) ms\)", line)
        assert found, line
        measured_ms, uncertainty_ms = float(found[1]), float(found[2])
        assert abs(measured_ms - true_ms) <= uncertainty_ms + 0.01, line
    assert lines[1].endswith(
        "over the show's bound of 2 ms; synchronise the clocks (chrony/NTP, or PTP)"
    )


@pytest.mark.parametrize(
    "endpoint",
    [
        "tcp/192.168.1.5:7447",
        "udp/host.local:0",
        "tcp/[::1]:7447",
        "ws/10.0.0.2:80?iface=eth0",
        "unixsock-stream//tmp/choreo.sock",
    ],
)
def test_endpoints_of_the_zenoh_form_pass_the_check(endpoint):
    zenoh_network.check_endpoint("connect", endpoint)


@pytest.mark.parametrize(
    "endpoint",
    [
        "bogus",
        "tcp/192.168.1.5",
        "tcp/192.168.1.5:65536",
        "http/1.2.3.4:80",
        "tcp/my host:1",
        "unixsock-stream/",
        "",
    ],
)
def test_an_endpoint_of_another_form_is_an_option_error_naming_the_argument(endpoint):
    with pytest.raises(OptionError) as raised:
        zenoh_network.Network(listen=["tcp/127.0.0.1:0"], connect=[endpoint])
    assert raised.value.option == "connect"
    assert raised.value.problem.startswith(f"{endpoint!r} is not a Zenoh endpoint: write ")


def test_a_session_that_cannot_open_for_a_cause_choreo_cannot_tell_says_so_in_one_line(
    monkeypatch,
):
    monkeypatch.setattr(zenoh_network, "listen_problem", lambda endpoint, config: None)
    with pytest.raises(ChoreoError) as raised:
        zenoh_network.Network(listen=["tcp/192.0.2.1:7447"])  # TEST-NET-1: no interface here has it
    message = str(raised.value)
    assert message.startswith("cannot open the Zenoh session: ")  # then Zenoh's reason
    assert ".rs:" not in message and "\n" not in message


class AnsweringPerformers:
    """Takes every start at once and records what is published (the stops); says nothing else."""

    realm = zenoh_network.Realm()

    def __init__(self):
        self.published: list[str] = []

    def ask_all(self, requests: dict[str, bytes], timeout_s: float) -> dict[str, bytes | None]:
        return {key: encode(Answer(key.split("/")[-2])) for key in requests}

    def publish(self, key: str, payload: bytes) -> None:
        self.published.append(key)


class InterruptedThread(threading.Thread):
    """A Ctrl-C landing as the conductor sets up its clock watcher, just after GO (any other
    thread is made as ever)."""

    def __init__(self, *args, target=None, **kwargs):
        if getattr(target, "__name__", "") == "_measure_again":
            raise KeyboardInterrupt
        super().__init__(*args, target=target, **kwargs)


def test_a_ctrl_c_just_after_go_stops_every_part_and_still_gives_a_report(monkeypatch):
    from choreo.show import conductor as conducting

    monkeypatch.setattr(conducting, "STOP_REPLIES_S", 0.05)  # no performer here to answer
    monkeypatch.setattr(conducting.threading, "Thread", InterruptedThread)
    show = load_show(SHOWS / "trio.yaml")
    network = AnsweringPerformers()
    conductor = conducting.Conductor(network, show, lambda _line: None)  # type: ignore[arg-type]
    clocks = {p.performer: ClockOffset(0.0, 0.0005, 8) for p in show.parts}
    readiness = {p.performer: Readiness(p.performer, "arm6", (), 0.5, 1.0) for p in show.parts}
    report = conductor.start_and_follow(time.time() + 0.5, clocks, readiness, time.time())
    assert report.interrupted
    assert report.stop_reason == conducting.INTERRUPTED
    assert [key.rsplit("/", 1)[-1] for key in network.published] == ["stop"]


def test_a_thread_is_joined_through_a_ctrl_c_that_comes_while_it_ends():
    from choreo.show.conductor import joined

    ending = threading.Event()
    thread = threading.Thread(target=ending.wait, args=(5.0,))
    thread.start()
    threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
    threading.Timer(0.2, ending.set).start()
    joined(thread)
    assert not thread.is_alive()
