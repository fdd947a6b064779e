"""choreo.core.atomic: a file is replaced whole or not at all, and no temporary file is left
behind."""

from __future__ import annotations

import os
import signal
import stat
from pathlib import Path

import pytest
from cli_helpers import WAVE, error_line, write_d6a

from choreo.cli import main
from choreo.core.atomic import atomic_output, check_writable, fsync_directory, write_text_atomically
from choreo.errors import ChoreoError


def test_write_text_replaces_the_file_whole_and_leaves_nothing_else(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text("old\n")
    write_text_atomically(path, "keyframes: []  # 30°\n")
    assert path.read_bytes() == "keyframes: []  # 30°\n".encode()
    assert [p.name for p in tmp_path.iterdir()] == ["wave.yaml"]


def test_a_failed_write_keeps_the_old_file_and_removes_the_temporary(tmp_path):
    path = tmp_path / "wave.yaml"
    path.write_text("old\n")
    with pytest.raises(RuntimeError, match="disk full"):
        with atomic_output(path) as temporary:
            temporary.write_text("half a fi")
            raise RuntimeError("disk full")
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["wave.yaml"]


def test_the_temporary_is_beside_the_target_so_the_rename_is_atomic(tmp_path):
    path = tmp_path / "wave.yaml"
    with atomic_output(path) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".wave.yaml.")
        temporary.write_bytes(b"\x00\x01")
    assert path.read_bytes() == b"\x00\x01"


@pytest.mark.parametrize("write", [check_writable, lambda path: write_text_atomically(path, "x")])
def test_ctrl_c_just_as_the_temporary_is_made_leaves_nothing_behind(tmp_path, monkeypatch, write):
    """The signal comes the moment the file exists: it is held until the file is named and
    cleaned up as any interrupted write is (here, not a timing: a test sending SIGTERM on
    seeing the temporary found this)."""
    make = os.open

    def made_then_interrupted(path, *args, **kwargs):
        made = make(path, *args, **kwargs)
        if ".tmp" in str(path):
            os.kill(os.getpid(), signal.SIGINT)
        return made

    monkeypatch.setattr(os, "open", made_then_interrupted)
    with pytest.raises(KeyboardInterrupt):
        write(tmp_path / "out.yaml")
    assert list(tmp_path.iterdir()) == []


def test_fsync_directory_accepts_a_folder(tmp_path):
    fsync_directory(tmp_path)  # raises OSError if the folder cannot be opened
    with pytest.raises(FileNotFoundError):
        fsync_directory(tmp_path / "missing")


def test_a_missing_folder_is_a_clear_error_naming_it(tmp_path):
    with pytest.raises(
        ChoreoError,
        match=r"cannot write .*nowhere/x.yaml: the folder .*nowhere "
        r"does not exist",
    ):
        write_text_atomically(tmp_path / "nowhere" / "x.yaml", "a: 1\n")


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_a_written_file_respects_the_umask(tmp_path, umask, mode):
    path = tmp_path / "wave.yaml"
    previous = os.umask(umask)
    try:
        write_text_atomically(path, "keyframes: []\n")
    finally:
        os.umask(previous)
    assert stat.S_IMODE(path.stat().st_mode) == mode


def test_the_temporary_keeps_the_suffix_writers_choose_a_format_by(tmp_path):
    with atomic_output(tmp_path / "keep.mp4") as temporary:
        assert temporary.suffix == ".mp4"
        temporary.write_bytes(b"video")


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


def test_a_symbolic_link_is_written_through_and_stays_a_link(tmp_path):
    target = tmp_path / "real.yaml"
    target.write_text("old\n")
    link = tmp_path / "link.yaml"
    link.symlink_to("real.yaml")
    write_text_atomically(link, "new\n")
    assert link.is_symlink() and os.readlink(link) == "real.yaml"
    assert target.read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.yaml", "real.yaml"]


def test_a_fifo_is_refused_and_left_a_fifo(tmp_path):
    fifo = tmp_path / "out.yaml"
    os.mkfifo(fifo)
    with pytest.raises(ChoreoError, match=r"cannot write .*out.yaml: it is a FIFO \(named pipe\)"):
        write_text_atomically(fifo, "a: 1\n")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["out.yaml"]


def test_a_device_is_refused_before_any_work(tmp_path):
    # only checked, never written: as root, a rename over /dev/null would replace the device
    with pytest.raises(ChoreoError, match="cannot write /dev/null: it is a device, not a file"):
        check_writable(Path("/dev/null"))
    link = tmp_path / "report.json"
    link.symlink_to("/dev/null")  # followed: the device behind a link is refused too
    with pytest.raises(ChoreoError, match="report.json: it is a device, not a file"):
        check_writable(link)


def test_a_long_name_is_written_with_a_shortened_temporary(tmp_path):
    path = tmp_path / ("a" * 245 + ".json")  # 250 bytes: with .XXXXXXXX.tmp.json it was 269
    write_text_atomically(path, "{}\n")
    assert path.read_text() == "{}\n"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_a_name_longer_than_the_file_system_takes_is_refused_with_its_length(tmp_path):
    path = tmp_path / ("a" * 252 + ".json")
    with pytest.raises(
        ChoreoError,
        match=r"the name is 257 bytes long, the most a file name can "
        r"be here is 255",
    ):
        check_writable(path)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="Linux's /proc")
def test_a_folder_that_takes_no_new_files_is_refused_by_the_check(tmp_path):
    # root passes os.access on /proc, yet no file can be made there
    with pytest.raises(ChoreoError, match="cannot write /proc/r.json: the folder /proc"):
        check_writable(Path("/proc/r.json"))
