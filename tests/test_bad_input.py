"""Bad input a new user hit (issue 12): each gets one clear line and exit 1 or 2, nothing lost.

Each test names the exact line a user sees and the exit code.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from choreo.cli import main
from choreo.emulator import connection

REPO = Path(__file__).resolve().parents[1]
WAVE = REPO / "motions" / "arm6" / "wave.yaml"


def motion_file(tmp_path: Path, keyframes: str, *, name: str = "m.yaml", head: str = "") -> Path:
    path = tmp_path / name
    path.write_text(f"name: m\nrobot: arm6\n{head}keyframes:\n  - pose: home\n{keyframes}")
    return path


def error_line(capsys) -> str:
    """The one line on stderr (asserting there is exactly one)."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    return err.rstrip("\n")


# --- usage errors: one UsageError, exit 2 --------------------------------------------------------
def test_a_usage_error_raised_by_a_handler_is_one_line_and_exit_2(capsys):
    assert main(["play", str(WAVE), "--exit-pose", "nope"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --exit-pose 'nope' is not a pose of arm6; poses: home, rest, ready"
    )


def test_usage_error_is_part_of_the_one_error_tree():
    from choreo.errors import ChoreoError, UsageError

    assert issubclass(UsageError, ChoreoError)


def test_cli_modules_follow_one_pattern():
    names = sorted(p.stem for p in (REPO / "choreo" / "cli").glob("*.py"))
    commands = [n for n in names if n not in ("__init__", "arguments")]
    assert commands and all(n.endswith("_commands") for n in commands), commands


# --- tracebacks ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "timing, where, seconds",
    [("after: 20000", "5:5", "20000"), ("t: 1.0e+9", "5:5", "1e+09")],
)
def test_a_segment_longer_than_ruckig_can_plan_is_one_line(
    tmp_path, capsys, timing, where, seconds
):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    {timing}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:{where}: keyframe reached {seconds} s after leaving the one "
        "before; at most 300 s can be planned between two keyframes: hold the one before "
        "instead (hold: is not limited), or add keyframes in between"
    )


def test_a_tiny_speed_is_one_line(capsys):
    assert main(["plan", str(WAVE), "--speed", "0.0002"]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {WAVE}:8:5: keyframe reached 5000 s after leaving the one before "
        "(at speed 0.0002); at most 300 s can be planned between two keyframes: hold the one "
        "before instead (hold: is not limited), or add keyframes in between"
    )


def test_a_long_hold_is_not_limited(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 30}\n    after: 1\n    hold: 1000\n")
    assert main(["plan", str(path)]) == 0
    assert "1001.0" in capsys.readouterr().out


# --- messages ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "written, hint", [("1e12", "1.0e+12"), ("2.5E3", "2.5e+3"), ("7.e2", "7.0e+2")]
)
def test_a_yaml_1_1_exponent_read_as_text_gets_a_hint(tmp_path, capsys, written, hint):
    path = motion_file(tmp_path, f"  - pose: {{shoulder: 30}}\n    after: {written}\n")
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:6:12: after must be a number >= 0, got {written!r} "
        f"(YAML reads {written} as text: write {hint})"
    )


def test_every_unreachable_keyframe_is_reported_at_once(tmp_path, capsys):
    path = motion_file(
        tmp_path,
        "  - pose: {shoulder: 80}\n    t: 0.1\n"
        "  - pose: {shoulder: 0}\n    t: 0.3\n"
        "  - pose: {shoulder: 80}\n    after: 0.1\n",
    )
    assert main(["plan", str(path)]) == 1
    lines = capsys.readouterr().err.splitlines()
    assert [line.split(": keyframe cannot be reached")[0] for line in lines] == [
        f"choreo: error: {path}:5:5",
        f"{path}:7:5",
        f"{path}:9:5",
    ]
    # each fix, applied alone to the keyframes before, is enough: t >= 0.467 then t >= 0.933
    assert lines[0].endswith(
        "allow 0.467 s at the earliest; use t >= 0.467, a lower speed, or stretch"
    )
    assert lines[1].endswith(
        "allow 0.933 s at the earliest; use t >= 0.933, a lower speed, or stretch"
    )
    assert lines[2].endswith("use after >= 0.467, a lower speed, or stretch")


def test_servo_limits_name_the_options_the_user_typed(capsys):
    argv = ["servo", "limits", "--id", "1", "--min", "900", "--max", "100", "-y"]
    assert main([*argv, "--port", "sim://?clock=virtual"]) == 2
    assert error_line(capsys) == "choreo: error: --min 900 must be below --max 100"


def test_piping_into_head_exits_quietly():
    """`choreo plan ... | head -1`: no "[Errno 32] Broken pipe", exit 1 (output cut short).
    The reader is gone before the first write, as when head has had its lines."""
    for argv in (
        ["plan", str(WAVE)],
        ["play", str(WAVE), "--dry-run"],
        ["scan", "--ids", "1", "--port", "sim://?ids=1"],
    ):
        read_end, write_end = os.pipe()
        os.close(read_end)
        with os.fdopen(write_end, "wb") as closed_pipe:
            process = subprocess.run(
                [sys.executable, "-m", "choreo", *argv],
                cwd=REPO,
                stdout=closed_pipe,
                stderr=subprocess.PIPE,
                timeout=120,
            )
        assert (process.returncode, process.stderr.decode()) == (1, ""), argv


def usage_error_line(capsys, argv: list[str]) -> str:
    """argparse's refusal: exit 2, its usage, then one line saying what is wrong."""
    with pytest.raises(SystemExit) as exited:
        main(argv)
    assert exited.value.code == 2
    return capsys.readouterr().err.splitlines()[-1]


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["scan", "--timeout-ms", "1e308"],
            "choreo scan: error: argument --timeout-ms: expected a number > 0 and <= 5000 ms, "
            "got '1e308'",
        ),
        (
            ["play", str(WAVE), "--health-timeout-ms", "1e308"],
            "choreo play: error: argument --health-timeout-ms: expected a number > 0 and "
            "<= 5000 ms, got '1e308'",
        ),
        (
            ["emulate", "--pty", "x", "--turnaround-ms", "1e308"],
            "choreo emulate: error: argument --turnaround-ms: expected a number in 0..1000 ms, "
            "got '1e308'",
        ),
        (
            ["scan", "--retries", "10"],
            "choreo scan: error: argument --retries: invalid choice: 10 (choose from 0, 1, 2, 3, "
            "4, 5, 6, 7, 8, 9)",
        ),
    ],
)
def test_timer_options_are_bounded(capsys, argv, line):
    assert usage_error_line(capsys, argv) == line


def test_robot_file_bus_ranges_equal_the_command_line(tmp_path, capsys):
    robot = tmp_path / "arm6" / "robot.yaml"
    robot.parent.mkdir()
    for source in (REPO / "models" / "arm6").iterdir():
        (robot.parent / source.name).write_bytes(source.read_bytes())
    text = robot.read_text().replace(
        "defaults:", "bus: {retries: 10, timeout_ms: 5001}\ndefaults:", 1
    )
    robot.write_text(text)
    line = next(n for n, t in enumerate(text.splitlines(), 1) if t.startswith("bus:"))
    assert main(["validate", str(robot)]) == 1
    assert capsys.readouterr().out.splitlines() == [
        f"{robot}:{line}:16: bus: retries must be in 0..9, got 10",
        f"{robot}:{line}:32: bus: timeout_ms must be in (0, 5000], got 5001",
    ]


# --- lost work -----------------------------------------------------------------------------------
ARM6_D6A_ROWS = (
    ("Servo1", "Servo2", "Servo3"),
    ((1, 500, (500, 500, 700)), (2, 800, (625, 400, 580))),
)


def write_d6a(path: Path) -> Path:
    from choreo.interop.d6a import ActionRow, write_action_group

    columns, rows = ARM6_D6A_ROWS
    write_action_group(path, columns, [ActionRow(*row) for row in rows])
    return path


def writing_commands(tmp_path: Path) -> dict[str, list[str]]:
    """Each command that writes a file: its argv without -o."""
    source = tmp_path / "in.yaml"
    source.write_text(WAVE.read_text())
    d6a = write_d6a(tmp_path / "in.d6a")
    return {
        "mirror": ["mirror", str(source)],
        "export": ["export", "d6a", str(source)],
        "import": ["import", "d6a", str(d6a), "--robot", "arm6", "--ids", "2,4,6"],
    }


@pytest.mark.parametrize("command", ["mirror", "export", "import"])
def test_an_existing_output_is_kept_without_overwrite(tmp_path, capsys, command):
    argv = writing_commands(tmp_path)[command]
    out = tmp_path / "kept.out"
    out.write_bytes(b"good work\n")
    assert main([*argv, "-o", str(out)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {out} exists: choose another file, or allow replacing it (--overwrite)"
    )
    assert out.read_bytes() == b"good work\n"
    assert main([*argv, "-o", str(out), "--overwrite"]) == 0
    assert out.read_bytes() != b"good work\n"


def test_mirror_refuses_to_write_over_its_own_input(tmp_path, capsys):
    source = tmp_path / "a.yaml"
    source.write_text(WAVE.read_text())
    assert main(["mirror", str(source), "-o", str(source)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {source} exists: choose another file, or allow replacing it (--overwrite)"
    )
    assert source.read_text() == WAVE.read_text()


@pytest.mark.parametrize("command", ["mirror", "export", "import"])
def test_a_missing_output_folder_is_found_before_the_work(tmp_path, capsys, command):
    out = tmp_path / "no" / "such" / "out.file"
    assert main([*writing_commands(tmp_path)[command], "-o", str(out)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: cannot write {out}: the folder {out.parent} does not exist"
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["preview", str(WAVE), "-o", "{out}.mp4"],
        ["preview", str(WAVE), "--report", "{out}.json"],
        ["plan", str(WAVE), "--plot", "{out}.png"],
    ],
)
def test_preview_and_plot_outputs_in_a_missing_folder_fail_before_the_work(tmp_path, capsys, argv):
    out = tmp_path / "missing" / "x"
    argv = [a.format(out=out) for a in argv]
    assert main(argv) == 1
    captured = capsys.readouterr()
    written = Path(argv[-1])
    assert captured.err == (
        f"choreo: error: cannot write {written}: the folder {written.parent} does not exist\n"
    )
    assert captured.out == ""  # nothing simulated, planned or rendered first


def test_ctrl_c_while_rendering_keeps_the_old_video(tmp_path):
    keep = tmp_path / "keep.mp4"
    keep.write_bytes(b"a good video")
    process = subprocess.Popen(
        [sys.executable, "-m", "choreo", "preview", str(WAVE), "-o", str(keep)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,  # Ctrl-C reaches ffmpeg too: signal the whole group
    )
    try:
        deadline = time.monotonic() + 120
        while not list(tmp_path.glob(".keep.mp4.*")):  # rendering has begun
            assert process.poll() is None and time.monotonic() < deadline
            time.sleep(0.02)
        os.killpg(process.pid, signal.SIGINT)
        out, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 130
    assert err.decode().strip() == "choreo: interrupted"
    assert keep.read_bytes() == b"a good video"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.mp4"]


def test_preview_size_is_bounded(capsys):
    assert usage_error_line(capsys, ["preview", str(WAVE), "--size", "100000x100000"]) == (
        "choreo preview: error: argument --size: expected WIDTHxHEIGHT from 16x16 to "
        "8192x8192, e.g. 640x480, got '100000x100000'"
    )


FRAME_TOO_LARGE = """
from choreo.errors import PreviewError
from choreo.preview.gl import offscreen_backend
from choreo.preview.model import load_model
from choreo.preview.render import FrameRenderer
from choreo.robot.robot_file import load_robot

try:
    FrameRenderer(load_model(load_robot("arm6")), 1 << 20, 16, offscreen_backend())
except PreviewError as error:
    print(error)
"""


def test_a_frame_larger_than_the_gl_allows_is_a_preview_error():
    """In a process of its own: PyOpenGL fixes its platform once imported (see test_render)."""
    done = subprocess.run(
        [sys.executable, "-c", FRAME_TOO_LARGE],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert re.fullmatch(
        r"cannot render 1048576x16 frames with (egl|osmesa): .+; try a smaller width/height\n",
        done.stdout,
    ), done.stdout


# --- messages (preview) --------------------------------------------------------------------------
PREVIEW_MOTIONS = REPO / "tests" / "data" / "preview" / "motions"


def test_preview_check_says_where_as_validate_does(capsys):
    collide = PREVIEW_MOTIONS / "collide.yaml"
    assert main(["preview", str(collide), "--check"]) == 1
    out = capsys.readouterr().out.splitlines()
    finding = next(line for line in out if ": error: " in line)
    assert finding.startswith(f"{collide}:6:5: error: self-collision: base hits forearm")
    assert main(["validate", str(collide)]) == 1
    validated = capsys.readouterr().out.splitlines()[0]
    assert validated == finding.replace(": error: ", ": preview: ", 1)


def test_the_viewer_on_a_display_that_is_not_there_is_one_line(monkeypatch, capsys):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["preview", str(PREVIEW_MOTIONS / "fine.yaml"), "--viewer"]) == 1
    assert error_line(capsys) == (
        "choreo: error: the viewer cannot open a window on display ':99' (X11: Failed to open "
        "display :99); render to a file instead: choreo preview MOTION -o out.mp4"
    )


# --- wrong results -------------------------------------------------------------------------------
def test_the_shipped_dance_exports(tmp_path, capsys):
    """Its first keyframe is at t 0: row 1 is reached by the approach, like an untimed one."""
    from choreo.motion.motion_file import load_motion

    out = tmp_path / "dance.d6a"
    dance = REPO / "motions" / "arm6" / "dance.yaml"
    assert main(["export", "d6a", str(dance), "-o", str(out)]) == 0
    assert load_motion(dance).keyframes[0].t_s == 0.0  # on beat 1 of its song
    assert re.fullmatch(
        rf"wrote {re.escape(str(out))}: \d+ rows, [\d.]+ s, from {re.escape(str(dance))}\n",
        capsys.readouterr().out,
    )


def test_import_ids_keep_the_order_given(tmp_path):
    """Column k is the k-th ID as written: 6,4,2 puts Servo1's 700 on the gripper (ID 6)."""
    from choreo.motion.motion_file import load_motion

    out = tmp_path / "out.yaml"
    d6a = write_d6a(tmp_path / "in.d6a")
    argv = ["import", "d6a", str(d6a), "--robot", "arm6", "-o", str(out), "--ids", "6,4,2"]
    assert main(argv) == 0
    motion = load_motion(out)
    first = dict(zip(motion.robot.joint_names, motion.keyframes[0].targets_deg))
    # row 1: Servo1 500 -> gripper (zero 700, direction -1): +48°; Servo3 700 -> shoulder +48°
    assert (first["gripper"], first["wrist_pitch"], first["shoulder"]) == (48.0, 0.0, 48.0)


def test_an_open_ended_id_range_is_an_error(capsys):
    assert usage_error_line(capsys, ["scan", "--ids", "1-"]) == (
        "choreo scan: error: argument --ids: servo IDs must look like '1-6,9', got '1-'"
    )


def test_importing_a_folder_says_it_is_a_folder(tmp_path, capsys):
    argv = ["import", "d6a", str(tmp_path), "--robot", "arm6", "-o", str(tmp_path / "o.yaml")]
    assert main(argv) == 1
    assert error_line(capsys) == (
        f"choreo: error: {tmp_path}: is a folder, not an action group (.d6a) file"
    )


# --- unbounded -----------------------------------------------------------------------------------
def test_validate_reads_at_most_16_mib(capsys):
    assert main(["validate", "/dev/zero"]) == 1
    assert capsys.readouterr().out == (
        "/dev/zero:1:1: cannot read the file: it is larger than 16 MiB, the most a robot or "
        "motion file may be\n"
    )


def test_repeat_is_bounded_at_its_line(tmp_path, capsys):
    path = motion_file(
        tmp_path, "  - pose: {shoulder: 30}\n    after: 1\n", head="repeat: 100000000\n"
    )
    assert main(["plan", str(path)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {path}:3:9: repeat 100000000 x 2 keyframe(s) = 200000000 keyframes to "
        "play; at most 10000 are played in one motion: repeat at most 5000"
    )


def test_play_loop_is_bounded(capsys):
    assert main(["play", str(WAVE), "--loop", "100000000", "--dry-run"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --loop 100000000 x 9 keyframe(s) = 900000000 keyframes to play; at most "
        "10000 are played in one motion: --loop at most 1111"
    )


def test_the_planner_bounds_repeat_for_motions_made_in_code():
    import dataclasses

    from choreo.errors import PlanningError
    from choreo.motion.motion_file import load_motion
    from choreo.plan.planner import plan_motion

    motion = dataclasses.replace(load_motion(WAVE), repeat=10**8)
    with pytest.raises(PlanningError, match="at most 10000 are played in one motion"):
        plan_motion(motion)


# --- signals -------------------------------------------------------------------------------------
def choreo_process(*argv: str, stdin=None) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "choreo", *argv],
        cwd=REPO,
        stdin=stdin,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def packets(emulator, command):
    from choreo.bus.protocol import Command

    # list() copies at once: the bridge thread appends meanwhile
    return [p for p in list(emulator.log.packets) if p.packet.command == Command[command]]


def test_sighup_during_play_stops_the_servos_like_ctrl_c(arm_on_a_pty):
    from emulated import wait_for

    from choreo.bus.protocol import BROADCAST_ID

    emulator, link = arm_on_a_pty
    argv = ["play", "motions/arm6/dance.yaml", "--port", str(link), "--timeout-ms", "500"]
    process = choreo_process(*argv, "--health-timeout-ms", "100")
    try:

        def playing():
            assert process.poll() is None, process.communicate()
            return len(packets(emulator, "MOVE_START")) >= 5

        wait_for(playing, "the motion to be playing")
        process.send_signal(signal.SIGHUP)
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130, stderr
    stops = packets(emulator, "MOVE_STOP")
    assert stops and stops[0].packet.servo_id == BROADCAST_ID
    assert "Traceback" not in stderr


def test_sighup_during_record_loads_the_taught_joints_again(arm_on_a_pty, tmp_path):
    from emulated import wait_for

    emulator, link = arm_on_a_pty
    out = tmp_path / "taught.yaml"
    argv = ["record", str(out), "--robot", "arm6", "--port", str(link), "--joints", "elbow"]
    process = choreo_process(*argv, "--timeout-ms", "500", stdin=subprocess.PIPE)

    def torque_of_elbow() -> list[bytes]:
        return [
            p.packet.params
            for p in packets(emulator, "LOAD_OR_UNLOAD_WRITE")
            if p.packet.servo_id == 3
        ]

    try:

        def unloaded():
            assert process.poll() is None, process.communicate()
            return torque_of_elbow() == [b"\x00"]

        wait_for(unloaded, "the recorder to unload the elbow")
        process.send_signal(signal.SIGHUP)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    # as after Ctrl-C at the prompt: the recording ends (nothing captured here, so exit 1)
    assert process.returncode == 1, stderr
    assert stdout.splitlines()[-2:] == [
        f"nothing captured: {out} not written",
        "taught joints loaded again, holding where they are",
    ]
    assert torque_of_elbow() == [b"\x00", b"\x01"]  # loaded again, holding where it is


def test_emulate_with_an_empty_pty_path_says_so(capsys):
    assert usage_error_line(capsys, ["emulate", "--pty", ""]) == (
        "choreo emulate: error: argument --pty: the path is empty: give a path for the link, "
        "e.g. /tmp/ttyCHOREO"
    )


def test_a_port_lost_during_play_is_one_error_line_and_no_traceback(tmp_path):
    from emulated import home_specs, served_on_a_pty, wait_for

    from choreo.core.clock import RealClock
    from choreo.emulator import BusEmulator
    from choreo.robot.robot_file import load_robot

    emulator = BusEmulator(home_specs(load_robot("arm6")), clock=RealClock())
    with served_on_a_pty(emulator, tmp_path / "ttyARM") as link:
        argv = ["play", "motions/arm6/dance.yaml", "--port", str(link), "--timeout-ms", "500"]
        process = choreo_process(*argv, "--health-timeout-ms", "100")

        def playing():
            assert process.poll() is None, process.communicate()
            return len(packets(emulator, "MOVE_START")) >= 5

        try:
            wait_for(playing, "the motion to be playing")
        except BaseException:
            process.kill()
            raise
    # the pty is gone, as when the USB adapter is pulled
    try:
        _, stderr = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 1
    assert "Traceback" not in stderr
    last = stderr.strip().splitlines()[-1]
    assert last.startswith(f"choreo: error: {link}: the port was lost (")
    assert last.endswith("): check the USB cable")


# --- port-open errors say the real cause ---------------------------------------------------------
LIST_PORTS = "list ports with `choreo ports`; `sim://` is the built-in emulator"


def scan_error(capsys, port: str) -> str:
    assert main(["scan", "--port", port, "--ids", "1"]) == 1
    return error_line(capsys)


def test_a_missing_port_is_not_called_busy(capsys):
    assert scan_error(capsys, "/dev/ttyNOPE") == (
        f"choreo: error: cannot open /dev/ttyNOPE: no such port; {LIST_PORTS}"
    )


def test_a_file_that_is_not_a_port_says_so(tmp_path, capsys):
    plain = tmp_path / "notes.txt"
    plain.write_text("not a tty")
    assert scan_error(capsys, str(plain)) == (
        f"choreo: error: cannot open {plain}: it is not a serial port; {LIST_PORTS}"
    )


def test_only_a_busy_port_asks_about_another_program(capsys):
    import pty

    import serial

    master, slave = pty.openpty()
    name = os.ttyname(slave)
    try:
        with serial.Serial(name, exclusive=True):  # another program holds it
            assert scan_error(capsys, name) == (
                f"choreo: error: cannot open {name}: the port is busy. Is another program using it?"
            )
    finally:
        os.close(master)
        os.close(slave)


def test_after_a_stop_the_path_error_covers_only_the_part_played():
    from choreo.bus.servo_bus import ServoBus
    from choreo.core.clock import VirtualClock
    from choreo.emulator import BusEmulator
    from choreo.motion.motion_file import load_motion
    from choreo.plan.performance import prepare
    from choreo.plan.pipeline import compile_motion
    from choreo.play.path_errors import measured_path_errors
    from choreo.play.player import Outcome, Player, PlayOptions, preflight

    def play(stop_at_tick: int | None):
        motion = load_motion(REPO / "motions" / "arm6" / "dance.yaml")
        robot, clock = motion.robot, VirtualClock()
        from emulated import home_specs

        emulator = BusEmulator(home_specs(robot), clock=clock)
        bus = ServoBus(connection(emulator))
        start, limits = preflight(bus, robot)
        performance = prepare(compile_motion(motion), start)

        def ctrl_c(progress):
            if progress.tick == stop_at_tick:
                raise KeyboardInterrupt

        player = Player(bus, robot, clock, limits, PlayOptions(), ctrl_c)
        report = player.play(performance.ticks, start)
        return report, measured_path_errors(emulator.log.moves, robot, performance, report, start)

    completed, whole = play(None)
    stopped, part = play(20)
    assert completed.outcome is Outcome.COMPLETED and stopped.outcome is Outcome.INTERRUPTED
    # what was played follows the plan as closely as a whole run does (not tens of degrees off)
    assert max(part) <= max(whole) + 0.5, (part, whole)


def test_play_on_a_virtual_clock_sim_url_completes(capsys):
    """The README's clock=virtual: the player keeps the emulator's time, so nothing lags."""
    assert main(["play", str(WAVE), "--port", "sim://?ids=1-6&clock=virtual"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("completed\n") and "away from where it should be" not in out


def test_play_stretch_says_how_much(tmp_path, capsys):
    path = motion_file(tmp_path, "  - pose: {shoulder: 80}\n    t: 0.1\n")
    argv = ["play", str(path), "--stretch", "--port", "sim://?ids=1-6&clock=virtual"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert f"{path}:5:5: stretched: reached 0.367 s later than written\n" in err


def test_plan_tolerance_has_a_maximum(capsys):
    assert usage_error_line(capsys, ["plan", str(WAVE), "--tolerance", "1000"]) == (
        "choreo plan: error: argument --tolerance: expected a number > 0 and <= 5°, got '1000'"
    )
    assert main(["plan", str(WAVE), "--tolerance", "5"]) == 0


def test_a_planning_error_inside_an_include_says_through_which(tmp_path, capsys):
    (tmp_path / "part.yaml").write_text(
        "robot: arm6\nkeyframes:\n  - pose: {shoulder: 0}\n"
        "  - pose: {shoulder: 80}\n    after: 0.1\n"
    )
    main_file = motion_file(tmp_path, "  - include: part.yaml\n    after: 1.0\n", name="main.yaml")
    outer = motion_file(tmp_path, "  - include: main.yaml\n", name="outer.yaml")
    assert main(["plan", str(outer)]) == 1
    assert error_line(capsys) == (
        f"choreo: error: {tmp_path / 'part.yaml'}:4:5: keyframe (included at {main_file}:5:14, "
        f"included at {outer}:5:14) cannot be reached at 1.100 s: the velocity, acceleration "
        "and jerk limits of shoulder allow 1.467 s at the earliest; use after >= 0.467, a lower "
        "speed, or stretch"
    )


def test_every_robot_file_problem_is_reported_at_once(tmp_path, capsys):
    """The bus, a joint (two problems), a pose and the model file: one run, every line."""
    robot = tmp_path / "arm6" / "robot.yaml"
    robot.parent.mkdir()
    for source in (REPO / "models" / "arm6").iterdir():
        (robot.parent / source.name).write_bytes(source.read_bytes())
    text = (
        robot.read_text()
        .replace("mjcf: arm6.xml", "mjcf: nothere.xml")
        .replace("defaults:", "bus: {retries: 100}\ndefaults:", 1)
        .replace(
            "base_yaw:    {id: 1, zero: 500, direction: 1, min: -120, max: 120}",
            "base_yaw:    {id: 1, zero: 500, direction: 2, min: 120, max: -120}",
        )
        .replace("rest:  {base_yaw: 0,", "rest:  {base_yw: 0,")
    )
    robot.write_text(text)
    assert main(["validate", str(robot)]) == 1
    assert [line.split(": ", 1)[1] for line in capsys.readouterr().out.splitlines()] == [
        f"the MuJoCo model {robot.parent / 'nothere.xml'} does not exist",
        "bus: retries must be in 0..9, got 100",
        "joint 'base_yaw': direction must be 1 or -1, got 2",
        "joint 'base_yaw': min 120° must be below max -120°",  # not hidden by the direction
        "pose 'rest' does not give base_yaw; every pose names every joint",
        "pose 'rest': unknown joint 'base_yw' (did you mean 'base_yaw'?); the robot's joints are "
        "base_yaw, shoulder, elbow, wrist_pitch, wrist_roll, gripper",
    ]


# --- missing -------------------------------------------------------------------------------------
def test_robots_lists_every_robot_with_its_joints_and_poses(capsys):
    assert main(["robots"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == [
        "arm6: 6 joints, poses home, rest, ready (models/arm6/robot.yaml)",
        "hexapod18: 18 joints, poses home, lying, crouch (models/hexapod18/robot.yaml)",
        "tonypi: 18 joints, poses home, straight, squat (models/tonypi/robot.yaml)",
    ]


def test_robots_name_shows_limits_and_pose_angles(capsys):
    from choreo.robot.robot_file import load_robot

    assert main(["robots", "arm6"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == "arm6 (models/arm6/robot.yaml)"
    rows = {line.split()[0]: line.replace("│", " ").split() for line in out[3:]}
    robot = load_robot("arm6")
    for joint in robot.joints:
        home, rest, ready = (robot.poses[p][joint.name] for p in ("home", "rest", "ready"))
        assert rows[joint.name] == [
            joint.name,
            str(joint.servo_id),
            "LX-16A",
            f"{joint.limits.min_deg:g}",
            f"{joint.limits.max_deg:g}",
            "300",
            "3000",
            "30000",
            f"{home:g}",
            f"{rest:g}",
            f"{ready:g}",
        ]
    assert out[-1] == "mirror: base_yaw <-> base_yaw (sign -1), wrist_roll <-> wrist_roll (sign -1)"


def test_robots_with_an_unknown_name_is_one_line(capsys):
    assert main(["robots", "armx"]) == 1
    assert error_line(capsys).startswith(
        "choreo: error: unknown robot 'armx' (did you mean 'arm6'?)"
    )


@pytest.mark.parametrize("terminal", [True, False])
def test_scan_shows_progress_on_stderr_only_on_a_terminal(terminal):
    env = {k: v for k, v in os.environ.items() if k not in ("FORCE_COLOR", "TTY_COMPATIBLE")}
    if terminal:
        env["FORCE_COLOR"] = "1"  # rich treats stderr as a terminal
    process = subprocess.run(
        [sys.executable, "-m", "choreo", "scan", "--port", "sim://?ids=1-3", "--ids", "0-9"],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert process.returncode == 0, process.stderr
    assert "3 servo(s) on sim://?ids=1-3" in process.stdout and "scanning" not in process.stdout
    assert ("scanning ID" in process.stderr and "/10" in process.stderr) is terminal
    if not terminal:
        assert process.stderr == ""


def png_size(path: Path) -> tuple[int, int]:
    import struct

    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_plan_plot_draws_a_time_window(tmp_path, capsys):
    from choreo.plan.plot import plot_size_px

    gait = REPO / "motions" / "hexapod18" / "tripod_gait.yaml"
    whole, window = tmp_path / "whole.png", tmp_path / "window.png"
    assert main(["plan", str(gait), "--plot", str(whole)]) == 0
    assert (
        main(["plan", str(gait), "--plot", str(window), "--plot-from", "2", "--plot-to", "4"]) == 0
    )
    assert png_size(window) == png_size(whole) == plot_size_px(18)
    assert window.read_bytes() != whole.read_bytes()
    capsys.readouterr()


@pytest.mark.parametrize(
    "extra, line",
    [
        (
            ["--plot-from", "20"],
            "choreo: error: --plot-from 20 is past the end of the motion: it lasts 4.900 s",
        ),
        (
            ["--plot-to", "9"],
            "choreo: error: --plot-to 9 is past the end of the motion: it lasts 4.900 s",
        ),
        (
            ["--plot-from", "3", "--plot-to", "2"],
            "choreo: error: --plot-from 3 must be before --plot-to 2",
        ),
    ],
)
def test_a_plot_window_outside_the_motion_is_refused_not_clamped(tmp_path, capsys, extra, line):
    plot = tmp_path / "p.png"
    assert main(["plan", str(WAVE), "--plot", str(plot), *extra]) == 2
    assert capsys.readouterr().err == line + "\n"
    assert not plot.exists()


def test_a_plot_window_needs_a_plot(capsys):
    assert main(["plan", str(WAVE), "--plot-from", "1"]) == 2
    assert error_line(capsys) == (
        "choreo: error: --plot-from and --plot-to choose what --plot draws: add --plot FILE.png"
    )


def test_a_closed_stdout_does_not_lose_the_play_report(tmp_path):
    report = tmp_path / "play.json"
    read_end, write_end = os.pipe()
    os.close(read_end)
    argv = ["play", str(WAVE), "--port", "sim://?ids=1-6&clock=virtual", "--report", str(report)]
    with os.fdopen(write_end, "wb") as closed_pipe:
        done = subprocess.run(
            [sys.executable, "-m", "choreo", *argv],
            cwd=REPO,
            stdout=closed_pipe,
            stderr=subprocess.PIPE,
            timeout=120,
        )
    assert done.returncode == 1 and b"Traceback" not in done.stderr
    assert json.loads(report.read_text())["outcome"] == "completed"
