"""The motion's song, played by the page in step with the timeline.

viser has no audio of its own: the song goes into the page as an <audio> element (the file's
bytes in a data URL: nothing else is served) with a small script that follows the page's own
controls: the time box, the Play/Pause button and the speed. The browser decodes the file.
"""

from __future__ import annotations

import base64
import json

from choreo.motion.music_block import Music

MAX_SONG_BYTES = 30_000_000  # a data URL this size is what the page can still take in
MIME = {".ogg": "audio/ogg", ".mp3": "audio/mpeg", ".wav": "audio/wav", ".flac": "audio/flac"}
DRIFT_S = 0.15  # the song is moved back in step when it drifts this far from the timeline

# Runs once when the element appears (an image that fails to load: inline <script> does not run
# from HTML put into a page). Every 100 ms: seek the song to the timeline's time (plus the
# song's start) when it drifts, play it while the page plays, pause it otherwise.
_FOLLOW = """
(function () {
  const song = document.getElementById("choreo-song");
  const offset = %(start)s, drift = %(drift)s;
  function control(label) {
    for (const p of document.querySelectorAll("p")) {
      if (p.textContent.trim() === label) {
        const row = p.closest("[class*=Flex-root]");
        if (row) return row.querySelector("input");
      }
    }
    return null;
  }
  setInterval(function () {
    const time = control("t (s)"), speed = control("speed");
    if (!time) return;
    const t = parseFloat(time.value), rate = speed ? parseFloat(speed.value) : 1;
    const playing = [...document.querySelectorAll("button")].some(
      (b) => b.textContent.trim() === "Pause");
    const want = offset + t;
    if (!isFinite(want) || want < 0) { song.pause(); return; }
    if (isFinite(rate) && rate > 0) song.playbackRate = rate;
    if (Math.abs(song.currentTime - want) > drift) song.currentTime = want;
    if (playing && song.paused) song.play().catch(() => {});
    if (!playing && !song.paused) song.pause();
  }, 100);
})();
"""


def song_html(music: Music) -> str:
    """The page's player of ``music.song``; or a note when the file can't go into the page."""
    path = music.song
    mime = MIME.get(path.suffix.lower())
    size = path.stat().st_size
    if mime is None or size > MAX_SONG_BYTES:
        why = "too large" if mime else f"a {path.suffix} file"
        return f"<p>{path.name}: {why}, not played in the page</p>"
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    script = _FOLLOW % {"start": json.dumps(music.start_s), "drift": json.dumps(DRIFT_S)}
    handler = script.replace("&", "&amp;").replace('"', "&quot;")
    return (
        f'<audio id="choreo-song" controls preload="auto" style="width: 100%" '
        f'src="data:{mime};base64,{data}"></audio>'
        f'<img src="data:," alt="" style="display: none" onerror="{handler}">'
    )
