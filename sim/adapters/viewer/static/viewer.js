// shipradar PPI: draws the batches the viewer pushes over its WebSocket (sim/adapters/viewer/wire.py).
// Plain ES2020 and canvas 2D; no build step and no network beyond this server.
"use strict";

(() => {
  const MAX_FADE = 50;           // scans kept for fading (server: MAX_FADE_SCANS)
  const MAX_TRUTH_POINTS = 20000; // truth history kept (one point per target per end of scan)
  const MAX_TRACK_POINTS = 2000;  // history kept per tracker track
  const css = getComputedStyle(document.documentElement);
  const colour = (name) => css.getPropertyValue(name).trim();
  const COLOURS = {
    plain: colour("--plain"), target: colour("--target"), noise: colour("--noise"),
    clutter: colour("--clutter"), truth: colour("--truth"), track: colour("--track"),
    ship: colour("--ship"), ring: colour("--ring"), text: colour("--text"),
    muted: colour("--muted"),
  };
  const ORIGIN_COLOUR = [COLOURS.target, COLOURS.noise, COLOURS.clutter];
  const ARRAYS = { f8: Float64Array, f4: Float32Array, u1: Uint8Array, i4: Int32Array };

  // ------------------------------------------------------------------ state
  const S = {
    info: null,              // {mode, source, t0, t1, ...}
    sensors: new Map(),      // id -> sensor record (see sensor())
    batches: new Map(),      // "sensor:first plot id" -> plot batch (for the truth join)
    truth: [],               // [{t, e: Float64Array, n, a}] target truth, time-ordered
    truthTimes: new Set(),
    tracks: new Map(),       // track id -> {sensor, pts: [[t, e, n, ve, vn, se, sn]]}
    clock: { t: 0, playing: false, speed: 1, live: false, ended: false, perf: 0 },
    lastItemT: 0,
    fadeScans: 5, truthColours: true, truthTracks: true, showTracks: true,
    selected: "all", userSelected: false,
    frozenAt: null,          // live stream: display time frozen by "pause"
    status: {}, latencyMs: null, errors: [], batchesReceived: 0, itemsReceived: 0,
    framesDrawn: 0, connected: false, closed: false,
    views: new Map(),        // sensor id -> {zoom, panE, panN}
  };

  function sensor(id) {
    let s = S.sensors.get(id);
    if (!s) {
      s = { id, meta: null, eos: [], batches: [], perScan: new Map(), lastScan: -1 };
      S.sensors.set(id, s);
      rebuildScopes();
    }
    return s;
  }

  function scanCount(s, scan) {
    let c = s.perScan.get(scan);
    if (!c) {
      c = { total: 0, target: 0, noise: 0, clutter: 0 };
      s.perScan.set(scan, c);
    }
    return c;
  }

  function resetData() {
    for (const s of S.sensors.values()) {
      s.eos = []; s.batches = []; s.perScan = new Map(); s.lastScan = -1;
    }
    // tracker tracks stay: they come from a live tracker, not from the replay, and are
    // drawn up to the display time
    S.batches.clear(); S.truth = []; S.truthTimes.clear();
  }

  // ------------------------------------------------------------------ items
  function apply(it) {
    S.itemsReceived++;
    if (typeof it.t === "number" && it.k !== "clock" && it.k !== "tracks" && it.k !== "reset") {
      S.lastItemT = Math.max(S.lastItemT, it.t);
    }
    switch (it.k) {
      case "info":
        S.info = it;
        setupControls();
        break;
      case "reset":
        resetData();
        S.lastItemT = it.t;
        break;
      case "clock":
        S.clock = { t: it.t ?? 0, playing: it.playing, speed: it.speed, live: it.live,
                    ended: it.ended, perf: performance.now() };
        updatePlayButton();
        break;
      case "error":
        S.errors.push(it.message);
        break;
      case "meta": {
        const s = sensor(it.sensor);
        const first = !s.meta;
        s.meta = it;
        if (first) rebuildScopes();
        break;
      }
      case "plots": {
        const s = sensor(it.sensor);
        const b = { sensor: it.sensor, scan: it.scan, t: it.t, id: it.id, ts: it.ts, r: it.r,
                    az: it.az, snr: it.snr, o: null, tg: null };
        s.batches.push(b);
        if (it.id.length) S.batches.set(it.sensor + ":" + it.id[0], b);
        scanCount(s, it.scan).total += it.id.length;
        prune(s, it.scan);
        break;
      }
      case "origin": {
        const b = S.batches.get(it.sensor + ":" + it.id0);
        if (!b || b.id.length !== it.n) break; // its plots were dropped
        b.o = it.o; b.tg = it.tg;
        const c = scanCount(sensor(it.sensor), it.scan);
        for (let i = 0; i < it.o.length; i++) {
          const o = it.o[i];
          if (o === 0) c.target++; else if (o === 1) c.noise++; else if (o === 2) c.clutter++;
        }
        break;
      }
      case "eos": {
        const s = sensor(it.sensor);
        s.eos.push(it);
        if (s.eos.length > 2 * MAX_FADE + 8) s.eos.splice(0, s.eos.length - (2 * MAX_FADE + 8));
        s.lastScan = Math.max(s.lastScan, it.scan);
        break;
      }
      case "targets":
        // every radar sends the same states at its own ends of scan: keep one per time
        if (S.truthTimes.has(it.t)) break;
        S.truthTimes.add(it.t);
        S.truth.push(it);
        if (S.truth.length * Math.max(1, it.e.length) > MAX_TRUTH_POINTS) {
          const gone = S.truth.shift();
          S.truthTimes.delete(gone.t);
        }
        break;
      case "tracks":
        for (let i = 0; i < it.ids.length; i++) {
          let tr = S.tracks.get(it.ids[i]);
          if (!tr) { tr = { sensor: it.sensor, pts: [] }; S.tracks.set(it.ids[i], tr); }
          tr.pts.push([it.t, it.e[i], it.n[i], it.ve[i], it.vn[i], it.se[i], it.sn[i]]);
          if (tr.pts.length > MAX_TRACK_POINTS) tr.pts.shift();
        }
        break;
      default:
        break;
    }
  }

  function prune(s, scan) {
    const keep = scan - MAX_FADE;
    let k = 0;
    while (k < s.batches.length && s.batches[k].scan < keep) {
      const b = s.batches[k];
      if (b.id.length) S.batches.delete(b.sensor + ":" + b.id[0]);
      k++;
    }
    if (k) s.batches.splice(0, k);
    for (const key of s.perScan.keys()) if (key < keep - 2 * MAX_FADE) s.perScan.delete(key);
  }

  function unpack(buf) {
    const h = new DataView(buf).getUint32(0, true);
    const head = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, h)));
    const base = 4 + h + ((8 - ((4 + h) % 8)) % 8);
    for (const it of head.items) {
      for (const key in it) {
        const v = it[key];
        if (v && typeof v === "object" && !Array.isArray(v) && "$" in v) {
          const [off, n, code] = v.$;
          it[key] = new ARRAYS[code](buf, base + off, n);
        }
      }
    }
    return head;
  }

  // ------------------------------------------------------------------ socket
  let ws = null;
  function send(obj) {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(JSON.stringify(obj));
  }

  function connect() {
    const url = (location.protocol === "https:" ? "wss://" : "ws://") + location.host + "/ws";
    ws = new WebSocket(url);
    ws.binaryType = "arraybuffer";
    ws.onopen = () => { S.connected = true; send({ cmd: "hello" }); };
    ws.onclose = () => { S.connected = false; S.closed = true; };
    ws.onerror = () => { /* onclose follows and is shown on the status line */ };
    ws.onmessage = (ev) => {
      const batch = unpack(ev.data);
      S.batchesReceived++;
      S.status = batch.status;
      const lat = Date.now() - batch.ws;
      S.latencyMs = S.latencyMs === null ? lat : 0.9 * S.latencyMs + 0.1 * lat;
      for (const it of batch.items) apply(it);
    };
  }

  // ------------------------------------------------------------------ time
  function now() {
    if (S.frozenAt !== null) return S.frozenAt;
    const c = S.clock;
    let t = c.t;
    if (c.playing) t += (performance.now() - c.perf) / 1000 * c.speed;
    if (c.live) {
      // extrapolate the sweep between messages, never far beyond the last one
      let period = 1;
      for (const s of S.sensors.values()) if (s.meta) period = Math.min(period, s.meta.period);
      t = Math.min(t, S.lastItemT + period / 4);
      return Math.max(t, c.t);
    }
    if (S.info && S.info.t1 !== null) t = Math.min(t, S.info.t1);
    return t;
  }

  // own ship position [e, n] and heading [deg] at time t: the ends of scan, dead-reckoned
  function shipAt(s, t) {
    const eos = s.eos;
    if (!eos.length) return { e: 0, n: 0, hd: null };
    let k = eos.length - 1;
    while (k > 0 && eos[k].t > t) k--;
    const ref = eos[k];
    const dt = t - ref.t;
    return { e: ref.e + ref.ve * dt, n: ref.n + ref.vn * dt, hd: ref.hd };
  }

  // ------------------------------------------------------------------ scopes
  const scopesEl = document.getElementById("scopes");
  const scopes = new Map(); // sensor id -> {el, canvas, ctx, title}

  function rebuildScopes() {
    const ids = [...S.sensors.keys()];
    const sel = document.getElementById("sensor");
    // until the user picks one, every radar is shown (side by side once there are two)
    const prev = S.userSelected ? S.selected : "all";
    sel.innerHTML = "";
    if (ids.length > 1) sel.add(new Option("all, side by side", "all"));
    for (const id of ids) sel.add(new Option(id, id));
    sel.value = ids.includes(prev) || (prev === "all" && ids.length > 1) ? prev
      : (ids.length > 1 ? "all" : ids[0] || "");
    S.selected = sel.value;
    const shown = S.selected === "all" ? ids : ids.filter((id) => id === S.selected);
    for (const [id, sc] of scopes) {
      if (!shown.includes(id)) { sc.el.remove(); scopes.delete(id); }
    }
    for (const id of shown) {
      if (scopes.has(id)) continue;
      const el = document.createElement("div");
      el.className = "scope";
      const canvas = document.createElement("canvas");
      canvas.dataset.sensor = id;
      const title = document.createElement("div");
      title.className = "title";
      el.append(canvas, title);
      scopesEl.append(el);
      const sc = { el, canvas, ctx: canvas.getContext("2d"), title, geom: null };
      scopes.set(id, sc);
      attachPanZoom(id, sc);
    }
  }

  function view(id) {
    let v = S.views.get(id);
    if (!v) { v = { zoom: 1, panE: 0, panN: 0 }; S.views.set(id, v); }
    return v;
  }

  function attachPanZoom(id, sc) {
    const c = sc.canvas;
    c.addEventListener("wheel", (ev) => {
      ev.preventDefault();
      const g = sc.geom;
      if (!g) return;
      const v = view(id);
      const factor = Math.exp(-ev.deltaY * 0.0015);
      const zoom = Math.min(200, Math.max(0.25, v.zoom * factor));
      // keep the point under the cursor where it is
      const rect = c.getBoundingClientRect();
      const mx = ev.clientX - rect.left, my = ev.clientY - rect.top;
      const e = g.ce + (mx - g.cx) / g.scale, n = g.cn - (my - g.cy) / g.scale;
      const scale = g.scale * zoom / v.zoom;
      v.zoom = zoom;
      v.panE += e - (g.ce + (mx - g.cx) / scale);
      v.panN += n - (g.cn - (my - g.cy) / scale);
    }, { passive: false });
    let drag = null;
    c.addEventListener("pointerdown", (ev) => {
      drag = { x: ev.clientX, y: ev.clientY };
      c.setPointerCapture(ev.pointerId);
      c.classList.add("dragging");
    });
    c.addEventListener("pointermove", (ev) => {
      if (!drag || !sc.geom) return;
      const v = view(id);
      v.panE -= (ev.clientX - drag.x) / sc.geom.scale;
      v.panN += (ev.clientY - drag.y) / sc.geom.scale;
      drag = { x: ev.clientX, y: ev.clientY };
    });
    const end = () => { drag = null; c.classList.remove("dragging"); };
    c.addEventListener("pointerup", end);
    c.addEventListener("pointercancel", end);
    c.addEventListener("dblclick", () => S.views.set(id, { zoom: 1, panE: 0, panN: 0 }));
  }

  function niceStep(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    for (const m of [1, 2, 2.5, 5, 10]) if (m * p >= x) return m * p;
    return 10 * p;
  }

  function fmtRange(m) {
    return m >= 1000 ? (m / 1000).toLocaleString("en", { maximumFractionDigits: 1 }) + " km"
      : Math.round(m) + " m";
  }

  function draw(id, sc, t) {
    const s = S.sensors.get(id);
    const canvas = sc.canvas;
    const dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (!w || !h) return;
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr); canvas.height = Math.round(h * dpr);
    }
    const ctx = sc.ctx;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.fillStyle = "#030b06";
    ctx.fillRect(0, 0, w, h);
    if (!s || !s.meta) {
      sc.title.innerHTML = `<b>${id}</b> waiting for its metadata&hellip;`;
      return;
    }
    const m = s.meta;
    const v = view(id);
    const ship = shipAt(s, t);
    const rMax = m.range_m;
    const scale = v.zoom * (Math.min(w, h) / 2 - 24) / rMax; // px per m
    const ce = ship.e + v.panE, cn = ship.n + v.panN;          // local frame at the centre
    const cx = w / 2, cy = h / 2;
    sc.geom = { scale, ce, cn, cx, cy, dpr };
    const X = (e) => cx + (e - ce) * scale;
    const Y = (n) => cy - (n - cn) * scale;
    const sx = X(ship.e), sy = Y(ship.n);

    // range rings around the own ship, labelled; azimuth ticks every 30 degrees
    const visible = Math.hypot(w, h) / 2 / scale + Math.hypot(v.panE, v.panN);
    const step = niceStep(Math.min(rMax, visible) / 6);
    ctx.lineWidth = 1;
    ctx.font = "12px system-ui, sans-serif";
    ctx.textBaseline = "middle";
    for (let r = step; r < rMax + 1e-6; r += step) {
      ctx.strokeStyle = "rgba(93,255,106,0.22)";
      ctx.beginPath(); ctx.arc(sx, sy, r * scale, 0, 2 * Math.PI); ctx.stroke();
      // labels just above the east spoke: on screen for every ring narrower than the scope
      const a = 75 * Math.PI / 180;
      ctx.fillStyle = "rgba(207,232,212,0.75)";
      ctx.fillText(fmtRange(r), sx + r * scale * Math.sin(a) + 3, sy - r * scale * Math.cos(a));
    }
    ctx.strokeStyle = "rgba(93,255,106,0.55)";
    ctx.beginPath(); ctx.arc(sx, sy, rMax * scale, 0, 2 * Math.PI); ctx.stroke();
    ctx.textAlign = "center";
    // bearing labels outside the instrumented range, or at the scope's edge when zoomed in
    const lr = Math.min(rMax * scale + 12, Math.min(w, h) / 2 - 12);
    for (let deg = 0; deg < 360; deg += 30) {
      const a = deg * Math.PI / 180, sa = Math.sin(a), ca = Math.cos(a);
      ctx.strokeStyle = "rgba(93,255,106,0.18)";
      ctx.beginPath(); ctx.moveTo(sx, sy);
      ctx.lineTo(sx + rMax * scale * sa, sy - rMax * scale * ca); ctx.stroke();
      ctx.fillStyle = "rgba(207,232,212,0.8)";
      ctx.fillText(String(deg).padStart(3, "0"), cx + lr * sa, cy - lr * ca);
    }
    ctx.textAlign = "left";

    // sweep: the antenna's azimuth now, with a fading trail behind it
    const az = (m.az0_deg * Math.PI / 180 + 2 * Math.PI * t / m.period) % (2 * Math.PI);
    const R = rMax * scale;
    const trail = Math.PI / 5;
    const grad = ctx.createConicGradient(az - Math.PI / 2 - trail, sx, sy);
    grad.addColorStop(0, "rgba(93,255,106,0)");
    grad.addColorStop(trail / (2 * Math.PI), "rgba(93,255,106,0.16)");
    grad.addColorStop(trail / (2 * Math.PI) + 1e-4, "rgba(93,255,106,0)");
    ctx.fillStyle = grad;
    ctx.beginPath(); ctx.moveTo(sx, sy);
    ctx.arc(sx, sy, R, az - Math.PI / 2 - trail, az - Math.PI / 2); ctx.closePath(); ctx.fill();
    ctx.strokeStyle = "rgba(93,255,106,0.85)";
    ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(sx, sy);
    ctx.lineTo(sx + R * Math.sin(az), sy - R * Math.cos(az)); ctx.stroke();

    // target truth: thin lines up to now, a ring at the present position
    if (S.truthTracks && S.truth.length) {
      ctx.strokeStyle = COLOURS.truth;
      ctx.lineWidth = 1;
      ctx.globalAlpha = 0.75;
      const k = S.truth[0].e.length;
      for (let j = 0; j < k; j++) {
        ctx.beginPath();
        let started = false, last = null;
        for (const tr of S.truth) {
          if (tr.t > t) break;
          if (!tr.a[j] || j >= tr.e.length) { started = false; continue; }
          const x = X(tr.e[j]), y = Y(tr.n[j]);
          if (started) ctx.lineTo(x, y); else ctx.moveTo(x, y);
          started = true; last = [x, y];
        }
        ctx.stroke();
        if (last) { ctx.beginPath(); ctx.arc(last[0], last[1], 4, 0, 2 * Math.PI); ctx.stroke(); }
      }
      ctx.globalAlpha = 1;
    }

    // plots, fading over N scans; target plots last (on top) when coloured
    const fade = S.fadeScans * m.period;
    const half = 1.75, big = 2.75;
    const targets = [];
    for (const b of s.batches) {
      if (b.t - m.period > t) continue;
      const p = shipAt(s, b.t);
      const coloured = S.truthColours && b.o;
      for (let i = 0; i < b.r.length; i++) {
        const age = t - b.ts[i];
        if (age > fade || age < -0.05) continue;
        const x = X(p.e + b.r[i] * Math.sin(b.az[i])), y = Y(p.n + b.r[i] * Math.cos(b.az[i]));
        const alpha = Math.max(0.12, 1 - Math.max(0, age) / fade);
        if (coloured && b.o[i] === 0) { targets.push([x, y, alpha]); continue; }
        ctx.globalAlpha = alpha;
        ctx.fillStyle = coloured ? ORIGIN_COLOUR[b.o[i]] || COLOURS.plain : COLOURS.plain;
        ctx.fillRect(x - half, y - half, 2 * half, 2 * half);
      }
    }
    ctx.fillStyle = COLOURS.target;
    for (const [x, y, alpha] of targets) {
      ctx.globalAlpha = alpha;
      ctx.fillRect(x - big, y - big, 2 * big, 2 * big);
    }
    ctx.globalAlpha = 1;

    // tracker tracks: history, the estimate now (with a 30 s velocity leader) and its id
    if (S.showTracks) {
      ctx.strokeStyle = COLOURS.track; ctx.fillStyle = COLOURS.track; ctx.lineWidth = 1.25;
      for (const [tid, tr] of S.tracks) {
        let head = null;
        ctx.beginPath();
        for (const p of tr.pts) {
          if (p[0] > t) break;
          if (head) ctx.lineTo(X(p[1]), Y(p[2])); else ctx.moveTo(X(p[1]), Y(p[2]));
          head = p;
        }
        if (!head || t - head[0] > fade) continue;
        ctx.globalAlpha = 0.6; ctx.stroke(); ctx.globalAlpha = 1;
        const x = X(head[1]), y = Y(head[2]);
        ctx.strokeRect(x - 5, y - 5, 10, 10);
        ctx.beginPath(); ctx.moveTo(x, y);
        ctx.lineTo(X(head[1] + 30 * head[3]), Y(head[2] + 30 * head[4])); ctx.stroke();
        ctx.fillText(String(tid).slice(0, 6), x + 8, y - 9);
      }
    }

    // own ship: a hull pointing along the heading
    ctx.save();
    ctx.translate(sx, sy);
    ctx.rotate((ship.hd ?? 0) * Math.PI / 180);
    ctx.fillStyle = COLOURS.ship;
    ctx.beginPath(); ctx.moveTo(0, -10); ctx.lineTo(5, 6); ctx.lineTo(-5, 6); ctx.closePath();
    ctx.fill();
    ctx.strokeStyle = COLOURS.ship; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(0, -10); ctx.lineTo(0, -34); ctx.stroke();
    ctx.restore();

    const hd = ship.hd === null ? "–" : ship.hd.toFixed(0).padStart(3, "0") + "°";
    sc.title.innerHTML = `<b>${id}</b> on ${m.platform} · heading ${hd} · ` +
      `range ${fmtRange(rMax)} · ${(60 / m.period).toFixed(0)} rpm · zoom ×${v.zoom.toFixed(1)}`;
  }

  // ------------------------------------------------------------------ status line
  const statusEl = document.getElementById("status");
  function fmtTime(t) {
    const m = Math.floor(t / 60), s = t - 60 * m;
    return `${m}:${s.toFixed(1).padStart(4, "0")}`;
  }
  function updateStatus(t) {
    const parts = [];
    const mode = S.info ? S.info.mode : "…";
    const conn = S.connected ? "" : (S.closed ? '<span class="err">disconnected</span> · ' : "");
    parts.push(`${conn}<span class="k">${mode}</span> t ${fmtTime(t)} (${t.toFixed(1)} s)`);
    const ids = S.selected === "all" ? [...S.sensors.keys()] : [S.selected];
    for (const id of ids) {
      const s = S.sensors.get(id);
      if (!s) continue;
      const scan = s.lastScan;
      const c = s.perScan.get(scan);
      let txt = `<span class="k">${id}</span> scan ${scan < 0 ? "–" : scan}`;
      if (c) {
        txt += `: ${c.total} plots`;
        if (S.truthColours && c.target + c.noise + c.clutter > 0) {
          txt += ` (<span class="c-target">${c.target} target</span>, ` +
            `<span class="c-noise">${c.noise} noise</span>, ` +
            `<span class="c-clutter">${c.clutter} clutter</span>)`;
        }
      }
      parts.push(txt);
    }
    const st = S.status || {};
    const dropped = st.dropped || 0;
    parts.push(dropped ? `<span class="warn">${dropped} dropped for this page</span>`
      : "0 dropped");
    if (st.bad) parts.push(`<span class="warn">${st.bad} unreadable</span>`);
    if (S.latencyMs !== null) parts.push(`latency ${Math.max(0, S.latencyMs).toFixed(0)} ms`);
    if (S.frozenAt !== null) parts.push('<span class="warn">display frozen</span>');
    if (S.errors.length) parts.push(`<span class="err">${S.errors[S.errors.length - 1]}</span>`);
    statusEl.innerHTML = parts.join(" · ");
  }

  // ------------------------------------------------------------------ controls
  const el = (id) => document.getElementById(id);
  let sliderBusy = false;

  function setupControls() {
    const live = S.info.mode === "live";
    el("speed-box").style.display = live ? "none" : "";
    el("slider").disabled = live;
    if (!live) {
      el("slider").min = S.info.t0;
      el("slider").max = S.info.t1;
    }
  }

  function updatePlayButton() {
    const c = S.clock;
    const live = S.info && S.info.mode === "live";
    const playing = live ? S.frozenAt === null : c.playing;
    el("play").innerHTML = playing ? "pause" : (c.ended ? "&#9654; replay" : "&#9654; play");
    if (!live && c.speed) el("speed").value = String(c.speed);
  }

  function togglePlay() {
    if (S.info && S.info.mode === "live") {
      S.frozenAt = S.frozenAt === null ? now() : null;
      updatePlayButton();
      return;
    }
    send({ cmd: S.clock.playing ? "pause" : "play" });
  }

  el("play").addEventListener("click", togglePlay);
  document.addEventListener("keydown", (ev) => {
    if (ev.code === "Space" && ev.target === document.body) { ev.preventDefault(); togglePlay(); }
  });
  el("speed").addEventListener("change", () => send({ cmd: "speed", value: Number(el("speed").value) }));
  el("slider").addEventListener("input", () => {
    sliderBusy = true;
    el("slider-label").textContent = `${Number(el("slider").value).toFixed(1)} s`;
  });
  el("slider").addEventListener("change", () => {
    sliderBusy = false;
    send({ cmd: "seek", t: Number(el("slider").value), window_scans: S.fadeScans });
  });
  el("fade").addEventListener("change", () => {
    const n = Math.round(Number(el("fade").value));
    S.fadeScans = Math.min(MAX_FADE, Math.max(1, Number.isFinite(n) ? n : 5));
    el("fade").value = S.fadeScans;
  });
  el("truth-colours").addEventListener("change", () => { S.truthColours = el("truth-colours").checked; });
  el("truth-tracks").addEventListener("change", () => { S.truthTracks = el("truth-tracks").checked; });
  el("tracks").addEventListener("change", () => { S.showTracks = el("tracks").checked; });
  el("sensor").addEventListener("change", () => {
    S.selected = el("sensor").value;
    S.userSelected = true;
    rebuildScopes();
  });
  el("reset-view").addEventListener("click", () => S.views.clear());

  // ------------------------------------------------------------------ frame loop
  function frame() {
    const t = now();
    S.displayT = t;
    for (const [id, sc] of scopes) draw(id, sc, t);
    if (!sliderBusy && S.info && S.info.mode !== "live") {
      el("slider").value = t;
      el("slider-label").textContent = `${t.toFixed(1)} / ${Number(S.info.t1).toFixed(0)} s`;
    } else if (S.info && S.info.mode === "live") {
      el("slider-label").textContent = `${t.toFixed(1)} s live`;
    }
    updateStatus(t);
    S.framesDrawn++;
    requestAnimationFrame(frame);
  }

  // ------------------------------------------------------------------ test hooks
  // A small read-only API for tests and the curious (browser console): counts, transforms.
  window.shipradarViewer = {
    state: S,
    now,
    /** plots per scan of a radar: {scan: {total, target, noise, clutter}} */
    perScan(id) {
      const s = S.sensors.get(id);
      return s ? Object.fromEntries([...s.perScan].map(([k, v]) => [k, { ...v }])) : {};
    },
    /** where a plot of range r [m] and azimuth az [rad] from the plots message of time
     * tMsg [s] is drawn: {x, y} in CSS pixels of that radar's canvas, and the device
     * pixel ratio (the plot is placed from the own ship's position at tMsg) */
    screenOf(id, r, az, tMsg) {
      const s = S.sensors.get(id), sc = scopes.get(id);
      if (!s || !sc || !sc.geom) return null;
      const g = sc.geom, p = shipAt(s, tMsg);
      return { x: g.cx + (p.e + r * Math.sin(az) - g.ce) * g.scale,
               y: g.cy - (p.n + r * Math.cos(az) - g.cn) * g.scale, dpr: g.dpr };
    },
    /** zoom (x, 1: the instrumented range fills the scope) and pan [m east, m north] */
    setView(id, zoom, panE = 0, panN = 0) { S.views.set(id, { zoom, panE, panN }); },
    send,
  };

  connect();
  requestAnimationFrame(frame);
})();
