// machplan's shop-floor panel (docs/panel.md): plain JavaScript, no library, no build step.
//
// Drawing: two canvases over each other. "paths" holds what does not move (the table, the
// parts, the planned path, the pierce points, the cut so far), drawn once per job, resize or
// zoom, with points closer than half a pixel to the last drawn one skipped, so that a
// 100,000-move job draws in tens of milliseconds; the cut so far is added to it piece by
// piece as it comes. "live" holds the tool only and is redrawn at most once per animation
// frame. window.panelStats tells the tests what the drawing cost.
'use strict';

const $ = (id) => document.getElementById(id);
const stats = (window.panelStats = { staticDrawMs: 0, staticPoints: 0, frames: 0, lastFrame: null, jobMoves: 0 });

// ---- session -----------------------------------------------------------------------------------
const clientId = sessionStorage.getItem('machplanClient') || (() => {
  const b = new Uint8Array(12);
  crypto.getRandomValues(b);
  const id = 'c-' + Array.from(b, (x) => x.toString(16).padStart(2, '0')).join('');
  sessionStorage.setItem('machplanClient', id);
  return id;
})();

async function api(method, path, body) {
  const opt = { method, headers: { 'X-Machplan-Client': clientId }, credentials: 'same-origin' };
  if (body !== undefined) {
    opt.headers['Content-Type'] = 'application/json';
    opt.body = JSON.stringify(body);
  } else if (method === 'POST') {
    opt.headers['Content-Type'] = 'application/json';
    opt.body = '{}';
  }
  const r = await fetch('/api' + path, opt);
  if (r.status === 401) { showLogin(true); throw new Error('not logged in'); }
  const text = await r.text();
  let j = null;
  try { j = text ? JSON.parse(text) : null; } catch (e) { j = null; }
  if (!r.ok) throw new Error((j && j.error) || ('HTTP ' + r.status));
  return j;
}

function say(text, isError) {
  const m = $('message');
  m.textContent = text;
  m.classList.toggle('hidden', !text);
  m.style.background = isError ? '#8e2424' : '';
  if (text) setTimeout(() => { if (m.textContent === text) m.classList.add('hidden'); }, isError ? 8000 : 3000);
}
async function act(method, path, body) {
  try { return await api(method, path, body); } catch (e) { say(e.message, true); return null; }
}
function showLogin(on) {
  $('login').classList.toggle('hidden', !on);
  if (on) linked(false, 'not authorised');
}
// Whether this page reaches the machine. When it does not (no token, a wrong one, the server
// gone), nothing on it may look live: the state says so and the E-STOP is disabled, as it could
// not stop anything.
function linked(on, why) {
  const e = $('estop');
  e.disabled = !on;
  e.title = on ? 'E-stop: torch off, controlled stop (any client, always)'
               : 'not connected: this page cannot stop the machine; use the machine\'s own E-stop';
  if (!on) showState(why || 'offline', 'offline');
}

async function login() {
  const q = new URLSearchParams(location.search);
  const token = q.get('token');
  if (token) {
    const r = await fetch('/api/login', { method: 'POST', headers: { Authorization: 'Bearer ' + token } });
    history.replaceState(null, '', location.pathname);  // the token leaves the address bar
    if (!r.ok) { showLogin(true); return false; }
  }
  try { await api('GET', '/status'); showLogin(false); return true; } catch (e) { return false; }
}

// ---- view: world <-> screen --------------------------------------------------------------------
const view = { job: null, guard: null, box: null, scale: 1, ox: 0, oy: 0, w: 0, h: 0, dpr: 1, mode: 'job' };
const trail = [];          // the cut so far: [x, y] or null for a break
let trailDrawn = 0;
let live = null;           // the newest frame
const edge = [null, null]; // the sheet edge's two points as taken, machine mm
let liveDirty = true;

function fit() {
  const c = $('paths');
  const r = c.getBoundingClientRect();
  view.dpr = window.devicePixelRatio || 1;
  view.w = Math.max(1, Math.floor(r.width * view.dpr));
  view.h = Math.max(1, Math.floor(r.height * view.dpr));
  for (const id of ['paths', 'live']) { $(id).width = view.w; $(id).height = view.h; }
  let b = null;
  if (view.mode === 'hybrid' && view.guard) b = guardBox(view.guard);
  else if (view.job) b = { x0: Math.min(0, view.job.bounds.min[0]), y0: Math.min(0, view.job.bounds.min[1]),
                           x1: Math.max(view.job.bounds.max[0], 10), y1: Math.max(view.job.bounds.max[1], 10) };
  if (!b) b = { x0: 0, y0: 0, x1: 400, y1: 300 };
  const m = 0.06 * Math.max(b.x1 - b.x0, b.y1 - b.y0) + 5;
  b = { x0: b.x0 - m, y0: b.y0 - m, x1: b.x1 + m, y1: b.y1 + m };
  view.box = b;
  view.scale = Math.min(view.w / (b.x1 - b.x0), view.h / (b.y1 - b.y0));  // one scale: drawn to scale
  view.ox = (view.w - view.scale * (b.x1 - b.x0)) / 2 - view.scale * b.x0;
  view.oy = (view.h + view.scale * (b.y1 - b.y0)) / 2 + view.scale * b.y0;
  drawStatic();
}
const sx = (x) => view.ox + view.scale * x;
const sy = (y) => view.oy - view.scale * y;

// A polyline of flat x, y pairs, skipping points within half a pixel of the last drawn one.
function polyline(g, pts, closed) {
  if (pts.length < 4) return 0;
  let lx = sx(pts[0]), ly = sy(pts[1]), n = 1;
  g.moveTo(lx, ly);
  const last = pts.length - 2;
  for (let i = 2; i < pts.length; i += 2) {
    const x = sx(pts[i]), y = sy(pts[i + 1]);
    if (i !== last && Math.abs(x - lx) < 0.5 && Math.abs(y - ly) < 0.5) continue;
    g.lineTo(x, y);
    lx = x; ly = y; n++;
  }
  if (closed) g.closePath();
  return n;
}

function drawStatic() {
  const t0 = performance.now();
  const g = $('paths').getContext('2d');
  g.setTransform(1, 0, 0, 1, 0, 0);
  g.fillStyle = '#f4f4f0';
  g.fillRect(0, 0, view.w, view.h);
  let n = 0;
  const px = view.dpr;
  if (view.mode === 'hybrid') { n = drawGuardStatic(g); }
  else if (view.job) {
    const j = view.job;
    g.strokeStyle = '#b0b0a8'; g.lineWidth = px;
    g.strokeRect(sx(0), sy(j.travel_mm[1]), view.scale * j.travel_mm[0], view.scale * j.travel_mm[1]);
    g.fillStyle = 'rgba(30,90,168,0.10)';
    for (const p of j.parts) { g.beginPath(); n += polyline(g, p, true); g.fill(); }
    g.setLineDash([4 * px, 4 * px]); g.strokeStyle = '#8a8a8a'; g.lineWidth = px;
    g.beginPath();
    for (const p of j.paths) if (p.kind !== 'cut') n += polyline(g, p.points, false);
    g.stroke();
    g.setLineDash([]); g.strokeStyle = '#1e5aa8'; g.lineWidth = 1.5 * px;
    g.beginPath();
    for (const p of j.paths) if (p.kind === 'cut') n += polyline(g, p.points, false);
    g.stroke();
    g.fillStyle = '#c62828';
    for (const p of j.pierces) { g.beginPath(); g.arc(sx(p[0]), sy(p[1]), 3 * px, 0, 2 * Math.PI); g.fill(); }
  }
  trailDrawn = 0;
  drawTrail();
  stats.staticDrawMs = performance.now() - t0;
  stats.staticPoints = n;
  liveDirty = true;
}

// The cut so far: only what came since the last call is drawn.
function drawTrail() {
  if (view.mode !== 'job') return;
  const g = $('paths').getContext('2d');
  g.strokeStyle = '#e65100'; g.lineWidth = 2.5 * view.dpr; g.lineCap = 'round';
  g.beginPath();
  for (let i = Math.max(1, trailDrawn); i < trail.length; i++) {
    const a = trail[i - 1], b = trail[i];
    if (!a || !b) continue;
    g.moveTo(sx(a[0]), sy(a[1])); g.lineTo(sx(b[0]), sy(b[1]));
  }
  g.stroke();
  trailDrawn = trail.length;
}

function addTrail(f) {
  const p = f.position_mm;
  if (f.torch && f.arc_ok !== false && (f.state === 'running' || f.state === 'held')) {
    const last = trail[trail.length - 1];
    if (!last || Math.hypot(p[0] - last[0], p[1] - last[1]) * view.scale > 0.7) trail.push([p[0], p[1]]);
  } else if (trail.length && trail[trail.length - 1] !== null) {
    trail.push(null);
  }
}

function drawLive() {
  requestAnimationFrame(drawLive);
  if (!liveDirty || !live) return;
  liveDirty = false;
  drawTrail();
  const g = $('live').getContext('2d');
  g.setTransform(1, 0, 0, 1, 0, 0);
  g.clearRect(0, 0, view.w, view.h);
  const px = view.dpr;
  let p = live.position_mm;
  if (view.mode === 'hybrid' && live.guard) p = live.guard.position_mm;
  const x = sx(p[0]), y = sy(p[1]);
  if (view.mode === 'hybrid' && view.guard) {
    g.strokeStyle = '#000'; g.lineWidth = 2 * px;
    g.beginPath(); g.arc(x, y, Math.max(3 * px, view.scale * view.guard.tool_radius_mm), 0, 2 * Math.PI); g.stroke();
  }
  g.strokeStyle = live.torch ? '#e65100' : '#000';
  g.lineWidth = 2 * px;
  g.beginPath(); g.arc(x, y, 7 * px, 0, 2 * Math.PI); g.stroke();
  g.beginPath(); g.moveTo(x - 12 * px, y); g.lineTo(x + 12 * px, y); g.moveTo(x, y - 12 * px); g.lineTo(x, y + 12 * px); g.stroke();
  if (live.torch) { g.fillStyle = 'rgba(230,81,0,0.5)'; g.beginPath(); g.arc(x, y, 5 * px, 0, 2 * Math.PI); g.fill(); }
}

// ---- hybrid ------------------------------------------------------------------------------------
function guardBox(d) {
  let b = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
  for (const set of [d.profile, d.boundary]) for (const c of set) for (let i = 0; i < c.length; i += 2) {
    b.x0 = Math.min(b.x0, c[i]); b.x1 = Math.max(b.x1, c[i]); b.y0 = Math.min(b.y0, c[i + 1]); b.y1 = Math.max(b.y1, c[i + 1]);
  }
  const m = 40;
  return { x0: b.x0 - m, y0: b.y0 - m, x1: b.x1 + m, y1: b.y1 + m };
}
function drawGuardStatic(g) {
  const d = view.guard;
  if (!d) return 0;
  let n = 0;
  const px = view.dpr;
  g.fillStyle = 'rgba(198,40,40,0.18)';           // the prohibited region: inside the boundary (outside machining)
  g.strokeStyle = '#c62828'; g.lineWidth = 1.5 * px; g.setLineDash([6 * px, 4 * px]);
  for (const c of d.boundary) { g.beginPath(); n += polyline(g, c, true); if (d.side === 'outside') g.fill(); g.stroke(); }
  g.setLineDash([]);
  g.fillStyle = 'rgba(60,60,60,0.25)'; g.strokeStyle = '#222'; g.lineWidth = 2 * px;
  for (const c of d.profile) { g.beginPath(); n += polyline(g, c, true); if (d.side === 'outside') g.fill(); g.stroke(); }
  if (d.attempts) {
    for (const a of d.attempts) { g.strokeStyle = a.success ? 'rgba(46,125,50,0.7)' : '#b71c1c'; g.lineWidth = px; g.beginPath(); n += polyline(g, a.points, false); g.stroke(); }
  }
  if (d.finish_paths) {
    for (const f of d.finish_paths) { g.strokeStyle = '#1e5aa8'; g.lineWidth = 2 * px; g.beginPath(); n += polyline(g, f.points, false); g.stroke(); }
  }
  return n;
}

// ---- live stream and status ---------------------------------------------------------------------
function fmt(v, d) { return (typeof v === 'number' && isFinite(v)) ? v.toFixed(d) : '-'; }
function showState(s, cls) {
  const el = $('state');
  el.textContent = s;
  el.className = 'state ' + (cls || s);
}
function showProgress(p) {
  $('progress-bar').style.width = (100 * p).toFixed(1) + '%';
  $('progress-text').textContent = (p >= 1 ? '100' : (100 * p).toFixed(1)) + ' %';
}
function onFrame(f) {
  live = f;
  stats.frames++;
  stats.lastFrame = f;
  liveDirty = true;
  addTrail(f);
  showState(f.estop && f.activity === 'idle' ? 'e-stop' : f.state === 'idle' && lastStatus ? lastStatus.state : f.state);
  $('dro-x').textContent = fmt(f.position_mm[0], 3);
  $('dro-y').textContent = fmt(f.position_mm[1], 3);
  $('dro-line').textContent = f.line > 0 ? f.line : '-';
  $('dro-feed').textContent = fmt(f.feed_mm_per_s, 1);
  $('dro-torch').textContent = f.torch ? (f.arc_ok ? 'ON arc' : 'ON') : 'off';
  $('dro-height').textContent = fmt(f.height_mm, 2);
  $('dro-thc').textContent = f.thc_active ? ('on ' + fmt(f.arc_voltage_v, 1) + ' V') : (f.arc_voltage_v ? fmt(f.arc_voltage_v, 1) + ' V' : '-');
  if (f.activity === 'running') {
    showProgress(f.progress);
    $('time-left').textContent = f.state === 'held' ? 'held, ' + fmtTime(f.time_left_s) + ' left' : fmtTime(f.time_left_s) + ' left';
    // What the machine makes of the feed override: above 100 % only where its limits leave room.
    const eff = f.feed_effective_pct;
    if (Math.abs(eff - f.feed_pct) >= 0.5) $('feed-val').textContent = `${f.feed_pct.toFixed(0)} % (runs at ${eff.toFixed(0)} %)`;
    else if ($('feed-val').textContent.includes('runs at')) $('feed-val').textContent = f.feed_pct.toFixed(0) + ' %';
  }
  if (f.guard) {
    $('g-phase').textContent = f.guard.phase;
    $('g-dist').textContent = fmt(f.guard.distance_mm, 2);
    $('g-hold').textContent = f.guard.holding ? 'HOLDING' : 'free';
    $('g-strokes').textContent = f.guard.strokes;
  }
}
function fmtTime(s) {
  if (!(s >= 0)) return '-';
  const m = Math.floor(s / 60), r = Math.round(s - 60 * m);
  return m > 0 ? `${m} min ${r} s` : `${(Math.round(s * 10) / 10).toFixed(1)} s`;
}

let ws = null;
function connect() {
  ws = new WebSocket(`ws://${location.host}/api/live`);
  ws.onopen = () => { $('link').textContent = 'live'; $('link').className = 'link on'; };
  ws.onmessage = (e) => { try { onFrame(JSON.parse(e.data)); } catch (err) { /* a broken frame is skipped */ } };
  ws.onclose = () => { $('link').textContent = 'offline'; $('link').className = 'link off'; setTimeout(connect, 1000); };
}

let lastStatus = null, shownJob = 0, shownReport = false, lastActivity = 'idle';
async function poll() {
  try {
    const s = await api('GET', '/status');
    lastStatus = s;
    linked(true);
    $('machine').textContent = s.machine + ' (' + s.backend + ')';
    const c = $('control');
    c.textContent = s.control.yours ? 'You have control' : s.control.held ? 'Take control (another client has it)' : 'Take control';
    c.classList.toggle('yours', s.control.yours);
    for (const id of ['load', 'run', 'frame', 'hold', 'resume', 'stop', 'reset', 'g-start', 'g-end']) $(id).disabled = !s.control.yours;
    // Greyed-out buttons say why, next to them.
    const why = s.control.yours ? ''
      : s.control.held ? 'Another client has control: Take control (top right) to load and run from here.'
                       : 'Take control (top right) to load and run: no client has it.';
    for (const el of document.querySelectorAll('.why')) { el.textContent = why; el.classList.toggle('hidden', !why); }
    // The banner shows what is in force now: a latched E-stop before the faults it caused or
    // followed; the server drops the faults when they are reset.
    const fb = $('fault');
    const f = s.faults && s.faults.length ? s.faults[0] : null;
    if (s.estop) {
      fb.textContent = 'E-STOP latched (fault estop' + (f && f.kind === 'estop' && f.line ? ' at line ' + f.line : '') +
                       '): the machine is stopped; Reset to go on';
      fb.classList.remove('hidden');
    } else if (f) {
      fb.textContent = 'FAULT ' + f.kind + (f.line ? ' at line ' + f.line : '') + ': ' + f.message;
      fb.classList.remove('hidden');
    } else fb.classList.add('hidden');
    if (s.job_id !== shownJob && s.job_id > 0) await loadDrawing();
    if (s.activity === 'running' && lastActivity !== 'running') { trail.length = 0; drawStatic(); shownReport = false; $('report-box').classList.add('hidden'); }
    if (s.activity === 'idle' && s.report_available && !shownReport) await showReport();
    if (s.activity === 'idle') {
      showState(s.estop ? 'e-stop' : s.state);
      showProgress(s.progress);  // a run that ended done is all done (100 %)
      if (s.state === 'done') $('time-left').textContent = 'done';
    }
    if (s.guard && view.mode === 'hybrid' && s.guard.phase === 'done' && !view.guardDone) { view.guardDone = true; await loadGuard(); }
    lastActivity = s.activity;
  } catch (e) {
    // Offline (the next poll tries again), or no longer authorised (api() said so).
    if ($('login').classList.contains('hidden')) linked(false, 'offline');
  }
  setTimeout(poll, 500);
}

async function loadDrawing() {
  const j = await act('GET', '/job');
  if (!j) return;
  view.job = j;
  shownJob = j.job_id;
  stats.jobMoves = j.moves;
  trail.length = 0;
  $('job-info').textContent = `${j.source.split('/').pop()}: ${j.moves} moves, about ${fmtTime(j.estimate_s)}`;
  fit();
}

async function showReport() {
  shownReport = true;
  const r = await act('GET', '/report');
  if (!r) return;
  $('report-box').classList.remove('hidden');
  const ending = r.summary.status;  // done, faulted, cancelled, deadline
  $('report-summary').innerHTML = '';
  const lines = [
    `${ending === 'done' ? 'done' : ending.toUpperCase()}: ${r.source.split('/').pop()}${r.summary.message ? ' (' + r.summary.message + ')' : ''}`,
    `cycle time ${fmt(r.cycle_time_s, 2)} s (lower bound ${fmt(r.lower_bound_s, 2)} s)`,
    `contour error max ${fmt(r.max_contour_error_mm, 4)} mm, rms ${fmt(r.rms_contour_error_mm, 4)} mm`,
    `holds ${(r.holds || []).length}, torch off at the end: ${r.torch_off_at_end ? 'yes' : 'NO'}`,
  ];
  for (const l of lines) { const d = document.createElement('div'); d.textContent = l; $('report-summary').appendChild(d); }
  $('report-json').textContent = JSON.stringify(r, null, 1);
  $('report-box').scrollIntoView({ block: 'nearest' });
}

async function loadGuard() {
  const d = await act('GET', '/guard');
  if (!d) return;
  view.guard = d;
  if (d.report) $('g-report').textContent = d.report;
  fit();
}

// ---- commands ----------------------------------------------------------------------------------
function wire() {
  $('estop').onclick = () => act('POST', '/estop');
  $('consumables').onclick = async () => {
    if (!confirm('Consumables changed: start the counters since the change again?')) return;
    const r = await act('POST', '/consumables', {});
    if (r) showStatistics(r.statistics);
  };
  $('control').onclick = () => act('POST', '/control', { take: true });
  $('frame').onclick = async () => {
    const laser = $('frame-laser').checked;
    const r = await act('POST', '/frame', laser ? { laser: true } : {});
    if (r && r.frame) {
      const f = r.frame, mm = (v) => v.toFixed(1);
      say(`framing X ${mm(f.x_mm[0])} .. ${mm(f.x_mm[1])}, Y ${mm(f.y_mm[0])} .. ${mm(f.y_mm[1])} mm at ${mm(f.feed_mm_per_s)} mm/s, torch off${laser ? ', traced by the laser pointer' : ''}`);
    }
  };
  $('run').onclick = () => { const l = parseInt($('from-line').value, 10); act('POST', '/run', l > 0 ? { from_line: l } : {}); };
  $('hold').onclick = () => act('POST', '/hold');
  $('resume').onclick = () => act('POST', '/resume');
  $('stop').onclick = () => act('POST', '/stop');
  $('reset').onclick = () => act('POST', '/reset');
  for (const b of document.querySelectorAll('.paused')) b.onclick = () => act('POST', '/paused_motion', { mm: Number(b.dataset.mm) });
  // Held: the speed every 100 ms while pressed (the server falls back to 0 300 ms after the last), 0 on release.
  for (const b of document.querySelectorAll('.paused-hold')) {
    let timer = null;
    const send = (speed) => act('POST', '/paused_motion', { speed });
    b.onpointerdown = () => { send(Number(b.dataset.speed)); clearInterval(timer); timer = setInterval(() => send(Number(b.dataset.speed)), 100); };
    b.onpointerup = b.onpointerleave = () => { if (timer) { clearInterval(timer); timer = null; send(0); } };
  }
  $('thc').onchange = () => act('POST', '/thc', { enabled: $('thc').checked });
  $('torch-enable').onchange = () => act('POST', '/torch', { enabled: $('torch-enable').checked });
  $('feed').oninput = () => { $('feed-val').textContent = $('feed').value + ' %'; };
  $('feed').onchange = () => act('POST', '/override', { feed: Number($('feed').value) });
  for (const b of document.querySelectorAll('.rapid')) b.onclick = () => { $('rapid-val').textContent = b.dataset.v + ' %'; act('POST', '/override', { rapid: Number(b.dataset.v) }); };
  // Sheet alignment: the two edge points are where the machine stands when taken (after a jog).
  const showEdge = () => {
    for (const i of [0, 1]) $('edge-' + (i + 1) + '-at').textContent = edge[i] ? `${fmt(edge[i][0], 3)}, ${fmt(edge[i][1], 3)}` : '-';
  };
  for (const i of [0, 1]) $('edge-' + (i + 1)).onclick = () => {
    if (!live) return say('no position yet: the machine has not reported one');
    edge[i] = [live.position_mm[0], live.position_mm[1]];
    showEdge();
  };
  $('edge-clear').onclick = () => { edge[0] = edge[1] = null; showEdge(); };
  $('load').onclick = async () => {
    const body = {};
    const f = $('file').files[0];
    if (f) { body.program = await f.text(); body.name = f.name; }
    else body.program = $('path').value.trim();
    const x = $('origin-x').value, y = $('origin-y').value;
    if (x !== '' && y !== '') body.origin = [Number(x), Number(y)];
    if (edge[0] && edge[1]) body.align = [edge[0], edge[1]];  // the server refuses it beside an origin
    const m = $('materials').files[0];
    if (m) body.materials = await m.text();  // a QtPlasmaC material file, as run --materials
    if ($('material').value !== '') body.material = parseInt($('material').value, 10);
    const r = await act('POST', '/job', body);
    if (r) {
      const turned = r.origin_from === 'sheet alignment' ? `, aligned to the sheet's edge (turned ${fmt(r.rotation_deg, 3)} deg)` : '';
      say(`loaded ${r.source}: ${r.steps} steps, about ${fmtTime(r.estimate_s)}${turned}`);
      await loadDrawing();
    }
  };
  for (const t of document.querySelectorAll('.tab')) t.onclick = () => {
    for (const o of document.querySelectorAll('.tab')) o.classList.toggle('active', o === t);
    for (const p of ['job', 'hybrid', 'history']) $('tab-' + p).classList.toggle('hidden', p !== t.dataset.tab);
    view.mode = t.dataset.tab === 'hybrid' ? 'hybrid' : 'job';
    if (t.dataset.tab === 'history') loadHistory();
    if (view.mode === 'hybrid') loadGuard(); else fit();
  };
  // Jog: held buttons and keys send the stick every 100 ms (the server centres it 300 ms after the last).
  for (const b of document.querySelectorAll('.jog button')) {
    const [x, y] = b.dataset.j.split(',').map(Number);
    b.onpointerdown = () => { stickSet(x, y); };
    b.onpointerup = b.onpointerleave = () => { stickSet(0, 0); };
  }
  const keys = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] };
  const down = new Set();
  const fromKeys = () => { let x = 0, y = 0; for (const k of down) { x += keys[k][0]; y += keys[k][1]; } stickSet(Math.max(-1, Math.min(1, x)), Math.max(-1, Math.min(1, y))); };
  addEventListener('keydown', (e) => { if (keys[e.key] && !(e.target instanceof HTMLInputElement)) { down.add(e.key); fromKeys(); e.preventDefault(); } });
  addEventListener('keyup', (e) => { if (keys[e.key]) { down.delete(e.key); fromKeys(); } });
  addEventListener('blur', () => { down.clear(); stickSet(0, 0); });
  // The on-screen stick.
  const st = $('stick'), knob = $('knob');
  const fromPointer = (e) => {
    const r = st.getBoundingClientRect();
    let x = (e.clientX - r.left - r.width / 2) / (r.width / 2), y = -(e.clientY - r.top - r.height / 2) / (r.height / 2);
    const n = Math.hypot(x, y); if (n > 1) { x /= n; y /= n; }
    knob.style.left = (62 + 62 * x) + 'px'; knob.style.top = (62 - 62 * y) + 'px';
    stickSet(x, y);
  };
  st.onpointerdown = (e) => { st.setPointerCapture(e.pointerId); fromPointer(e); };
  st.onpointermove = (e) => { if (e.buttons) fromPointer(e); };
  st.onpointerup = () => { knob.style.left = knob.style.top = '62px'; stickSet(0, 0); };
  $('g-start').onclick = async () => {
    const body = { profile: $('g-profile').value.trim(), side: $('g-side').value, tool_radius_mm: Number($('g-radius').value),
                   tolerance_mm: Number($('g-tol').value), feed_mm_per_s: Number($('g-feed').value), finish: $('g-finish').checked };
    const r = await act('POST', '/guard', body);
    if (r) { view.guardDone = false; $('g-report').textContent = ''; await loadGuard(); }
  };
  $('g-end').onclick = () => act('POST', '/resume');   // cycle start ends the manual part
  addEventListener('resize', fit);
}

// One stick for keys, buttons, the on-screen stick and a gamepad; sent while deflected.
const stick = { x: 0, y: 0, sentZero: true };
function stickSet(x, y) { stick.x = x; stick.y = y; sendStick(); }
function sendStick() {
  const moving = Math.hypot(stick.x, stick.y) > 0.02;
  if (!moving && stick.sentZero) return;
  stick.sentZero = !moving;
  fetch('/api/jog', { method: 'POST', credentials: 'same-origin',
                      headers: { 'Content-Type': 'application/json', 'X-Machplan-Client': clientId },
                      body: JSON.stringify({ x: moving ? stick.x : 0, y: moving ? stick.y : 0 }) }).catch(() => {});
}
setInterval(() => {
  // The Gamepad API: the first pad's left stick (its Y grows downward).
  const pads = navigator.getGamepads ? navigator.getGamepads() : [];
  for (const p of pads) {
    if (!p || p.axes.length < 2) continue;
    const x = Math.abs(p.axes[0]) > 0.1 ? p.axes[0] : 0, y = Math.abs(p.axes[1]) > 0.1 ? -p.axes[1] : 0;
    if (x || y || stick.padActive) { stick.padActive = !!(x || y); stick.x = x; stick.y = y; }
    break;
  }
  sendStick();
}, 100);

async function loadHistory() {
  const h = await act('GET', '/history');
  if (!h) return;
  const fill = (id, rows) => {
    const tb = $(id).querySelector('tbody');
    tb.innerHTML = '';
    for (const r of rows) { const tr = document.createElement('tr'); for (const c of r) { const td = document.createElement('td'); td.textContent = c; tr.appendChild(td); } tb.appendChild(tr); }
  };
  fill('h-cal', h.calibrations.map((c) => [c.fit_id, c.machine, c.created_utc, c.feed_factor.map((v) => v.toFixed(3)).join(' / '), c.backlash_mm.map((v) => v.toFixed(3)).join(' / '), c.active ? 'active' : '']));
  fill('h-tun', h.tunings.map((t) => [t.id, t.machine, t.controller, t.created_utc, t.active ? 'active' : '']));
  $('h-store').textContent = 'store: ' + h.store + (h.calibrations.length + h.tunings.length ? '' : ' (nothing stored)');
  showStatistics(await act('GET', '/statistics'));
}

// The machine's counters: the last job, since the last consumable change, lifetime.
function showStatistics(s) {
  if (!s) return;
  const row = (label, f) => [label, f.jobs, f.pierces, f.arc_on_s.toFixed(1), f.cycle_s.toFixed(1), (f.cut_mm / 1000).toFixed(2), (f.rapid_mm / 1000).toFixed(2), `${f.probes} (${f.probes_skipped})`, f.faults];
  const rows = [];
  if (s.jobs.length) rows.push(row('last job: ' + s.jobs[0].status, s.jobs[0].figures));
  rows.push(row('since change', s.since_change), row('lifetime', s.lifetime));
  const tb = $('h-stats').querySelector('tbody');
  tb.innerHTML = '';
  for (const r of rows) { const tr = document.createElement('tr'); for (const c of r) { const td = document.createElement('td'); td.textContent = c; tr.appendChild(td); } tb.appendChild(tr); }
  $('h-change').textContent = s.last_change ? `consumables changed ${s.last_change.utc} by ${s.last_change.who}` : 'consumables never changed';
}

(async () => {
  wire();
  fit();
  requestAnimationFrame(drawLive);
  if (await login()) { connect(); poll(); }
})();
