"""Beats and downbeats from Beat This! (CPJKU, ISMIR 2024: MIT code and weights), the optional
neural tracker (``choreo[beats-neural]``, with torch), chosen with ``tracker="beat-this"``.

Its weights are fetched by the package on first use (torch's hub cache) and not shipped with
it: where they cannot be fetched the tracker says so in one line. The default path (librosa)
needs no torch.
"""

from __future__ import annotations

import numpy as np

from choreo.errors import ChoreoError
from choreo.music.decode import Audio

CHECKPOINT = "final0"  # the model the paper reports, trained on all its data but one fold


def neural_beats(audio: Audio) -> tuple[np.ndarray, np.ndarray]:
    """(beat times, downbeat times) of ``audio`` by Beat This!, without its DBN."""
    try:
        from beat_this.inference import Audio2Beats
    except ImportError:
        raise ChoreoError(
            "the beat-this tracker needs Beat This! and torch: install the extra, "
            "pip install 'choreo[beats-neural]'"
        ) from None
    try:
        tracker = Audio2Beats(checkpoint_path=CHECKPOINT, device="cpu", dbn=False)
    except Exception as error:  # noqa: BLE001 - torch's hub raises whatever the network did
        raise ChoreoError(
            f"Beat This! could not load its weights ({CHECKPOINT}): {error}; "
            "use the default tracker, or fetch the weights where there is a network"
        ) from None
    beats, downbeats = tracker(np.asarray(audio.mono, dtype=np.float32), audio.rate_hz)
    return np.asarray(beats, dtype=float), np.asarray(downbeats, dtype=float)
