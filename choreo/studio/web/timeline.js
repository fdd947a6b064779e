// choreo studio's timeline: lanes of keyframe diamonds, the song's waveform with its bars and
// beats, the findings, and the curves (plan solid, simulation dashed) under one playhead.
//
// The studio (Python) owns the file and the plan: it sends the state as Server-Sent Events
// ("state", "play", "time", "status") and hears the page's requests as posted JSON. The page
// owns only what is on screen: the view (zoom, pan, folded limbs), the selection, the copy
// buffer, and while playing its own clock, which the song follows.
"use strict";
(function () {
  const LABEL_W = 150, RULER_H = 22, WAVE_H = 40, FIND_H = 16, KEYS_H = 18, ROW_H = 16;
  const MIN_SPAN_S = 5, MAX_SPAN_S = 600, FRAME_S = 1 / 30, SNAP_S = 0.05, NO_BEAT_STEP_S = 0.5;
  const DIAMOND = 5, DRAG_PX = 3, DIAMOND_GAP_PX = 2, CURVE_PX = 3;
  const SEVERITY = { error: "#d62728", warning: "#f0a020" };
  const COLOURS = ["#2878ff", "#e0561b", "#2ca02c", "#9467bd", "#d62728", "#17becf", "#8c564b"];
  const SEEK_S = 0.25, NUDGE = 0.05; // the song: seek when this far off, else nudge its rate

  const canvas = document.getElementById("canvas");
  // CPU-backed canvases: without a GPU, Chromium's GPU canvas is emulated and far slower
  const screen = canvas.getContext("2d", { willReadFrequently: true });
  // everything but the playhead is drawn on a layer, again only when it changes: while playing
  // a frame is the layer copied and the playhead drawn over it
  const layer = document.createElement("canvas");
  const layerCtx = layer.getContext("2d", { willReadFrequently: true });
  let ctx = layerCtx; // where the draw* functions draw
  let layerKey = "";
  let stateCount = 0;
  const tip = document.getElementById("tip");
  const song = document.getElementById("song");
  const statusLine = document.getElementById("status");
  const clock = document.getElementById("clock");
  const playButton = document.getElementById("play");
  const snapBox = document.getElementById("snap");

  let state = null;
  const view = { t0: 0, span: 10, scrollY: 0, folded: new Set(), picked: new Set(), fitted: false };
  const selection = new Set();
  let copied = [];
  let play = { playing: false, t: 0, speed: 1, perf: performance.now() };
  let timeS = 0;
  let drag = null; // what the pointer is doing: scrub, box, keys
  let dirty = true; // to be redrawn on the next frame (changed() asks for it)
  let framePending = false;
  let songUrl = null;
  const drift = [];
  const partMs = {}; // how long each part of the last redraw took

  // --- talking to the studio -------------------------------------------------------------
  // Requests go one after another, in order (a scrub then K adds at the scrubbed time); a
  // scrub still waiting to go is replaced by a newer one.
  const outbox = [];
  let sending = false;
  function send(request) {
    const last = outbox[outbox.length - 1];
    if (request.op === "scrub" && last && last.op === "scrub") outbox[outbox.length - 1] = request;
    else outbox.push(request);
    if (!sending) sendNext();
  }

  function sendNext() {
    const request = outbox.shift();
    if (!request) {
      sending = false;
      return;
    }
    sending = true;
    fetch("command", {
      method: "POST",
      headers: { "Content-Type": "application/json" },
      body: JSON.stringify(request),
    })
      .catch(() => showStatus({ text: "the studio does not answer", kind: "failed" }))
      .finally(sendNext);
  }

  const events = new EventSource("events");
  events.addEventListener("state", (e) => setState(JSON.parse(e.data)));
  events.addEventListener("play", (e) => setPlay(JSON.parse(e.data)));
  events.addEventListener("time", (e) => {
    if (!play.playing && !(drag && drag.kind === "scrub")) setTime(JSON.parse(e.data).t);
  });
  events.addEventListener("status", (e) => showStatus(JSON.parse(e.data)));

  function showStatus(status) {
    statusLine.textContent = status.text;
    statusLine.className = status.kind || "";
  }

  function setState(next) {
    const first = state === null;
    state = next;
    stateCount += 1;
    for (const index of [...selection]) if (index >= state.keyframes.length) selection.delete(index);
    if (first || !view.fitted) fit();
    if (view.picked.size === 0 && state.joints.length) view.picked.add(0);
    for (const name of [...view.picked]) if (name >= state.joints.length) view.picked.delete(name);
    const music = state.music;
    const url = music ? music.song_url : null;
    if (url !== songUrl) {
      songUrl = url;
      song.pause();
      if (song.src) URL.revokeObjectURL(song.src);
      song.removeAttribute("src");
      // the whole file as a blob: the song can then be sought anywhere at once
      if (url) {
        fetch(url)
          .then((answer) => (answer.ok ? answer.blob() : null))
          .then((blob) => {
            if (!blob || songUrl !== url) return;
            song.src = URL.createObjectURL(blob);
            followSong(play.playing);
          });
      }
    }
    changed();
  }

  function setPlay(next) {
    play = { playing: next.playing, t: next.t, speed: next.speed, perf: performance.now() };
    timeS = next.t;
    playButton.textContent = next.playing ? "Pause" : "Play";
    if (!next.playing) {
      song.pause();
      followSong(false);
    }
    changed();
  }

  function setTime(t) {
    timeS = t;
    if (!play.playing) followSong(false);
    keepInView(t);
    changed();
  }

  // --- time and pixels ----------------------------------------------------------------------
  // the canvas's CSS width, read once per redraw (and per pointer event): reading clientWidth
  // for every point drawn asks the browser for its layout thousands of times a redraw
  let cssW = 0;
  const canvasW = () => cssW || (cssW = canvas.clientWidth);
  const plotW = () => canvasW() - LABEL_W;
  const xOf = (t) => LABEL_W + ((t - view.t0) / view.span) * plotW();
  const tOf = (x) => view.t0 + ((x - LABEL_W) / plotW()) * view.span;

  function fit() {
    if (!state) return;
    const length = Math.max(state.end_s - state.start_s, 0.1);
    view.span = clamp(length * 1.04, MIN_SPAN_S, MAX_SPAN_S);
    view.t0 = state.start_s - (view.span - length) / 2;
    if (view.span === MIN_SPAN_S) view.t0 = state.start_s - 0.2;
    view.fitted = true;
    changed();
  }

  function zoom(factor, atT) {
    const span = clamp(view.span * factor, MIN_SPAN_S, MAX_SPAN_S);
    const at = atT === undefined ? timeS : atT;
    view.t0 = at - ((at - view.t0) * span) / view.span;
    view.span = span;
    view.fitted = false;
    pan(0);
  }

  function pan(dt) {
    if (!state) return;
    view.t0 = clamp(view.t0 + dt, state.start_s - view.span * 0.9, state.end_s - view.span * 0.1);
    changed();
  }

  function keepInView(t) {
    if (t < view.t0 || t > view.t0 + view.span) pan(t - (view.t0 + view.span / 2));
  }

  const clamp = (v, lo, hi) => Math.min(Math.max(v, lo), hi);

  function beats() {
    return state && state.music ? state.music.beats : [];
  }

  // Snap a time to the music's beats (to bars when beats are too close to tell apart) or to
  // SNAP_S without music.
  function snapped(t, free) {
    if (free || !snapBox.checked) return Math.round(t * 100) / 100;
    const grid = beats();
    if (!grid.length || t < grid[0]) return Math.round(t / SNAP_S) * SNAP_S;
    const pxPerBeat = grid.length > 1 ? ((grid[1] - grid[0]) / view.span) * plotW() : 99;
    const step = pxPerBeat < 6 ? state.music.beats_per_bar : 1;
    let best = grid[0];
    for (let i = barStart() % step; i < grid.length; i += step) {
      if (Math.abs(grid[i] - t) < Math.abs(best - t)) best = grid[i];
    }
    return best;
  }

  function barStart() {
    const music = state.music;
    const first = (music.bar_one_beat - 1) % music.beats_per_bar;
    return (first + music.beats_per_bar) % music.beats_per_bar;
  }

  function beatStep(direction) {
    const grid = beats();
    if (!grid.length) return timeS + direction * NO_BEAT_STEP_S;
    if (direction > 0) {
      for (const b of grid) if (b > timeS + 1e-3) return b;
      return state.end_s;
    }
    for (let i = grid.length - 1; i >= 0; i--) if (grid[i] < timeS - 1e-3) return grid[i];
    return state.start_s;
  }

  // --- rows ---------------------------------------------------------------------------------
  // The fixed rows at the top, the lanes (scrolled), the curves at the bottom.
  function layout() {
    const height = canvas.clientHeight;
    const wave = state && state.music ? WAVE_H : 0;
    const lanesTop = RULER_H + wave + FIND_H + KEYS_H;
    const curvesH = Math.max(90, Math.round(height * 0.38));
    const rows = [];
    if (state) {
      for (const limb of state.limbs) {
        rows.push({ kind: "limb", limb });
        if (!view.folded.has(limb.name)) for (const j of limb.joints) rows.push({ kind: "joint", j });
      }
    }
    const lanesH = Math.max(0, height - lanesTop - curvesH);
    view.scrollY = clamp(view.scrollY, 0, Math.max(0, rows.length * ROW_H - lanesH));
    return {
      height, wave, waveTop: RULER_H, findTop: RULER_H + wave, keysTop: RULER_H + wave + FIND_H,
      lanesTop, lanesH, rows, curvesTop: lanesTop + lanesH, curvesH,
    };
  }

  // --- drawing --------------------------------------------------------------------------------
  function resize() {
    const ratio = window.devicePixelRatio || 1;
    cssW = canvas.clientWidth;
    const w = Math.round(cssW * ratio), h = Math.round(canvas.clientHeight * ratio);
    for (const c of [canvas, layer]) {
      if (c.width !== w || c.height !== h) {
        c.width = w;
        c.height = h;
      }
    }
    for (const c of [screen, layerCtx]) c.setTransform(ratio, 0, 0, ratio, 0, 0);
    return ratio;
  }

  // what the layer shows: it is drawn again when this changes
  function layerState() {
    return [
      stateCount, view.t0, view.span, view.scrollY, [...view.folded].join(","),
      [...view.picked].join(","), [...selection].join(","), drag ? JSON.stringify(drag) : "",
      canvas.clientWidth, canvas.clientHeight, snapBox.checked,
    ].join("|");
  }

  // Draw the timeline: the layer if it changed (or ``full``), then the playhead over it.
  // Returns the milliseconds it took.
  function redraw(full) {
    const began = performance.now();
    const ratio = resize();
    const L = layout();
    const key = layerState();
    if (full || key !== layerKey) {
      layerKey = key;
      drawLayer(L);
    }
    screen.setTransform(1, 0, 0, 1, 0, 0);
    screen.clearRect(0, 0, canvas.width, canvas.height);
    screen.drawImage(layer, 0, 0);
    screen.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx = screen;
    if (state) drawPlayhead(L);
    ctx = layerCtx;
    clock.textContent = state ? clockText() : "";
    screen.getImageData(0, 0, 1, 1); // the drawing done, not only asked for
    return performance.now() - began;
  }

  function drawLayer(L) {
    const W = canvasW();
    ctx = layerCtx;
    ctx.clearRect(0, 0, W, L.height);
    ctx.font = "11px system-ui, sans-serif";
    ctx.textBaseline = "middle";
    if (!state) {
      ctx.fillStyle = "#666";
      ctx.fillText("loading…", 8, 12);
      return;
    }
    const parts = [drawGrid, drawRuler, drawWave, drawFindings, drawLanes, drawCurves, drawLabels, drawBox];
    for (const part of parts) {
      const t = performance.now();
      if (part !== drawWave || L.wave) part(L);
      partMs[part.name] = performance.now() - t;
    }
  }

  function visibleRange(times) {
    // indices of the sorted ``times`` inside the view (a few pixels of margin)
    const margin = (view.span / Math.max(plotW(), 1)) * 8;
    return [lowerBound(times, view.t0 - margin), lowerBound(times, view.t0 + view.span + margin)];
  }

  function lowerBound(sorted, value) {
    let lo = 0, hi = sorted.length;
    while (lo < hi) {
      const mid = (lo + hi) >> 1;
      if (sorted[mid] < value) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  }

  function drawGrid(L) {
    const W = canvasW();
    ctx.save();
    ctx.beginPath();
    ctx.rect(LABEL_W, 0, W - LABEL_W, L.height);
    ctx.clip();
    const grid = beats();
    if (grid.length) {
      const [a, b] = visibleRange(grid);
      const per = state.music.beats_per_bar, first = barStart();
      const pxPerBeat = grid.length > 1 ? ((grid[1] - grid[0]) / view.span) * plotW() : 99;
      for (let i = a; i < b; i++) {
        const bar = (i - first) % per === 0;
        if (!bar && pxPerBeat < 6) continue;
        ctx.fillStyle = bar ? "#c9c9d6" : "#ececf2";
        ctx.fillRect(Math.round(xOf(grid[i])), RULER_H, 1, L.height - RULER_H);
      }
    }
    // the approach (before 0) and past the end, shaded
    ctx.fillStyle = "rgba(0,0,0,0.05)";
    if (state.start_s < 0) ctx.fillRect(xOf(state.start_s), RULER_H, xOf(0) - xOf(state.start_s), L.height);
    ctx.fillStyle = "rgba(0,0,0,0.08)";
    ctx.fillRect(xOf(state.end_s), RULER_H, W, L.height);
    ctx.restore();
  }

  function tickStep() {
    const perPx = view.span / Math.max(plotW(), 1);
    for (const step of [0.1, 0.2, 0.5, 1, 2, 5, 10, 15, 30, 60, 120]) if (step / perPx >= 60) return step;
    return 300;
  }

  function drawRuler(L) {
    const W = canvasW();
    ctx.fillStyle = "#f1f1f4";
    ctx.fillRect(0, 0, W, RULER_H);
    ctx.fillStyle = "#d0d0d6";
    ctx.fillRect(0, RULER_H - 1, W, 1);
    const step = tickStep();
    ctx.fillStyle = "#555";
    ctx.textAlign = "left";
    for (let t = Math.ceil(view.t0 / step) * step; t <= view.t0 + view.span; t += step) {
      const x = Math.round(xOf(t));
      if (x < LABEL_W) continue;
      ctx.fillRect(x, RULER_H - 7, 1, 6);
      ctx.fillText(formatTime(t, step), x + 3, 8);
    }
    const grid = beats();
    if (grid.length) {
      // bar numbers, as many as fit
      const per = state.music.beats_per_bar, first = barStart();
      const [a, b] = visibleRange(grid);
      let lastX = -1e9;
      ctx.fillStyle = "#7a56c2";
      for (let i = a; i < b; i++) {
        if ((i - first) % per !== 0) continue;
        const x = xOf(grid[i]);
        if (x < LABEL_W || x - lastX < 28) continue;
        lastX = x;
        ctx.fillText(String(Math.floor((i - first) / per) + 1), x + 2, 17);
      }
    }
    ctx.fillStyle = "#444";
    ctx.fillText(grid.length ? "time s · bar" : "time s", 6, 11);
  }

  function formatTime(t, step) {
    if (Math.abs(t) < 1e-9) t = 0;
    if (step >= 60 && Math.abs(t) >= 60) {
      const m = Math.floor(t / 60), s = Math.round(t - m * 60);
      return `${m}:${String(s).padStart(2, "0")}`;
    }
    return step < 1 ? t.toFixed(1) : String(Math.round(t));
  }

  function drawWave(L) {
    const music = state.music, peaks = music.peaks;
    const W = canvasW();
    const mid = L.waveTop + L.wave / 2, half = L.wave / 2 - 3;
    ctx.fillStyle = "#f6f3fc";
    ctx.fillRect(LABEL_W, L.waveTop, W - LABEL_W, L.wave);
    ctx.fillStyle = "#8d6fd1";
    if (peaks.length) {
      for (let x = LABEL_W; x < W; x++) {
        // the song's time under this pixel column, and the loudest peak in it
        const a = (tOf(x) + music.offset_s) * music.peaks_per_s;
        const b = (tOf(x + 1) + music.offset_s) * music.peaks_per_s;
        let peak = 0;
        for (let i = Math.max(0, Math.floor(a)); i < Math.min(peaks.length, Math.ceil(b)); i++) {
          if (peaks[i] > peak) peak = peaks[i];
        }
        if (peak > 0) {
          const h = Math.max(1, (peak / 100) * half);
          ctx.fillRect(x, mid - h, 1, 2 * h);
        }
      }
    }
  }

  function drawFindings(L) {
    const W = canvasW();
    ctx.fillStyle = "#fcfcfd";
    ctx.fillRect(LABEL_W, L.findTop, W - LABEL_W, FIND_H);
    for (const finding of state.findings) {
      const x = xOf(finding.t);
      if (x < LABEL_W - 6 || x > W + 6) continue;
      const x2 = Math.max(x + 3, xOf(finding.t + (finding.duration_s || 0)));
      ctx.fillStyle = SEVERITY[finding.severity] || "#1f77b4";
      ctx.globalAlpha = 0.35;
      ctx.fillRect(x, L.findTop + 3, x2 - x, FIND_H - 6);
      ctx.globalAlpha = 1;
      triangle(x, L.findTop + 2, FIND_H - 4);
    }
  }

  function triangle(x, top, size) {
    ctx.beginPath();
    ctx.moveTo(x, top + size);
    ctx.lineTo(x - size / 2, top);
    ctx.lineTo(x + size / 2, top);
    ctx.closePath();
    ctx.fill();
  }

  function keyTimes() {
    if (!state._times) state._times = state.keyframes.map((k) => k.t);
    return state._times;
  }

  function draggedTime(index) {
    const k = state.keyframes[index];
    return drag && drag.kind === "keys" && drag.moved && selection.has(index) ? k.t + drag.dt : k.t;
  }

  // keyframe indices by joint, kept with the state (the lanes ask for them every redraw)
  function keysOfJoint(j) {
    if (!state._byJoint) {
      state._byJoint = new Map();
      state.keyframes.forEach((k, i) => {
        for (const joint of k.joints) {
          if (!state._byJoint.has(joint)) state._byJoint.set(joint, new Set());
          state._byJoint.get(joint).add(i);
        }
      });
    }
    return state._byJoint.get(j) || new Set();
  }

  function drawDiamonds(y, indices, xs) {
    // indices: keyframes in time order drawn on the row centred at y; one path per colour,
    // and one diamond per pixel column (a thousand keyframes in a few hundred pixels)
    const paths = { "#ff8a00": [], "#3b4a6b": [], "#9aa0ad": [] };
    for (const i of indices) {
      const colour = selection.has(i) ? "#ff8a00" : state.keyframes[i].editable ? "#3b4a6b" : "#9aa0ad";
      paths[colour].push(xs ? xs.get(i) : Math.round(xOf(draggedTime(i))));
    }
    for (const colour in paths) {
      const xs = paths[colour];
      if (!xs.length) continue;
      ctx.fillStyle = colour;
      ctx.beginPath();
      let last = -Infinity;
      for (const x of xs) {
        if (x - last < DIAMOND_GAP_PX) continue;
        last = x;
        ctx.moveTo(x, y - DIAMOND);
        ctx.lineTo(x + DIAMOND, y);
        ctx.lineTo(x, y + DIAMOND);
        ctx.lineTo(x - DIAMOND, y);
        ctx.closePath();
      }
      ctx.fill();
    }
  }

  function visibleKeyframes() {
    const [a, b] = visibleRange(keyTimes());
    const shown = [];
    for (let i = a; i < b; i++) shown.push(i);
    if (drag && drag.kind === "keys" && drag.moved) for (const i of selection) if (i < a || i >= b) shown.push(i);
    return shown;
  }

  function drawLanes(L) {
    const W = canvasW();
    const shown = visibleKeyframes();
    const xs = new Map(shown.map((i) => [i, Math.round(xOf(draggedTime(i)))])); // once, not per lane
    ctx.fillStyle = "#f4f5f8";
    ctx.fillRect(LABEL_W, L.keysTop, W - LABEL_W, KEYS_H);
    ctx.save();
    ctx.beginPath();
    ctx.rect(LABEL_W - DIAMOND - 1, 0, W, L.lanesTop);
    ctx.clip();
    drawDiamonds(L.keysTop + KEYS_H / 2, shown, xs);
    ctx.restore();
    ctx.save();
    ctx.beginPath();
    ctx.rect(0, L.lanesTop, W, L.lanesH);
    ctx.clip();
    L.rows.forEach((row, r) => {
      const top = L.lanesTop + r * ROW_H - view.scrollY;
      if (top + ROW_H < L.lanesTop || top > L.lanesTop + L.lanesH) return;
      if (row.kind === "limb") {
        ctx.fillStyle = "#e9eaf0";
        ctx.fillRect(0, top, W, ROW_H);
        if (view.folded.has(row.limb.name)) {
          const keys = row.limb.joints.map(keysOfJoint);
          drawDiamonds(top + ROW_H / 2, shown.filter((i) => keys.some((k) => k.has(i))), xs);
        }
      } else {
        if (r % 2) {
          ctx.fillStyle = "rgba(0,0,0,0.025)";
          ctx.fillRect(LABEL_W, top, W, ROW_H);
        }
        const keys = keysOfJoint(row.j);
        drawDiamonds(top + ROW_H / 2, shown.filter((i) => keys.has(i)), xs);
      }
    });
    ctx.restore();
  }

  function drawCurves(L) {
    const W = canvasW(), top = L.curvesTop + 6, h = L.curvesH - 12;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, L.curvesTop, W, L.curvesH);
    ctx.fillStyle = "#d0d0d6";
    ctx.fillRect(0, L.curvesTop, W, 1);
    const curves = state.curves, picked = [...view.picked];
    if (!picked.length || !curves.t.length) {
      ctx.fillStyle = "#777";
      ctx.fillText("click a joint's name to see its curves", 8, L.curvesTop + 14);
      return;
    }
    let [lo, hi] = valueRange(picked);
    if (!(hi > lo)) { lo -= 5; hi += 5; }
    const pad = (hi - lo) * 0.08;
    lo -= pad; hi += pad;
    const yOf = (v) => top + h - ((v - lo) / (hi - lo)) * h;
    ctx.fillStyle = "#666";
    ctx.textAlign = "right";
    for (const v of [hi - pad, (lo + hi) / 2, lo + pad]) {
      ctx.fillText(`${Math.round(v) || 0}°`, LABEL_W - 6, yOf(v));
      ctx.fillStyle = "#eee";
      ctx.fillRect(LABEL_W, Math.round(yOf(v)), W - LABEL_W, 1);
      ctx.fillStyle = "#666";
    }
    ctx.textAlign = "left";
    ctx.save();
    ctx.beginPath();
    ctx.rect(LABEL_W, L.curvesTop, W - LABEL_W, L.curvesH);
    ctx.clip();
    const [a, b] = visibleRange(curves.t);
    const from = Math.max(0, a - 1), to = Math.min(curves.t.length, b + 1);
    for (const j of picked) {
      ctx.strokeStyle = COLOURS[j % COLOURS.length];
      curve(curves.t, curves.plan[j], from, to, yOf, 2, []);
      if (curves.sim) curve(curves.t, curves.sim[j], from, to, yOf, 1.2, [6, 3]);
    }
    ctx.restore();
  }

  // the lowest and highest value of the picked joints' curves, kept with the state (it is
  // the same for every redraw until the state or the picked joints change)
  function valueRange(picked) {
    const key = picked.join(",");
    if (!state._ranges) state._ranges = new Map();
    if (!state._ranges.has(key)) {
      let lo = Infinity, hi = -Infinity;
      const curves = state.curves;
      for (const j of picked) {
        for (const series of curves.sim ? [curves.plan[j], curves.sim[j]] : [curves.plan[j]]) {
          for (const v of series) if (v !== null) { if (v < lo) lo = v; if (v > hi) hi = v; }
        }
      }
      state._ranges.set(key, [lo, hi]);
    }
    return state._ranges.get(key);
  }

  // A curve as one filled path of thin rectangles, one per CURVE_PX column, each spanning the
  // column's lowest to highest value (and the last value before it, so the curve never breaks).
  // Not a stroked polyline: with 2,000 samples the software rasterizer spent ~40 ms a redraw on
  // the zig-zag's joins; rectangles fill in a fraction of that and draw the same envelope.
  // ``dash`` [on, off] in pixels leaves the off columns out (the simulation's dashed look).
  function curve(times, values, from, to, yOf, width, dash) {
    ctx.fillStyle = ctx.strokeStyle;
    ctx.beginPath();
    const period = dash.length ? dash[0] + dash[1] : 0;
    let column = NaN, lo = 0, hi = 0, last = NaN;
    const flush = () => {
      if (Number.isNaN(column)) return;
      const x = column * CURVE_PX;
      if (!period || x % period < dash[0]) {
        ctx.rect(x, hi - width / 2, CURVE_PX, lo - hi + width);
      }
    };
    const x0 = LABEL_W - (view.t0 / view.span) * plotW(), perS = plotW() / view.span;
    for (let i = from; i < to; i++) {
      const v = values[i];
      if (v === null) { flush(); column = NaN; last = NaN; continue; }
      const x = x0 + times[i] * perS, y = yOf(v);
      const here = Math.floor(x / CURVE_PX);
      if (here !== column) {
        flush();
        column = here;
        lo = hi = Number.isNaN(last) ? y : last;  // joined to the column before
      }
      if (y > lo) lo = y;
      if (y < hi) hi = y;
      last = y;
    }
    flush();
    ctx.fill();
  }

  function drawLabels(L) {
    ctx.fillStyle = "#f1f1f4";
    ctx.fillRect(0, RULER_H, LABEL_W, L.lanesTop - RULER_H);
    ctx.fillStyle = "#444";
    ctx.textAlign = "left";
    if (L.wave) ctx.fillText(`song ${state.music.name}`, 6, L.waveTop + L.wave / 2);
    ctx.fillText(`findings (${state.findings.length})`, 6, L.findTop + FIND_H / 2);
    ctx.fillText(`keyframes (${state.keyframes.length})`, 6, L.keysTop + KEYS_H / 2);
    ctx.save();
    ctx.beginPath();
    ctx.rect(0, L.lanesTop, LABEL_W, L.lanesH);
    ctx.clip();
    L.rows.forEach((row, r) => {
      const top = L.lanesTop + r * ROW_H - view.scrollY;
      if (top + ROW_H < L.lanesTop || top > L.lanesTop + L.lanesH) return;
      const y = top + ROW_H / 2;
      if (row.kind === "limb") {
        ctx.fillStyle = "#e9eaf0";
        ctx.fillRect(0, top, LABEL_W, ROW_H);
        ctx.fillStyle = "#333";
        ctx.fillText(`${view.folded.has(row.limb.name) ? "▸" : "▾"} ${row.limb.name}`, 4, y);
      } else {
        const picked = view.picked.has(row.j);
        ctx.fillStyle = picked ? COLOURS[row.j % COLOURS.length] : "#ccc";
        ctx.fillRect(14, y - 4, 8, 8);
        ctx.fillStyle = "#333";
        ctx.fillText(state.joints[row.j].name, 26, y);
      }
    });
    ctx.restore();
    ctx.fillStyle = "#d0d0d6";
    ctx.fillRect(LABEL_W - 1, RULER_H, 1, L.height);
  }

  function drawBox(L) {
    if (!drag || drag.kind !== "box") return;
    ctx.fillStyle = "rgba(40,120,255,0.12)";
    ctx.strokeStyle = "rgba(40,120,255,0.8)";
    ctx.lineWidth = 1;
    const x = Math.min(drag.x0, drag.x), y = Math.min(drag.y0, drag.y);
    ctx.fillRect(x, y, Math.abs(drag.x - drag.x0), Math.abs(drag.y - drag.y0));
    ctx.strokeRect(x + 0.5, y + 0.5, Math.abs(drag.x - drag.x0), Math.abs(drag.y - drag.y0));
  }

  function drawPlayhead(L) {
    const x = Math.round(xOf(timeS));
    if (x < LABEL_W || x > canvas.clientWidth) return;
    ctx.fillStyle = "#e3262f";
    ctx.fillRect(x, 0, 1.5, L.height);
    ctx.beginPath();
    ctx.moveTo(x - 5, 0);
    ctx.lineTo(x + 6, 0);
    ctx.lineTo(x + 0.5, 7);
    ctx.closePath();
    ctx.fill();
  }

  function clockText() {
    let text = `${timeS.toFixed(2)} s`;
    const grid = beats();
    if (grid.length && timeS >= grid[0]) {
      const i = Math.max(0, lowerBound(grid, timeS + 1e-6) - 1);
      const per = state.music.beats_per_bar, first = barStart();
      const within = i + 1 < grid.length ? (timeS - grid[i]) / (grid[i + 1] - grid[i]) : 0;
      const bar = Math.floor((i - first) / per) + 1, beat = ((i - first) % per + per) % per + 1;
      text += ` · bar ${bar} beat ${(beat + within).toFixed(1)}`;
    }
    if (selection.size) text += ` · ${selection.size} selected`;
    return text;
  }

  // --- what is under the pointer -------------------------------------------------------------
  function hit(x, y) {
    const L = layout();
    if (y < RULER_H) return { kind: "ruler" };
    if (L.wave && y < L.waveTop + L.wave) return { kind: "ruler" };
    if (y >= L.curvesTop) return { kind: "curves" };
    if (y < L.findTop + FIND_H) {
      let best = null, bestD = 7;
      state.findings.forEach((f, i) => {
        const d = Math.abs(xOf(f.t) - x);
        if (d < bestD) { best = i; bestD = d; }
      });
      return best === null ? { kind: "ruler" } : { kind: "finding", index: best };
    }
    let lane = null; // which keyframes the row under the pointer shows
    if (y < L.lanesTop) lane = () => true;
    else {
      const row = L.rows[Math.floor((y - L.lanesTop + view.scrollY) / ROW_H)];
      if (!row) return { kind: "empty" };
      if (x < LABEL_W) return row.kind === "limb" ? { kind: "limb", name: row.limb.name } : { kind: "label", j: row.j };
      if (row.kind === "joint") lane = (k) => k.joints.includes(row.j);
      else if (view.folded.has(row.limb.name)) lane = (k) => k.joints.some((j) => row.limb.joints.includes(j));
      else return { kind: "empty" };
    }
    if (x < LABEL_W - DIAMOND) return { kind: "empty" };
    const index = nearestKeyframe(x, lane);
    return index === null ? { kind: "empty" } : { kind: "key", index };
  }

  function nearestKeyframe(x, lane) {
    let best = null, bestD = DIAMOND + 2;
    for (const i of visibleKeyframes()) {
      if (!lane(state.keyframes[i])) continue;
      const d = Math.abs(xOf(state.keyframes[i].t) - x);
      if (d < bestD) { best = i; bestD = d; }
    }
    return best;
  }

  function keyframesInBox(x0, y0, x1, y1) {
    const L = layout();
    const [xa, xb] = [Math.min(x0, x1), Math.max(x0, x1)];
    const [ya, yb] = [Math.min(y0, y1), Math.max(y0, y1)];
    const found = new Set();
    const rowsIn = (top, h, lane) => {
      const y = top + h / 2;
      if (y < ya || y > yb) return;
      for (const i of visibleKeyframes()) {
        const x = xOf(state.keyframes[i].t);
        if (x >= xa && x <= xb && lane(state.keyframes[i])) found.add(i);
      }
    };
    rowsIn(L.keysTop, KEYS_H, () => true);
    L.rows.forEach((row, r) => {
      const top = L.lanesTop + r * ROW_H - view.scrollY;
      if (top < L.lanesTop - ROW_H / 2 || top > L.lanesTop + L.lanesH) return;
      if (row.kind === "joint") rowsIn(top, ROW_H, (k) => k.joints.includes(row.j));
      else if (view.folded.has(row.limb.name)) rowsIn(top, ROW_H, (k) => k.joints.some((j) => row.limb.joints.includes(j)));
    });
    return found;
  }

  // --- pointer --------------------------------------------------------------------------------
  function point(event) {
    const box = canvas.getBoundingClientRect();
    cssW = canvas.clientWidth;
    return [event.clientX - box.left, event.clientY - box.top];
  }

  canvas.addEventListener("pointerdown", (event) => {
    if (!state || event.button !== 0) return;
    canvas.focus();
    const [x, y] = point(event);
    const what = hit(x, y);
    canvas.setPointerCapture(event.pointerId);
    if (what.kind === "ruler" || what.kind === "curves") {
      if (x < LABEL_W) return;
      drag = { kind: "scrub" };
      scrubTo(tOf(x), true);
    } else if (what.kind === "finding") {
      openFinding(what.index);
    } else if (what.kind === "limb") {
      if (view.folded.has(what.name)) view.folded.delete(what.name);
      else view.folded.add(what.name);
    } else if (what.kind === "label") {
      if (view.picked.has(what.j)) view.picked.delete(what.j);
      else view.picked.add(what.j);
    } else if (what.kind === "key") {
      const index = what.index;
      if (event.shiftKey) {
        if (selection.has(index)) selection.delete(index);
        else selection.add(index);
      } else if (!selection.has(index)) {
        selection.clear();
        selection.add(index);
      }
      drag = { kind: "keys", index, x0: x, dt: 0, moved: false, shift: event.shiftKey };
    } else {
      drag = { kind: "box", x0: x, y0: y, x, y, add: event.shiftKey };
    }
    changed();
  });

  canvas.addEventListener("pointermove", (event) => {
    const [x, y] = point(event);
    if (!drag) {
      hover(x, y);
      return;
    }
    if (drag.kind === "scrub") scrubTo(tOf(x), true);
    else if (drag.kind === "box") Object.assign(drag, { x, y });
    else if (drag.kind === "keys") {
      if (Math.abs(x - drag.x0) > DRAG_PX) drag.moved = true;
      if (drag.moved && selection.has(drag.index)) {
        const from = state.keyframes[drag.index].t;
        const to = snapped(from + tOf(x) - tOf(drag.x0), event.altKey);
        drag.dt = to - from;
        tip.style.display = "block";
        tip.textContent = `${to.toFixed(2)} s (${drag.dt >= 0 ? "+" : ""}${drag.dt.toFixed(2)} s)`;
        placeTip(x, y);
      }
    }
    changed();
  });

  canvas.addEventListener("pointerup", (event) => {
    if (!drag) return;
    const [x, y] = point(event);
    const done = drag;
    drag = null;
    tip.style.display = "none";
    if (done.kind === "scrub") scrubTo(tOf(x), false);
    else if (done.kind === "box") {
      if (!done.add) selection.clear();
      if (Math.abs(x - done.x0) > DRAG_PX || Math.abs(y - done.y0) > DRAG_PX) {
        for (const i of keyframesInBox(done.x0, done.y0, x, y)) selection.add(i);
      }
      announceSelection();
    } else if (done.kind === "keys") {
      if (done.moved && Math.abs(done.dt) > 1e-6) moveSelected(done.dt);
      else {
        if (!done.shift) {
          selection.clear();
          selection.add(done.index);
        }
        announceSelection(); // one keyframe selected: the studio scrubs to it
      }
    }
    changed();
  });

  canvas.addEventListener("pointerleave", () => { if (!drag) tip.style.display = "none"; });

  canvas.addEventListener("wheel", (event) => {
    if (!state) return;
    event.preventDefault();
    const [x, y] = point(event);
    const L = layout();
    const overLanes = y >= L.lanesTop && y < L.curvesTop;
    if (event.ctrlKey || event.metaKey || (!overLanes && !event.shiftKey && !event.deltaX)) {
      zoom(Math.exp(event.deltaY * 0.002), x > LABEL_W ? tOf(x) : undefined);
    } else if (event.shiftKey || Math.abs(event.deltaX) > Math.abs(event.deltaY)) {
      pan(((event.deltaX || event.deltaY) / Math.max(plotW(), 1)) * view.span);
    } else {
      view.scrollY += event.deltaY;
      changed();
    }
  }, { passive: false });

  function hover(x, y) {
    if (!state) return;
    const what = hit(x, y);
    let text = "";
    if (what.kind === "key") {
      const k = state.keyframes[what.index];
      text = `keyframe ${what.index + 1} · ${k.t.toFixed(2)} s · ${k.where}${k.label ? " · " + k.label : ""}`;
    } else if (what.kind === "finding") {
      const f = state.findings[what.index];
      text = `${f.t.toFixed(2)} s ${f.severity}: ${f.message} (keyframe ${f.keyframe})`;
    } else if (what.kind === "label") text = "click: show or hide this joint's curves";
    else if (what.kind === "limb") text = "click: fold or unfold this limb's lanes";
    tip.style.display = text ? "block" : "none";
    tip.textContent = text;
    if (text) placeTip(x, y);
  }

  function placeTip(x, y) {
    const w = canvas.clientWidth;
    tip.style.left = `${Math.min(x + 12, w - tip.offsetWidth - 4)}px`;
    tip.style.top = `${y + 14}px`;
  }

  // --- requests -------------------------------------------------------------------------------
  let lastScrub = 0;
  function scrubTo(t, live) {
    if (!state) return;
    t = clamp(t, state.start_s, state.end_s);
    timeS = t;
    if (play.playing) play = { ...play, t, perf: performance.now() };
    followSong(play.playing);
    keepInView(t);
    changed();
    const now = performance.now();
    if (!live || now - lastScrub > 40) { // at most 25 scrubs a second while dragging
      lastScrub = now;
      send({ op: "scrub", t: Math.round(t * 1000) / 1000 });
    }
  }

  function openFinding(index) {
    const f = state.findings[index];
    scrubTo(f.t, false);
    send({ op: "finding", index, version: state.version });
  }

  function announceSelection() {
    const indices = [...selection].sort((a, b) => a - b);
    send({ op: "select", indices, version: state.version });
  }

  function moveSelected(dt) {
    const moves = [...selection].sort((a, b) => a - b).map((i) => ({
      index: i, t: Math.round((state.keyframes[i].t + dt) * 1000) / 1000,
    }));
    send({ op: "move", moves, version: state.version });
  }

  function copy() {
    const indices = [...selection].sort((a, b) => a - b);
    if (!indices.length) return;
    const t0 = state.keyframes[indices[0]].t;
    copied = indices.map((i) => ({ offset_s: state.keyframes[i].t - t0, pose: state.keyframes[i].pose }));
    showStatus({ text: `copied ${copied.length} keyframe${copied.length > 1 ? "s" : ""}: paste puts them at the playhead`, kind: "" });
  }

  function paste() {
    if (!copied.length) {
      showStatus({ text: "nothing copied: select keyframes and copy them first", kind: "refused" });
      return;
    }
    const at = timeS;
    send({
      op: "paste",
      keyframes: copied.map((c) => ({ t: Math.round((at + c.offset_s) * 1000) / 1000, pose: c.pose })),
      version: state.version,
    });
  }

  // --- keys (the table in the README) ----------------------------------------------------------
  function onKey(key) {
    if (!state) return false;
    const ctrl = key.ctrlKey || key.metaKey;
    const name = key.key;
    if (name === " ") send({ op: "play" });
    else if (name === "ArrowLeft" || name === "ArrowRight") {
      const direction = name === "ArrowRight" ? 1 : -1;
      scrubTo(key.shiftKey ? beatStep(direction) : timeS + direction * FRAME_S, false);
    } else if ((name === "k" || name === "K") && !ctrl) send({ op: "add" });
    else if (name === "Delete" || name === "Backspace") {
      if (selection.size) send({ op: "delete", indices: [...selection].sort((a, b) => a - b), version: state.version });
      selection.clear();
    } else if (name === "Home") scrubTo(state.start_s, false);
    else if (name === "End") scrubTo(state.end_s, false);
    else if (ctrl && (name === "z" || name === "Z")) send({ op: key.shiftKey ? "redo" : "undo" });
    else if (ctrl && (name === "y" || name === "Y")) send({ op: "redo" });
    else if (ctrl && (name === "c" || name === "C")) copy();
    else if (ctrl && (name === "v" || name === "V")) paste();
    else if (ctrl && (name === "a" || name === "A")) state.keyframes.forEach((_, i) => selection.add(i));
    else if (name === "Escape") selection.clear();
    else if (name === "+" || name === "=") zoom(1 / 1.5);
    else if (name === "-") zoom(1.5);
    else if (name === "0") fit();
    else return false;
    changed();
    return true;
  }

  document.addEventListener("keydown", (event) => {
    if (event.target instanceof HTMLInputElement && event.target.type !== "checkbox") return;
    if (onKey(event)) event.preventDefault();
  });
  // keys pressed in viser's page (the 3D view has the focus) come here as messages
  window.addEventListener("message", (event) => {
    const key = event.data && event.data.choreoKey;
    if (key) onKey(key);
  });

  playButton.addEventListener("click", () => send({ op: "play" }));
  document.getElementById("zoom-in").addEventListener("click", () => zoom(1 / 1.5));
  document.getElementById("zoom-out").addEventListener("click", () => zoom(1.5));
  document.getElementById("zoom-fit").addEventListener("click", fit);

  // --- the song follows the timeline's clock ----------------------------------------------------
  function followSong(playing) {
    if (!state || !state.music || !song.src) return;
    const want = state.music.offset_s + timeS;
    const inside = want >= 0 && (!song.duration || want < song.duration);
    if (!playing || !inside) {
      if (!song.paused) song.pause();
      if (inside && Math.abs(song.currentTime - want) > 1e-3) song.currentTime = want;
      return;
    }
    if (song.paused) {
      song.currentTime = want;
      song.playbackRate = play.speed;
      song.play().catch(() => {});
      return;
    }
    const off = song.currentTime - want;
    if (Math.abs(off) > SEEK_S) {
      song.currentTime = want;
      return;
    }
    // nudge the song's rate toward the timeline: 20 ms behind plays 2% faster for a while
    song.playbackRate = play.speed * clamp(1 - off, 1 - NUDGE, 1 + NUDGE);
    if (!song.seeking && song.readyState >= 3) {
      drift.push(off);
      if (drift.length > 20000) drift.shift();
    }
  }

  // A frame is asked for when something changed, and every frame while playing; an idle
  // timeline asks for none (a frame loop that never stopped kept a software-rendering browser a
  // quarter of a core busy redrawing the page, with nothing new on it).
  function changed() {
    dirty = true;
    if (!framePending) {
      framePending = true;
      requestAnimationFrame(frame);
    }
  }

  function frame() {
    framePending = false;
    if (play.playing && state) {
      let t = play.t + ((performance.now() - play.perf) / 1000) * play.speed;
      if (t > state.end_s) t = state.end_s; // the studio says where it goes on from there
      timeS = t;
      followSong(true);
      keepInView(t);
      changed();
    }
    if (dirty) {
      dirty = false;
      redraw(false);
    }
  }
  window.addEventListener("resize", changed);
  changed();

  // for the tests and the benchmarks: what the page shows, and a timed redraw
  window.choreoTimeline = {
    get state() { return state; },
    get time() { return timeS; },
    get playing() { return play.playing; },
    get selection() { return [...selection].sort((a, b) => a - b); },
    get view() { return { t0: view.t0, span: view.span }; },
    drift: () => drift.slice(),
    partMs: () => ({ ...partMs }),
    clearDrift: () => { drift.length = 0; },
    redraw,
    xOf, tOf, layout,
    keyframeY: () => { const L = layout(); return L.keysTop + KEYS_H / 2; },
    findingY: () => { const L = layout(); return L.findTop + FIND_H / 2; },
  };
})();
