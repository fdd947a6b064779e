"""Music figures on this machine.

1. Beat detection for a 3-minute song (the shipped groove, synthesized 84 bars long at 112 BPM,
   encoded as ogg): librosa's first import (numba compiles once per machine, then caches),
   decoding with the bundled ffmpeg, detection, and how close the detected beats are to the kicks.
2. Real-time emulated play with the song: ``runs`` plays of the first bars of arm6/dance (its
   song cued on the first START by a recording sink with 80 ms output latency, i.e. called that
   much before), on the emulated bus with the real clock. Offset = when the sink's first sample
   sounds minus when the first broadcast START's last byte reaches the emulated servos (the wire
   log's clock): p50 and max over the runs.

No audio device exists here: the sink records instead of sounding (what a real PortAudio stream
adds - its DAC timing - is the device's, not choreo's).

Run: python benchmarks/bench_music.py [--runs 20]
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from choreo.bus.protocol import Command  # noqa: E402
from choreo.bus.servo_bus import ServoBus  # noqa: E402
from choreo.core.clock import RealClock  # noqa: E402
from choreo.emulator import BusEmulator, ServoSpec, connection  # noqa: E402
from choreo.emulator.trace import WireTrace  # noqa: E402
from choreo.motion.motion_file import load_motion  # noqa: E402
from choreo.music.decode import Audio, decode_song, encode  # noqa: E402
from choreo.plan.performance import prepare  # noqa: E402
from choreo.plan.pipeline import compile_motion  # noqa: E402
from choreo.play.play_options import PlayOptions  # noqa: E402
from choreo.play.player import Player  # noqa: E402
from choreo.play.preflight import preflight  # noqa: E402
from choreo.play.soundtrack import RecordingSink, SongCue, play_with_song  # noqa: E402

LATENCY_S = 0.08


def groove_module():
    spec = importlib.util.spec_from_file_location("groove", REPO / "motions/songs/groove.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def beat_detection() -> None:
    groove = groove_module()
    bars = int(np.ceil(180 / (4 * 60 / groove.BPM)))
    samples = groove.synthesize(bars=bars)
    with tempfile.TemporaryDirectory() as folder:
        song = encode(Audio(samples, groove.RATE_HZ), Path(folder) / "long.ogg")
        began = time.perf_counter()
        from choreo.music.beats import detect_beats, require_librosa

        require_librosa()
        import librosa.beat  # noqa: F401  (what detect_beats loads)

        imported = time.perf_counter()
        audio = decode_song(song)
        decoded = time.perf_counter()
        analysis = detect_beats(audio)
        detected = time.perf_counter()
        size_kb = song.stat().st_size // 1024
    kicks = groove.LEAD_IN_S + np.arange(bars * 4) * 60 / groove.BPM
    beats = np.asarray(analysis.beats_s)
    errors_ms = np.array([np.min(np.abs(beats - k)) for k in kicks]) * 1000
    print(
        f"beat detection, {audio.duration_s:.0f} s song ({size_kb} KB ogg, {bars * 4} kicks at "
        f"{groove.BPM} BPM):"
    )
    print(f"  librosa import {imported - began:.2f} s (first run on a machine: numba compiles)")
    print(f"  decode {decoded - imported:.2f} s, detect {detected - decoded:.2f} s")
    print(
        f"  {len(beats)} beats at {analysis.bpm:.2f} BPM; distance kick -> nearest beat "
        f"p50 {np.median(errors_ms):.1f} ms, max {errors_ms.max():.1f} ms"
    )


def song_offsets(runs: int) -> None:
    motion = load_motion(REPO / "motions/arm6/dance.yaml")
    motion = dataclasses.replace(motion, keyframes=motion.keyframes[:5])  # the first two bars
    compiled = compile_motion(motion)
    robot = motion.robot
    offsets_ms = []
    for _ in range(runs):
        clock = RealClock()
        emulator = BusEmulator(
            [
                ServoSpec(j.servo_id, j.servo_model, position_units=j.to_units(a))
                for j, a in zip(robot.joints, robot.pose_vector("home"))
            ],
            clock=clock,
        )
        bus = ServoBus(connection(emulator))
        start, limits = preflight(bus, robot)
        performance = prepare(compiled, start)
        sink = RecordingSink(clock, latency_s=LATENCY_S)
        options = PlayOptions(lead_s=LATENCY_S + 0.05)  # as choreo play sets it for a song
        player = Player(bus, robot, clock, limits, options)
        cue = SongCue.of(motion.music, performance)
        play_with_song(player, performance, start, sink, Audio(np.zeros(1, np.float32), 1), cue)
        first_start = next(
            p.time_s
            for p in WireTrace.of(emulator).packets
            if p.packet.command is Command.MOVE_START
        )
        offsets_ms.append((sink.sounds_at_s - first_start) * 1000)
    offsets = np.array(offsets_ms)
    print(
        f"real-time emulated play, {runs} runs of {compiled.trajectory.duration_s:.2f} s "
        f"(arm6 dance, first bars), the song on a recording sink with "
        f"{LATENCY_S * 1000:.0f} ms latency:"
    )
    print(
        f"  song start - first START on the wire: p50 {np.median(offsets):+.3f} ms, "
        f"max |offset| {np.max(np.abs(offsets)):.3f} ms (goal within 2 ms)"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args()
    beat_detection()
    song_offsets(args.runs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
