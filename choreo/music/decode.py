"""Songs as samples: decode wav, flac, ogg and mp3 with the ffmpeg that ``imageio-ffmpeg`` ships
(a dependency already, for the preview video), and encode them back (the shipped songs).

Decoding needs no extra: ffmpeg reads every format a motion's ``music:`` may name.
"""

from __future__ import annotations

import functools
import os
import re
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from choreo.core.arguments import Range, check_number, check_path
from choreo.core.file_kind import not_a_file
from choreo.errors import ChoreoError

SONG_SUFFIXES = (".wav", ".flac", ".ogg", ".mp3")
ANALYSIS_RATE_HZ = 22050  # enough for beats; what the beat tracker expects
DECODE_CHUNK_BYTES = 1 << 20
RATE_HZ = Range(at_least=8000, at_most=192_000, whole=True, unit=" Hz")  # telephone to studio
CHANNELS = Range(at_least=1, at_most=8, whole=True)  # mono to 7.1


@dataclass(frozen=True)
class Audio:
    samples: np.ndarray  # float32, shape (frames,) for mono or (frames, channels)
    rate_hz: int

    @property
    def duration_s(self) -> float:
        return len(self.samples) / self.rate_hz

    @property
    def mono(self) -> np.ndarray:
        return self.samples if self.samples.ndim == 1 else self.samples.mean(axis=1)


def ffmpeg_exe() -> str:
    import imageio_ffmpeg

    return imageio_ffmpeg.get_ffmpeg_exe()


def check_song_path(path: Path) -> str | None:
    """Why ``path`` can't be a song (one phrase), or None if it can."""
    if path.suffix.lower() not in SONG_SUFFIXES:
        return f"{path} is not a song file: use {', '.join(SONG_SUFFIXES)}"
    kind = not_a_file(path)
    if kind is not None:
        return f"{path} is {kind}, not a song file"
    if not path.is_file():
        return f"{path} does not exist"
    return None


def decode_song(
    path: str | os.PathLike[str], rate_hz: int = ANALYSIS_RATE_HZ, channels: int = 1
) -> Audio:
    """The song at ``path`` (wav, flac, ogg, mp3) as float samples at ``rate_hz``, mixed down
    to ``channels``; ChoreoError if ffmpeg can't read it."""
    path = check_path("path", path, "a song file's path")
    check_number("rate_hz", rate_hz, RATE_HZ)
    check_number("channels", channels, CHANNELS)
    problem = check_song_path(path)
    if problem:
        raise ChoreoError(problem)
    stat = path.stat()
    return _decode(str(path.resolve()), stat.st_mtime_ns, stat.st_size, rate_hz, channels)


@functools.lru_cache(maxsize=8)
def _decode(path: str, _mtime_ns: int, _size: int, rate_hz: int, channels: int) -> Audio:
    command = [ffmpeg_exe(), "-v", "error", "-nostdin", "-i", path, "-vn"]
    command += ["-f", "f32le", "-ac", str(channels), "-ar", str(rate_hz), "-"]
    # Read a chunk at a time into one growing buffer: collecting the whole output and joining it
    # (subprocess.run) holds the song twice over.
    data = bytearray()
    with tempfile.TemporaryFile() as errors:
        with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors) as ffmpeg:
            assert ffmpeg.stdout is not None
            while chunk := ffmpeg.stdout.read(DECODE_CHUNK_BYTES):
                data += chunk
        if ffmpeg.returncode != 0:
            errors.seek(0)
            raise ChoreoError(f"cannot decode {path}: {ffmpeg_reason(errors.read())}")
    samples = np.frombuffer(data, dtype="<f4", count=len(data) // 4)
    if channels > 1:
        samples = samples.reshape(-1, channels)
    samples.flags.writeable = False  # cached: shared by every caller
    return Audio(samples, rate_hz)


def encode(audio: Audio, path: str | Path) -> Path:
    """Write ``audio`` to ``path``; the format follows the suffix (ogg is Vorbis)."""
    path = Path(path)
    if path.suffix.lower() not in SONG_SUFFIXES:
        raise ValueError(f"song suffix must be one of {SONG_SUFFIXES}, got {path.name}")
    channels = 1 if audio.samples.ndim == 1 else audio.samples.shape[1]
    codec = {".ogg": ["-c:a", "libvorbis", "-q:a", "3"], ".mp3": ["-q:a", "4"]}.get(
        path.suffix.lower(), []
    )
    command = [ffmpeg_exe(), "-v", "error", "-nostdin", "-y", "-f", "f32le"]
    command += ["-ac", str(channels), "-ar", str(audio.rate_hz), "-i", "-", *codec, str(path)]
    data = np.ascontiguousarray(audio.samples, dtype="<f4").tobytes()
    result = subprocess.run(command, input=data, capture_output=True, check=False)
    if result.returncode != 0:
        raise ChoreoError(f"cannot write {path}: {ffmpeg_reason(result.stderr)}")
    return path


def add_song_to_video(video: Path, song: Path, song_at_start_s: float, duration_s: float) -> None:
    """Put ``song`` into the mp4 ``video`` as its audio track, in place: the video's t=0 hears
    the song at ``song_at_start_s`` (negative: the song begins that much into the video, as when
    the video shows the approach before the motion); at most ``duration_s`` of audio (the video's
    length), and the video keeps every frame if the song ends first."""
    muxed = video.with_name(f".{video.stem}.song{video.suffix}")
    skip_s, delay_ms = max(0.0, song_at_start_s), round(max(0.0, -song_at_start_s) * 1000)
    command = [ffmpeg_exe(), "-v", "error", "-nostdin", "-y", "-i", str(video)]
    command += ["-ss", f"{skip_s:.6f}", "-i", str(song)]
    # AAC's fast coder: ffmpeg's default (twoloop) spends 0.6 s of CPU on an 18 s song, 2.5x
    # the fast one's, for a difference no preview's listener hears at 128 kbit/s
    command += ["-map", "0:v", "-map", "1:a", "-c:v", "copy"]
    command += ["-c:a", "aac", "-aac_coder", "fast", "-b:a", "128k"]
    if delay_ms:
        command += ["-af", f"adelay={delay_ms}:all=1"]
    command += ["-t", f"{duration_s:.6f}", str(muxed)]
    try:
        result = subprocess.run(command, capture_output=True, check=False)
    except BaseException:  # Ctrl-C or SIGTERM while ffmpeg works: leave nothing behind
        muxed.unlink(missing_ok=True)
        raise
    if result.returncode != 0:
        muxed.unlink(missing_ok=True)
        raise ChoreoError(f"cannot add {song.name} to {video}: {ffmpeg_reason(result.stderr)}")
    muxed.replace(video)


_FFMPEG_PREFIX = re.compile(r"^\[[^\]]*@ 0x[0-9a-fA-F]+\] ")  # "[out#0/f32le @ 0x55...] "
# How ffmpeg says it could not open an input: "Error opening input: ..." in newer releases,
# "<path>: Invalid data found when processing input" in older ones, after the demuxer's own
# detail ("[ogg @ 0x...] ogg page, unsupported version").
_UNREADABLE_INPUT = ("Error opening input", "Invalid data found when processing input")


def ffmpeg_reason(stderr: bytes) -> str:
    """What ffmpeg's error output says, in one phrase: its first line is the cause (the lines
    after it are what failed because of it), without ffmpeg's ``[stream @ 0x...]`` tags."""
    lines = [
        _FFMPEG_PREFIX.sub("", line).strip()
        for line in stderr.decode(errors="replace").splitlines()
    ]
    cause = next((line for line in lines if line), "")
    if not cause:
        return "ffmpeg failed without saying why"
    if "does not contain any stream" in cause:
        return "it has no audio"
    if any(marker in line for line in lines for marker in _UNREADABLE_INPUT):
        return f"it is not a sound file ffmpeg can read ({cause})"
    return cause
