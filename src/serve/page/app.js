// isoview serve: the page. Plain JavaScript, no build step. It keeps the view state as the
// list of `--set` overrides (plus the time), posts it whole to /api/state on every change
// (latest wins on the server), and long-polls /api/frame for coarse and full frames.
'use strict';

const TOKEN = new URLSearchParams(location.search).get('token') || '';
const HEADERS = { 'X-Isoview-Token': TOKEN };
const $ = (id) => document.getElementById(id);

const view = {
  info: null,          // GET /api/state
  sets: new Map(),     // key -> value (TOML syntax), in insertion order
  time: 0,
  shown: { gen: 0, level: 'full', stride: 1 },
  aov: null,           // { gen, width, height, planes: {name: Float32Array} }
  camera: null,        // { eye, target, up, fov }
  homeCamera: null,
  probePixel: null,
  playing: false,
};

// ---- small helpers ----
const fmt = (x, p = 6) => (typeof x === 'number' ? (Number.isInteger(x) ? String(x) : Number(x.toPrecision(p)).toString()) : String(x));
const vec = (v) => '[' + v.map((x) => fmt(x, 9)).join(', ') + ']';
const sub = (a, b) => a.map((x, i) => x - b[i]);
const add = (a, b) => a.map((x, i) => x + b[i]);
const mul = (a, s) => a.map((x) => x * s);
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => mul(a, 1 / Math.hypot(...a));

function showError(message) {
  const e = $('error');
  e.textContent = message || '';
  e.hidden = !message;
}

// A 503 with Retry-After is the server saying it is busy (another state being loaded, too
// many requests waiting for frames): wait as it says and ask again, a minute at most.
async function api(path, options = {}) {
  for (let tries = 0; ; tries++) {
    const r = await fetch(path, { ...options, headers: { ...HEADERS, ...(options.headers || {}) } });
    const wait = Number(r.headers.get('Retry-After'));
    if (r.status !== 503 || !wait || tries >= 60) return r;
    await new Promise((ok) => setTimeout(ok, wait * 1000));
  }
}

async function errorText(r) {
  try { return (await r.json()).error; } catch (_) { return `HTTP ${r.status}`; }
}

function setList() {
  return [...view.sets].map(([k, v]) => `${k}=${v}`);
}

function shellQuote(s) {
  return /^[A-Za-z0-9_\-./=,:+@%]+$/.test(s) ? s : `'${s.replace(/'/g, `'\\''`)}'`;
}

function commandLine() {
  const words = ['isoview', 'render', shellQuote(view.info.scene), '-o', 'out.exr'];
  for (const s of setList()) words.push('--set', shellQuote(s));
  if (view.time) words.push('--time', fmt(view.time));
  return words.join(' ');
}

// ---- sending the state (one request in flight; the latest change wins) ----
let inFlight = false;
let pending = null;

function sendState(preview) {
  pending = { set: setList(), time: view.time, preview };
  $('command').textContent = commandLine();
  history.replaceState(null, '', location.pathname + location.search + '#' +
    encodeURIComponent(JSON.stringify({ set: pending.set, time: view.time })));
  pump();
}

async function pump() {
  if (inFlight || !pending) return;
  const body = pending;
  pending = null;
  inFlight = true;
  try {
    const r = await api('/api/state', { method: 'POST', body: JSON.stringify(body) });
    if (r.ok) showError('');
    else showError(await errorText(r));
  } catch (e) {
    showError(`cannot reach the server: ${e}`);
  } finally {
    inFlight = false;
    pump();
  }
}

function setKey(key, value, preview = false) {
  view.sets.set(key, value);
  sendState(preview);
}

// ---- frames: long-poll for anything newer than what is shown ----
async function pollFrames() {
  for (;;) {
    let r;
    try {
      r = await api(`/api/frame?after=${view.shown.gen}&level=${view.shown.level}`);
    } catch (e) {
      showError(`cannot reach the server: ${e}`);
      await new Promise((ok) => setTimeout(ok, 1000));
      continue;
    }
    if (r.status === 204) continue;
    if (r.status === 503) {
      // The server is busy (too many tabs waiting): ask again in a moment.
      await new Promise((ok) => setTimeout(ok, Number(r.headers.get('Retry-After') || 1) * 1000));
      continue;
    }
    const gen = Number(r.headers.get('X-Isoview-Generation') || view.shown.gen);
    if (!r.ok) {
      showError(await errorText(r));
      view.shown = { gen, level: 'full', stride: 1 };
      continue;
    }
    const level = r.headers.get('X-Isoview-Level');
    const bitmap = await createImageBitmap(await r.blob());
    const [w, h] = (r.headers.get('X-Isoview-Image') || '1x1').split('x').map(Number);
    const stride = level === 'coarse' ? Math.max(1, Math.round(w / bitmap.width)) : 1;
    drawFrame(bitmap, w, h, stride);
    view.shown = { gen, level, stride };
    showTimings(r, bitmap.width * bitmap.height, level);
    if (level === 'full') loadAov(gen);
    if (view.playing) stepTime();
  }
}

function drawFrame(bitmap, w, h, stride) {
  const c = $('image');
  if (c.width !== w || c.height !== h) {
    c.width = w;
    c.height = h;
    $('overlay').width = w;
    $('overlay').height = h;
  }
  const g = c.getContext('2d');
  g.imageSmoothingEnabled = false;
  g.clearRect(0, 0, w, h);
  // Coarse pixel (i, j) is image pixel (s i, s j): draw it over the s x s block it starts.
  g.drawImage(bitmap, 0, 0, bitmap.width * stride, bitmap.height * stride);
  drawOverlay();
}

function showTimings(r, pixels, level) {
  const gpu = r.headers.get('X-Isoview-Gpu-Ms');
  const wall = Number(r.headers.get('X-Isoview-Render-Ms'));
  const ms = gpu ? Number(gpu) : wall;
  const rays = ms > 0 ? (pixels / (ms / 1000) / 1e6).toFixed(2) : '?';
  $('timings').textContent =
    `${level} #${r.headers.get('X-Isoview-Generation')}  GPU ${gpu ? Number(gpu).toFixed(1) + ' ms' : 'n/a'}  ` +
    `render ${wall.toFixed(1)} ms  ${rays} Mrays/s`;
}

// ---- hover: values of the full frame under the cursor ----
const AOV_CHANNELS = ['Z', 'N.X', 'N.Y', 'N.Z', 'steps', 'cell.X', 'cell.Y', 'cell.Z'];

async function loadAov(gen) {
  const r = await api('/api/aov?ch=' + AOV_CHANNELS.join(','));
  if (!r.ok) return;
  const w = Number(r.headers.get('X-Isoview-Width'));
  const h = Number(r.headers.get('X-Isoview-Height'));
  const all = new Float32Array(await r.arrayBuffer());
  const planes = {};
  AOV_CHANNELS.forEach((c, i) => { planes[c] = all.subarray(i * w * h, (i + 1) * w * h); });
  view.aov = { gen: Number(r.headers.get('X-Isoview-Generation')), width: w, height: h, planes };
}

function pixelAt(ev) {
  const c = $('image');
  const rect = c.getBoundingClientRect();
  let x = Math.floor((ev.clientX - rect.left) * c.width / rect.width);
  let y = Math.floor((ev.clientY - rect.top) * c.height / rect.height);
  x = Math.min(Math.max(x, 0), c.width - 1);
  y = Math.min(Math.max(y, 0), c.height - 1);
  // On a coarse frame, the pixel shown is the one at the block's corner.
  const s = view.shown.stride;
  return [s * Math.floor(x / s), s * Math.floor(y / s)];
}

function showHover(ev) {
  const [x, y] = pixelAt(ev);
  const a = view.aov;
  if (!a || a.gen !== view.shown.gen || x >= a.width || y >= a.height) {
    $('hover').textContent = `pixel (${x}, ${y})  (values once the full frame is in)`;
    return;
  }
  const i = y * a.width + x;
  const p = a.planes;
  const z = p.Z[i];
  $('hover').textContent = `pixel (${x}, ${y})  ` + (Number.isFinite(z)
    ? `Z ${fmt(z)}  N (${fmt(p['N.X'][i], 4)}, ${fmt(p['N.Y'][i], 4)}, ${fmt(p['N.Z'][i], 4)})  ` +
      `steps ${p.steps[i]}  cell [${p['cell.X'][i]}, ${p['cell.Y'][i]}, ${p['cell.Z'][i]}]`
    : `miss  steps ${p.steps[i]}`);
}

// ---- probe panel ----
async function probe(x, y) {
  view.probePixel = [x, y];
  drawOverlay();
  const r = await api(`/api/probe?x=${x}&y=${y}`);
  if (!r.ok) { $('probe').textContent = await errorText(r); return; }
  renderProbe(await r.json());
}

function esc(s) {
  return String(s).replace(/[&<>]/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;' }[c]));
}

function renderProbe(p) {
  const a = p.analytic;
  const f = p.fixed_step;
  const list = (v) => (v || []).map((x) => fmt(x)).join(', ');
  let html = `<div>pixel (${p.pixel[0]}, ${p.pixel[1]}) of ${p.image[0]}x${p.image[1]}, ` +
    `isovalue ${fmt(p.isovalue)}, inside ${p.inside}</div>`;
  html += `<div>ray ${vec(p.ray.origin)} → ${vec(p.ray.direction)}; box ` +
    (p.box_span ? `t ∈ [${fmt(p.box_span[0])}, ${fmt(p.box_span[1])}]` : 'missed') + '</div>';
  html += `<div><b>analytic</b> (Newton steps ${a.newton_steps}): ${a.crossings} crossing(s), ` +
    `${a.cells_visited} cell(s) visited, ` +
    (a.hit ? `<span class="hit">hit t = ${fmt(a.hit.t, 9)} in cell [${a.hit.cell.join(', ')}] at ${vec(a.hit.position)}</span>`
      : '<span class="miss">no hit</span>') + '</div>';
  html += '<table><tr><th>cell</th><th>t in, out</th><th>corners v000 v100 v010 v110 v001 v101 v011 v111</th>' +
    '<th>cubic g(u) = c0 + c1 u + c2 u² + c3 u³</th><th>g\'(u) = 0</th><th>roots u (t) and Newton iterates</th></tr>';
  for (const c of a.cells) {
    const roots = c.roots.map((r) => `#${r.crossing} u=${fmt(r.u, 9)} (t=${fmt(r.t, 9)}, ${r.entering ? 'entering' : 'leaving'})` +
      `<br>&nbsp;&nbsp;iterates ${list(r.newton_iterates)}`).join('<br>');
    html += `<tr><td>[${c.cell.join(', ')}]</td><td>${fmt(c.t[0])}, ${fmt(c.t[1])}</td>` +
      `<td>${list(c.corners)}</td><td>${list(c.cubic || c.bernstein)}</td><td>${list(c.derivative_roots)}</td>` +
      `<td style="text-align:left">${roots || '—'}</td></tr>`;
  }
  html += '</table>';
  html += `<div><b>fixed-step</b> (steps ${f.steps}, ${f.samples_taken} samples): ` +
    (f.hit ? `<span class="hit">first crossing t = ${fmt(f.hit.t, 9)} in cell [${f.hit.cell.join(', ')}]</span>`
      : `<span class="miss">${esc(f.miss)}</span>`) + '</div>';
  if (a.hit && !f.hit) html += '<div class="miss">fixed-step MISSES a surface that the exact trace hits</div>';
  if (p.hit_distance !== null) html += `<div>hits ${fmt(p.hit_distance)} apart</div>`;
  html += `<details><summary>probe --json</summary><pre>${esc(JSON.stringify(p, null, 2))}</pre></details>`;
  $('probe').innerHTML = html;
}

// ---- camera: orbit, pan, zoom ----
function cameraFromInfo(info) {
  const c = info.camera;
  return {
    eye: c.eye.slice(), target: c.target.slice(), up: c.up.slice(), fov: c.fov_y_deg,
    ortho: c.projection === 'orthographic', orthoHeight: c.ortho_height,
  };
}

function sendCamera(preview) {
  const c = view.camera;
  view.sets.set('camera.eye', vec(c.eye));
  view.sets.set('camera.target', vec(c.target));
  view.sets.set('camera.up', vec(c.up));
  if (c.ortho) view.sets.set('camera.ortho_height', fmt(c.orthoHeight, 9));
  sendState(preview);
  drawOverlay();
}

function basis(c) {
  const f = norm(sub(c.target, c.eye));
  const r = norm(cross(f, c.up));
  const u = cross(r, f);
  return { f, r, u };
}

function orbit(dx, dy) {
  const c = view.camera;
  const up = norm(c.up);
  let off = sub(c.eye, c.target);
  const rot = (v, axis, ang) => {
    const k = norm(axis);
    const cos = Math.cos(ang), sin = Math.sin(ang);
    return add(add(mul(v, cos), mul(cross(k, v), sin)), mul(k, dot(k, v) * (1 - cos)));
  };
  off = rot(off, up, -dx * 0.01);
  const right = norm(cross(off, up));
  const next = rot(off, right, dy * 0.01);
  // Stay off the poles (the up vector must not be parallel to the view).
  if (Math.abs(dot(norm(next), up)) < 0.995) off = next;
  c.eye = add(c.target, off);
}

function pan(dx, dy) {
  const c = view.camera;
  const { r, u } = basis(c);
  const dist = Math.hypot(...sub(c.eye, c.target));
  const height = c.ortho ? c.orthoHeight : 2 * dist * Math.tan(c.fov * Math.PI / 360);
  const s = height / $('image').getBoundingClientRect().height;
  const move = add(mul(r, -dx * s), mul(u, dy * s));
  c.eye = add(c.eye, move);
  c.target = add(c.target, move);
}

function zoom(factor) {
  const c = view.camera;
  // An orthographic view zooms by its height; moving the eye would change nothing.
  if (c.ortho) c.orthoHeight *= factor;
  else c.eye = add(c.target, mul(sub(c.eye, c.target), factor));
}

function wireCamera() {
  const img = $('image');
  let drag = null;
  img.addEventListener('contextmenu', (e) => e.preventDefault());
  img.addEventListener('pointerdown', (e) => {
    drag = { x: e.clientX, y: e.clientY, moved: false, pan: e.shiftKey || e.button !== 0 };
    img.setPointerCapture(e.pointerId);
  });
  img.addEventListener('pointermove', (e) => {
    showHover(e);
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (!drag.moved && Math.hypot(dx, dy) < 3) return;
    drag.moved = true;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.pan) pan(dx, dy); else orbit(dx, dy);
    sendCamera(true);
  });
  img.addEventListener('pointerup', (e) => {
    if (drag && !drag.moved && e.button === 0) probe(...pixelAt(e));
    drag = null;
  });
  img.addEventListener('wheel', (e) => {
    e.preventDefault();
    zoom(Math.exp(e.deltaY * 0.001));
    sendCamera(true);
  }, { passive: false });
  $('reset-view').addEventListener('click', () => {
    view.camera = JSON.parse(JSON.stringify(view.homeCamera));
    sendCamera(false);
  });
}

// ---- the overlay: the probed pixel and the slice plane, projected with the contract's camera ----
function project(p) {
  const c = view.camera;
  const { f, r, u } = basis(c);
  const d = sub(p, c.eye);
  const W = $('image').width, H = $('image').height, a = W / H;
  let sx, sy;
  if (c.ortho) {
    const h = c.orthoHeight / 2;
    sx = dot(d, r) / (h * a);
    sy = dot(d, u) / h;
  } else {
    const z = dot(d, f);
    if (z <= 1e-9) return null;
    const h = Math.tan(c.fov * Math.PI / 360);
    sx = dot(d, r) / (z * h * a);
    sy = dot(d, u) / (z * h);
  }
  return [(sx + 1) * 0.5 * W, (1 - sy) * 0.5 * H];
}

function slicePlaneCorners() {
  const b = view.info.field.bounds;
  const axis = 'xyz'.indexOf($('slice-axis').value);
  const at = Number($('slice-at').value);
  const [i, j] = [0, 1, 2].filter((k) => k !== axis);
  const corner = (ui, vj) => {
    const p = [0, 0, 0];
    p[axis] = at;
    p[i] = ui ? b.max[i] : b.min[i];
    p[j] = vj ? b.max[j] : b.min[j];
    return p;
  };
  return [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
}

function drawOverlay() {
  const o = $('overlay');
  const g = o.getContext('2d');
  g.clearRect(0, 0, o.width, o.height);
  if (!view.info || !view.camera) return;
  if ($('slice-on').checked) {
    const pts = slicePlaneCorners().map(project);
    if (pts.every(Boolean)) {
      g.beginPath();
      pts.forEach(([x, y], k) => (k ? g.lineTo(x, y) : g.moveTo(x, y)));
      g.closePath();
      g.fillStyle = 'rgba(80, 160, 255, 0.18)';
      g.strokeStyle = 'rgba(120, 190, 255, 0.9)';
      g.lineWidth = Math.max(1, o.width / 400);
      g.fill();
      g.stroke();
    }
  }
  if (view.probePixel) {
    const [x, y] = view.probePixel;
    g.strokeStyle = '#ff0';
    g.lineWidth = 1;
    g.strokeRect(x - 3.5, y - 3.5, 8, 8);
  }
}

// ---- the slice panel ----
let sliceToken = 0;

async function updateSlice() {
  drawOverlay();
  const on = $('slice-on').checked;
  $('slice-view').hidden = !on;
  if (!on) return;
  const mine = ++sliceToken;
  const q = `/api/slice?axis=${$('slice-axis').value}&at=${$('slice-at').value}`;
  const [png, cells, svg] = await Promise.all([api(q + '&format=png'), api(q + '&format=cells'), api(q + '&format=svg')]);
  if (mine !== sliceToken) return;
  if (png.status === 503) {
    // Too many requests wait for pictures (a fast drag): ask again in a moment, if still wanted.
    await new Promise((ok) => setTimeout(ok, Number(png.headers.get('Retry-After') || 1) * 1000));
    if (mine === sliceToken) updateSlice();
    return;
  }
  if (!png.ok) { $('slice-info').textContent = await errorText(png); return; }
  const url = URL.createObjectURL(await png.blob());
  const img = $('slice-img');
  if (img.src.startsWith('blob:')) URL.revokeObjectURL(img.src);
  img.src = url;
  const grid = await cells.json();
  $('slice-svg').innerHTML = svg.ok ? (await svg.text()).replace(/<\?xml[^>]*>/, '') : '';
  drawSliceGrid(grid);
  $('slice-info').textContent = `${grid.plane_axes[0]} right, ${grid.plane_axes[1]} up; between layers ` +
    `${grid.layer} and ${grid.layer + 1} (weight ${fmt(grid.weight, 4)}); ${grid.dims[0]}x${grid.dims[1]} points`;
}

function drawSliceGrid(grid) {
  const c = $('slice-grid');
  const [W, H] = grid.picture;
  c.width = W;
  c.height = H;
  const g = c.getContext('2d');
  const [nu, nv] = grid.dims;
  const X = (i) => (i / (nu - 1)) * W, Y = (j) => H - (j / (nv - 1)) * H;
  g.strokeStyle = 'rgba(255, 255, 255, 0.35)';
  g.lineWidth = 1;
  if (nu <= 128 && nv <= 128) {
    for (let i = 0; i < nu; i++) { g.beginPath(); g.moveTo(X(i), 0); g.lineTo(X(i), H); g.stroke(); }
    for (let j = 0; j < nv; j++) { g.beginPath(); g.moveTo(0, Y(j)); g.lineTo(W, Y(j)); g.stroke(); }
  }
  if (nu <= 24 && nv <= 24) {
    g.font = `${Math.max(10, Math.round(W / 40))}px ui-monospace, monospace`;
    g.fillStyle = '#fff';
    g.strokeStyle = '#000';
    g.lineWidth = 3;
    for (let j = 0; j < nv; j++) {
      for (let i = 0; i < nu; i++) {
        const v = fmt(grid.values[j * nu + i], 3);
        const x = Math.min(Math.max(X(i) + 3, 2), W - 8 * v.length), y = Math.min(Math.max(Y(j) - 4, 14), H - 4);
        g.strokeText(v, x, y);
        g.fillText(v, x, y);
      }
    }
  }
}

// ---- controls ----
function slider(id, key, { preview = true, format = (v) => fmt(Number(v)), out } = {}) {
  const el = $(id);
  const show = () => { if (out) $(out).textContent = fmt(Number(el.value)); };
  el.addEventListener('input', () => { show(); setKey(key, format(el.value), preview); });
  el.addEventListener('change', () => { show(); setKey(key, format(el.value), false); });
  return show;
}

function buildControls(info) {
  const f = info.field;
  const range = f.range || [-1, 1];
  const span = range[1] - range[0] || 1;
  const iso = $('isovalue');
  iso.min = range[0];
  iso.max = range[1];
  iso.step = span / 1000;
  iso.value = info.surface.isovalue;
  $('isovalue-out').textContent = fmt(info.surface.isovalue);
  $('inside').value = info.surface.inside;
  $('method').value = info.render.method;
  $('interpolation').value = info.field.interpolation;
  $('shading').value = info.render.shading;
  $('steps').value = info.render.steps;
  $('steps-out').textContent = info.render.steps;
  $('newton').value = info.render.newton_steps;
  $('newton-out').textContent = info.render.newton_steps;
  $('crossing').value = info.render.crossing;
  $('crossing-out').textContent = info.render.crossing;
  $('skip').checked = info.render.skip;
  $('occupancy').checked = info.render.occupancy;
  $('normals').value = info.render.normals;
  $('projection').value = info.camera.projection;
  $('time-box').hidden = !f.time_varying;
  $('time').value = info.time;
  $('time-out').textContent = fmt(info.time);
  const box = $('corners');
  box.innerHTML = '';
  $('corners-box').hidden = !f.corners;
  if (f.corners) {
    const names = ['v000', 'v100', 'v010', 'v110', 'v001', 'v101', 'v011', 'v111'];
    const lo = Math.min(-1, ...f.corners), hi = Math.max(1, ...f.corners);
    const values = f.corners.slice();
    names.forEach((n, k) => {
      const label = document.createElement('label');
      label.innerHTML = `${n} <output>${fmt(values[k])}</output><input type="range" min="${lo}" max="${hi}" step="${(hi - lo) / 1000}" value="${values[k]}" data-corner="${k}">`;
      const input = label.querySelector('input');
      const send = (preview) => {
        values[k] = Number(Number(input.value).toPrecision(6));
        label.querySelector('output').textContent = fmt(values[k]);
        setKey('field.values', vec(values), preview);
      };
      input.addEventListener('input', () => send(true));
      input.addEventListener('change', () => send(false));
      box.appendChild(label);
    });
  }
  const b = f.bounds;
  const axis = 'xyz'.indexOf($('slice-axis').value);
  const at = $('slice-at');
  at.min = b.min[axis];
  at.max = b.max[axis];
  at.step = (b.max[axis] - b.min[axis]) / 1000;
  if (!(Number(at.value) >= b.min[axis] && Number(at.value) <= b.max[axis])) at.value = (b.min[axis] + b.max[axis]) / 2;
  $('slice-at-out').textContent = fmt(Number(at.value));
}

function wireControls() {
  slider('isovalue', 'surface.isovalue', { out: 'isovalue-out' });
  slider('steps', 'render.steps', { out: 'steps-out' });
  slider('newton', 'render.newton_steps', { out: 'newton-out' });
  slider('crossing', 'render.crossing', { out: 'crossing-out' });
  const select = (id, key) => $(id).addEventListener('change', () => setKey(key, JSON.stringify($(id).value)));
  select('inside', 'surface.inside');
  select('method', 'render.method');
  select('interpolation', 'field.interpolation');
  select('shading', 'render.shading');
  select('normals', 'render.normals');
  $('projection').addEventListener('change', () => {
    view.camera.ortho = $('projection').value === 'orthographic';
    view.homeCamera.ortho = view.camera.ortho;
    setKey('camera.projection', JSON.stringify($('projection').value));
    drawOverlay();
  });
  $('skip').addEventListener('change', () => setKey('render.skip', String($('skip').checked)));
  $('occupancy').addEventListener('change', () =>
    setKey('render.occupancy', String($('occupancy').checked)));
  const timeInput = () => {
    view.time = Number(Number($('time').value).toPrecision(6));
    $('time-out').textContent = fmt(view.time);
    sendState(true);
  };
  $('time').addEventListener('input', timeInput);
  $('play').addEventListener('click', () => {
    view.playing = !view.playing;
    $('play').textContent = view.playing ? 'pause' : 'play';
    if (view.playing) stepTime();
  });
  $('slice-on').addEventListener('change', updateSlice);
  $('slice-axis').addEventListener('change', () => { buildSliceRange(); updateSlice(); });
  $('slice-at').addEventListener('input', () => { $('slice-at-out').textContent = fmt(Number($('slice-at').value)); updateSlice(); });

  $('copy-command').addEventListener('click', async () => {
    const text = commandLine();
    $('command').textContent = text;
    try { await navigator.clipboard.writeText(text); status('copied'); } catch (_) { status('select the command below to copy it'); }
  });
  $('save-scene').addEventListener('click', () => download('/api/scene.toml', 'scene.toml'));
  $('save-exr').addEventListener('click', () => download('/api/exr', 'isoview.exr'));
  $('send-tev').addEventListener('click', async () => {
    const r = await api('/api/tev', { method: 'POST', body: JSON.stringify({ address: $('tev-address').value }) });
    status(r.ok ? `sent #${(await r.json()).generation} to tev` : await errorText(r));
  });
}

function buildSliceRange() {
  const b = view.info.field.bounds;
  const axis = 'xyz'.indexOf($('slice-axis').value);
  const at = $('slice-at');
  at.min = b.min[axis];
  at.max = b.max[axis];
  at.step = (b.max[axis] - b.min[axis]) / 1000;
  at.value = (b.min[axis] + b.max[axis]) / 2;
  $('slice-at-out').textContent = fmt(Number(at.value));
}

function status(text) {
  $('action-status').textContent = text;
}

async function download(path, name) {
  const r = await api(path);
  if (!r.ok) { status(await errorText(r)); return; }
  const a = document.createElement('a');
  a.href = URL.createObjectURL(await r.blob());
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
  status(`saved ${name}`);
}

function stepTime() {
  if (!view.playing) return;
  const t = $('time');
  let next = Number(t.value) + 1 / 24;
  if (next > Number(t.max)) next = 0;
  t.value = next;
  view.time = next;
  $('time-out').textContent = fmt(next);
  sendState(true);
}

// ---- start: the server's state, or the one in the URL ----
async function loadInfo() {
  const r = await api('/api/state');
  if (!r.ok) { showError(await errorText(r)); return null; }
  return r.json();
}

async function start() {
  if (!TOKEN) showError('no token in the URL: open the URL that `isoview serve` printed');
  let info = await loadInfo();
  if (!info) return;
  if (location.hash.length > 1) {
    try {
      const saved = JSON.parse(decodeURIComponent(location.hash.slice(1)));
      const r = await api('/api/state', { method: 'POST', body: JSON.stringify({ set: saved.set || [], time: saved.time || 0 }) });
      if (r.ok) info = await loadInfo();
      else showError(await errorText(r));
    } catch (e) {
      showError(`the state in the URL is unreadable: ${e}`);
    }
  }
  view.info = info;
  view.time = info.time;
  view.sets = new Map(info.set.map((s) => { const k = s.indexOf('='); return [s.slice(0, k).trim(), s.slice(k + 1).trim()]; }));
  view.camera = cameraFromInfo(info);
  view.homeCamera = cameraFromInfo(info);
  $('scene-name').textContent = info.scene;
  $('device').textContent = `${info.device} · ${info.field.describe}`;
  $('command').textContent = commandLine();
  buildControls(info);
  pollFrames();
}

wireCamera();
wireControls();
start();
