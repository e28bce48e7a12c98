// The page of `raycast serve`: shows frames from /frame, follows /events, and lets the
// mouse move the camera. Plain ES2020, no modules, nothing from other origins (CSP).
'use strict';

// ---- Vector maths (3-element arrays) ----
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [
  a[1] * b[2] - a[2] * b[1],
  a[2] * b[0] - a[0] * b[2],
  a[0] * b[1] - a[1] * b[0],
];
const length = (a) => Math.sqrt(dot(a, a));
function normalize(a) {
  const l = length(a);
  return l > 0 ? scale(a, 1 / l) : [0, 0, 0];
}
// Rodrigues' formula: v rotated by `angle` radians about the unit vector k.
function rotate(v, k, angle) {
  const c = Math.cos(angle), s = Math.sin(angle);
  return add(add(scale(v, c), scale(cross(k, v), s)), scale(k, dot(k, v) * (1 - c)));
}
// Any unit vector perpendicular to a (for degenerate cross products).
function perpendicular(a) {
  const other = Math.abs(a[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
  return normalize(cross(a, other));
}

const DEG = Math.PI / 180;
const ORBIT_PER_PIXEL = 0.3 * DEG;
const POLE_MARGIN = 5 * DEG;        // stay within 85 degrees of the up axis's poles
const MIN_DISTANCE = 1e-4;          // dolly never reaches the target
const MAX_DISTANCE = 1e9;           // nor overflows to infinity
const INTERACTIVE_MS = 250;         // small frames until this long after the last move

// Everything a headless test may read lives here.
const rc = (window.raycast = {
  state: null,
  camera: null,   // {eye, look_at, up}: the user's view, kept across reloads
  frames: 0,      // frames shown
  shown: null,    // query string of the frame on screen
  busy: false,    // a /frame request is in flight
});

let tab = 'color';
let device = 'gpu';
let lastKey = null;       // what the last request (good or failed) asked for
let objectUrl = null;     // URL of the picture on screen, revoked when replaced
let lastMove = -Infinity; // time of the last drag or wheel event
let idleTimer = 0;
let drag = null;          // {id, button, x, y} while a pointer is down on the picture

const $ = (sel) => document.querySelector(sel);
const img = $('#picture');
const stats = $('#stats');
const errorPanel = $('#error');

function copyCamera(c) {
  return { eye: c.eye.slice(), look_at: c.look_at.slice(), up: c.up.slice() };
}

// ---- State from the server ----
function applyState(s) {
  const first = !rc.state;
  rc.state = s;
  if (first || !rc.camera) rc.camera = copyCamera(s.camera);
  rc.camera.up = s.camera.up.slice(); // requests always use the scene camera's up

  $('#title').textContent = s.title;
  document.title = 'raycast · ' + s.title;
  $('#files').textContent = (s.files || []).join(' · ') + (s.hook ? '  (colour: ' + s.hook + ')' : '');
  errorPanel.hidden = s.error == null;
  errorPanel.textContent = s.error == null ? '' : s.error;
  if (first) stats.textContent = 'loading…';
  refreshButtons();
  update();
}

// Marks the active tab and device; disables Colour where the CPU reference cannot colour.
function refreshButtons() {
  const noColour = rc.state && !rc.state.cpu_color && device !== 'gpu';
  if (noColour && tab === 'color') tab = 'id';
  for (const b of document.querySelectorAll('[data-tab]')) {
    b.setAttribute('aria-pressed', String(b.dataset.tab === tab));
    if (b.dataset.tab === 'color') {
      b.disabled = !!noColour;
      if (noColour) b.title = 'The CPU reference cannot colour with a custom hook: use the GPU device';
      else b.removeAttribute('title');
    }
  }
  for (const b of document.querySelectorAll('[data-device]')) {
    b.setAttribute('aria-pressed', String(b.dataset.device === device));
  }
}

// ---- Frames ----
function interactive() {
  return drag !== null || performance.now() - lastMove < INTERACTIVE_MS;
}

function frameSize() {
  const [w, h] = rc.state.camera.size;
  if (!interactive()) return [w, h];
  return [Math.max(1, Math.round(w / 3)), Math.max(1, Math.round(h / 3))];
}

const vec = (v) => v.map(String).join(',');

function wantedQuery() {
  const c = rc.camera;
  const [w, h] = frameSize();
  return 'tab=' + tab + '&device=' + device + '&eye=' + vec(c.eye) + '&look_at=' + vec(c.look_at) +
    '&up=' + vec(c.up) + '&size=' + w + 'x' + h;
}

// Requests the wanted frame unless it is already asked for; one request at a time, and
// the end of each request calls this again, so the latest wish wins.
function update() {
  if (!rc.state || rc.busy) return;
  const query = wantedQuery();
  const key = query + '#' + rc.state.version;
  if (key === lastKey) return;
  lastKey = key;
  rc.busy = true;
  requestFrame(query).finally(() => {
    rc.busy = false;
    update();
  });
}

async function requestFrame(query) {
  const small = interactive();
  try {
    const res = await fetch('/frame?' + query, { cache: 'no-store' });
    if (!res.ok) {
      const text = (await res.text()).split('\n')[0].trim();
      showError(res.status + ' ' + (text || res.statusText));
      return;
    }
    const blob = await res.blob();
    await showPicture(blob, small);
    rc.frames += 1;
    rc.shown = query;
    img.dataset.query = query;
    img.dataset.version = res.headers.get('X-Version') || '';
    showStats(query, res.headers);
  } catch (e) {
    showError(e && e.message ? e.message : String(e));
  }
}

// Decodes off-screen first, so a bad PNG never replaces the last good picture.
async function showPicture(blob, small) {
  const url = URL.createObjectURL(blob);
  try {
    const probe = new Image();
    probe.src = url;
    await probe.decode();
  } catch (e) {
    URL.revokeObjectURL(url);
    throw new Error('could not decode the frame');
  }
  const [w, h] = rc.state.camera.size;
  img.width = w;   // display size stays the full size even for small frames
  img.height = h;
  img.style.setProperty('--aspect', String(w / h));
  img.classList.toggle('small', small);
  await new Promise((resolve) => {
    img.addEventListener('load', resolve, { once: true });
    img.addEventListener('error', resolve, { once: true });
    img.src = url;
  });
  if (objectUrl) URL.revokeObjectURL(objectUrl);
  objectUrl = url;
}

function showStats(query, headers) {
  const size = /size=(\d+x\d+)/.exec(query)[1];
  const secs = parseFloat(headers.get('X-Frame-Seconds'));
  const rays = parseFloat(headers.get('X-Rays'));
  const parts = [size];
  if (Number.isFinite(secs)) parts.push((secs * 1000).toFixed(1) + ' ms');
  if (Number.isFinite(secs) && secs > 0 && Number.isFinite(rays)) {
    parts.push((rays / secs / 1e6).toFixed(1) + ' Mrays/s');
  }
  const mode = headers.get('X-Mode');
  if (mode) parts.push(mode);
  const summary = headers.get('X-Summary');
  if (device === 'diff' && summary) parts.push(summary);
  stats.textContent = parts.join(' · ');
  stats.classList.remove('bad');
}

function showError(text) {
  stats.textContent = 'frame failed: ' + text;
  stats.classList.add('bad');
}

// ---- Camera moves ----
function orbit(dx, dy) {
  const c = rc.camera;
  const up = normalize(c.up);
  let offset = rotate(sub(c.eye, c.look_at), up, -dx * ORBIT_PER_PIXEL);
  // Elevation: angle from the up pole, kept away from both poles.
  const theta = Math.acos(Math.max(-1, Math.min(1, dot(normalize(offset), up))));
  const target = Math.max(POLE_MARGIN, Math.min(Math.PI - POLE_MARGIN, theta - dy * ORBIT_PER_PIXEL));
  let axis = cross(offset, up); // rotating about it by a positive angle moves towards up
  axis = length(axis) > 1e-12 ? normalize(axis) : perpendicular(up);
  offset = rotate(offset, axis, theta - target);
  c.eye = add(c.look_at, offset);
}

function pan(dx, dy) {
  const c = rc.camera;
  const forward = normalize(sub(c.look_at, c.eye));
  const right = normalize(cross(forward, c.up));
  const upView = cross(right, forward);
  // World units per CSS pixel at the target's distance, so the scene follows the cursor.
  const height = img.getBoundingClientRect().height || rc.state.camera.size[1];
  const perPixel = length(sub(c.look_at, c.eye)) * 2 * Math.tan(rc.state.camera.fov * DEG / 2) / height;
  const move = add(scale(right, -dx * perPixel), scale(upView, dy * perPixel));
  c.eye = add(c.eye, move);
  c.look_at = add(c.look_at, move);
}

function dolly(deltaY) {
  const c = rc.camera;
  const offset = sub(c.eye, c.look_at);
  const dist = Math.min(MAX_DISTANCE, Math.max(MIN_DISTANCE, length(offset) * Math.exp(deltaY * 0.001)));
  c.eye = add(c.look_at, scale(normalize(offset), dist));
}

// After a move: ask now (small), and once more at full size when the moving stops.
function moved() {
  lastMove = performance.now();
  clearTimeout(idleTimer);
  idleTimer = setTimeout(update, INTERACTIVE_MS + 10);
  update();
}

img.addEventListener('pointerdown', (e) => {
  if (!rc.camera || (e.button !== 0 && e.button !== 2)) return;
  e.preventDefault();
  img.setPointerCapture(e.pointerId);
  drag = { id: e.pointerId, button: e.button, x: e.clientX, y: e.clientY };
  update();
});

img.addEventListener('pointermove', (e) => {
  if (!drag || e.pointerId !== drag.id) return;
  const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
  if (dx === 0 && dy === 0) return;
  drag.x = e.clientX;
  drag.y = e.clientY;
  if (drag.button === 2 || e.shiftKey) pan(dx, dy);
  else orbit(dx, dy);
  moved();
});

function endDrag(e) {
  if (!drag || e.pointerId !== drag.id) return;
  drag = null;
  if (img.hasPointerCapture(e.pointerId)) img.releasePointerCapture(e.pointerId);
  clearTimeout(idleTimer);
  idleTimer = setTimeout(update, Math.max(0, lastMove + INTERACTIVE_MS + 10 - performance.now()));
  update();
}
img.addEventListener('pointerup', endDrag);
img.addEventListener('pointercancel', endDrag);
img.addEventListener('contextmenu', (e) => e.preventDefault());
img.addEventListener('dragstart', (e) => e.preventDefault());

img.addEventListener('wheel', (e) => {
  if (!rc.camera) return;
  e.preventDefault();
  // Lines and pages into rough pixels, so every mouse zooms at a similar speed.
  const unit = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
  dolly(e.deltaY * unit);
  moved();
}, { passive: false });

// ---- Buttons ----
for (const b of document.querySelectorAll('[data-tab]')) {
  b.addEventListener('click', () => { tab = b.dataset.tab; refreshButtons(); update(); });
}
for (const b of document.querySelectorAll('[data-device]')) {
  b.addEventListener('click', () => { device = b.dataset.device; refreshButtons(); update(); });
}
$('#reset').addEventListener('click', () => {
  if (!rc.state) return;
  rc.camera = copyCamera(rc.state.camera); // the newest scene camera
  update();
});

// ---- Connection: SSE sends the state on connect and on each change, and reconnects. ----
const events = new EventSource('/events');
events.addEventListener('state', (e) => applyState(JSON.parse(e.data)));
events.addEventListener('error', () => {
  if (!rc.state) stats.textContent = 'waiting for the server…';
});
fetch('/state', { cache: 'no-store' })
  .then((r) => (r.ok ? r.json() : null))
  .then((s) => { if (s && !rc.state) applyState(s); })
  .catch(() => {});
