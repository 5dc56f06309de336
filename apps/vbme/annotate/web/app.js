// vbme annotate: the page. Holds the annotation (the JSON form of doc/annotation_format.md),
// lets the user edit it on the frame, and asks the program to calibrate after every edit.
// Image coordinates follow the annotation format: pixel centres at integers.

const $ = (id) => document.getElementById(id);
const AXIS_COLOURS = ['#ff5050', '#50e050', '#5090ff'];  // world x, y, z (as vbme calibrate)
const GROUP_COLOURS = ['#ff8c42', '#42d6ff', '#c77dff', '#ffd23f', '#3bceac', '#ee4266'];

const state = {
  info: null,
  frame: 0,
  image: null,            // HTMLImageElement of the current frame
  ann: emptyAnnotation(),
  activeGroup: 0,
  activeLight: -1,        // light polygon being drawn
  tool: 'line',
  suggestions: [],        // [{s: [x1,y1,x2,y2], axis}]: axis in the chosen proposal's frame
  proposals: [],          // ranked Manhattan frames {focal, focal_rel_sigma, confidence, ambiguous, note, axes}
  proposal: -1,           // the chosen one (-1: none, the suggestions are ungrouped)
  feedback: null,
  view: { s: 1, ox: 0, oy: 0 },
  undo: [], redo: [],
  drag: null,             // current pointer gesture
  mouse: null,            // last pointer position (image coordinates)
  space: false,
  calibrating: 0,         // sequence number of the last request sent
  calibrated: 0,          // sequence number of the last reply shown
  placement: null,        // { place: [u, v], scale, rotate_deg } of --object
  preview: null,          // ImageBitmap of the latest preview render
  previewSeq: 0,          // bumps on every change: running refinements stop
};

function emptyAnnotation() {
  return { lines: [], room: { floor_edges: {}, ceiling_edges: {}, wall_corners: [], faces: {} }, lights: [] };
}

/** Fills the optional parts so that the editor can rely on them. */
function normalise(a) {
  const n = Object.assign(emptyAnnotation(), a || {});
  n.lines = (n.lines || []).map((g, i) => ({ name: g.name || `group_${i + 1}`, axis: g.axis || 'any', segments: g.segments || [] }));
  n.room = Object.assign({ floor_edges: {}, ceiling_edges: {}, wall_corners: [], faces: {} }, n.room || {});
  n.lights = n.lights || [];
  return n;
}

// ---------------------------------------------------------------------------------------------
// Server

async function api(path, body) {
  const opts = body === undefined ? {} : { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) };
  const r = await fetch('api/' + path, opts);
  const j = await r.json().catch(() => ({ error: `HTTP ${r.status}` }));
  if (!r.ok) throw new Error(j.error || `HTTP ${r.status}`);
  return j;
}

/** The annotation as the file holds it: empty parts left out. */
function annotationForServer() {
  const a = JSON.parse(JSON.stringify(state.ann));
  a.image_size = [state.image.naturalWidth, state.image.naturalHeight];
  const room = a.room;
  for (const k of ['floor_edges', 'ceiling_edges']) {
    for (const w of Object.keys(room[k])) if (!room[k][w].length) delete room[k][w];
    if (!Object.keys(room[k]).length) delete room[k];
  }
  if (!room.wall_corners.length) delete room.wall_corners;
  if (!Object.keys(room.faces).length) delete room.faces;
  if (!Object.keys(room).length) delete a.room;
  if (!a.lines.length) delete a.lines;
  if (!a.lights.length) delete a.lights;
  for (const k of ['camera_height', 'room_height', 'focal']) if (!(a[k] > 0)) delete a[k];
  return a;
}

let calibrateTimer = null;
function scheduleCalibrate() {
  clearTimeout(calibrateTimer);
  document.body.dataset.calibrating = '1';  // an edit not yet calibrated
  calibrateTimer = setTimeout(calibrate, 60);
}

async function calibrate() {
  const seq = ++state.calibrating;
  document.body.dataset.calibrating = '1';
  try {
    const fb = await api('calibrate', { frame: state.frame, annotation: annotationForServer() });
    if (seq < state.calibrated) return;
    state.calibrated = seq;
    state.feedback = fb;
  } catch (e) {
    state.feedback = { ok: false, warnings: [e.message], missing: [] };
  }
  if (seq === state.calibrating) document.body.dataset.calibrating = '';
  document.body.dataset.calibrated = String(seq);
  showFeedback();
  draw();
}

async function save() {
  status('saving…');
  try {
    const r = await api('save', { frame: state.frame, annotation: annotationForServer(), placement: state.placement });
    status('saved ' + r.saved.join(', ') + (r.scene_error ? '\n' + r.scene_error : '') + (r.insert_hint ? '\n' + r.insert_hint : ''), !!r.scene_error);
    document.body.dataset.saved = String((+document.body.dataset.saved || 0) + 1);
  } catch (e) {
    status(e.message, true);
  }
}

/** The object's preview: differential renders with more and more samples per pixel, each
replacing the last, until the placement or the annotation changes. */
async function refinePreview() {
  if (!state.placement) return;
  const seq = ++state.previewSeq;
  const st = $('preview-status');
  for (const spp of [1, 4, 16, 64]) {
    st.textContent = `rendering ${spp} sample(s) per pixel…`;
    let r;
    try {
      r = await fetch('api/preview', { method: 'POST', headers: { 'Content-Type': 'application/json' },
        body: JSON.stringify({ frame: state.frame, annotation: annotationForServer(), placement: state.placement, spp }) });
    } catch (e) { st.textContent = e.message; return; }
    if (seq !== state.previewSeq) return;
    if (!r.ok) {
      const j = await r.json().catch(() => ({ error: `HTTP ${r.status}` }));
      st.textContent = j.error; st.dataset.spp = '0'; state.preview = null; draw();
      return;
    }
    const bmp = await createImageBitmap(await r.blob());
    if (seq !== state.previewSeq) return;
    state.preview = bmp;
    st.textContent = `preview at ${spp} sample(s) per pixel` + (spp < 64 ? ', refining…' : '');
    st.dataset.spp = String(spp);
    draw();
  }
}

function status(text, error = false) {
  $('status').textContent = text;
  $('status').className = error ? 'error' : '';
}

// ---------------------------------------------------------------------------------------------
// Undo / redo: whole-annotation snapshots

function edit(fn) {
  state.undo.push(JSON.stringify(state.ann));
  if (state.undo.length > 500) state.undo.shift();
  state.redo = [];
  fn();
  changed();
}

function undo() {
  if (!state.undo.length) return;
  state.redo.push(JSON.stringify(state.ann));
  state.ann = JSON.parse(state.undo.pop());
  state.activeLight = -1;
  changed();
}

function redo() {
  if (!state.redo.length) return;
  state.undo.push(JSON.stringify(state.ann));
  state.ann = JSON.parse(state.redo.pop());
  changed();
}

function changed() {
  state.activeGroup = Math.min(state.activeGroup, Math.max(0, state.ann.lines.length - 1));
  if (state.activeLight >= state.ann.lights.length) state.activeLight = -1;
  $('undo').disabled = !state.undo.length;
  $('redo').disabled = !state.redo.length;
  renderPanel();
  draw();
  scheduleCalibrate();
  if (state.placement) { clearTimeout(previewTimer); previewTimer = setTimeout(refinePreview, 400); }
}
let previewTimer = null;

// ---------------------------------------------------------------------------------------------
// View: image ↔ screen

const canvas = $('view');
const ctx = canvas.getContext('2d');

function toScreen(x, y) {
  const v = state.view;
  return [(x + 0.5) * v.s + v.ox, (y + 0.5) * v.s + v.oy];
}

function toImage(sx, sy) {
  const v = state.view;
  return [(sx - v.ox) / v.s - 0.5, (sy - v.oy) / v.s - 0.5];
}

function fit() {
  const st = $('stage');
  canvas.width = st.clientWidth;
  canvas.height = st.clientHeight;
  if (!state.image) return;
  const w = state.image.naturalWidth, h = state.image.naturalHeight;
  const s = Math.min(canvas.width / w, canvas.height / h);
  state.view = { s, ox: (canvas.width - w * s) / 2, oy: (canvas.height - h * s) / 2 };
  draw();
}

function zoomAt(sx, sy, factor) {
  const v = state.view;
  const s = Math.max(0.1, Math.min(64, v.s * factor));
  const k = s / v.s;
  state.view = { s, ox: sx - (sx - v.ox) * k, oy: sy - (sy - v.oy) * k };
  draw();
}

// ---------------------------------------------------------------------------------------------
// Drawing

function line(x1, y1, x2, y2, colour, width = 1.5, dash = []) {
  const [a, b] = toScreen(x1, y1), [c, d] = toScreen(x2, y2);
  ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.setLineDash(dash);
  ctx.beginPath(); ctx.moveTo(a, b); ctx.lineTo(c, d); ctx.stroke();
  ctx.setLineDash([]);
}

function dot(x, y, colour, r = 4) {
  const [a, b] = toScreen(x, y);
  ctx.fillStyle = colour; ctx.strokeStyle = '#000'; ctx.lineWidth = 1;
  ctx.beginPath(); ctx.arc(a, b, r, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
}

function label(x, y, text, colour) {
  const [a, b] = toScreen(x, y);
  ctx.font = '11px monospace'; ctx.fillStyle = '#000'; ctx.fillText(text, a + 5, b - 3);
  ctx.fillStyle = colour; ctx.fillText(text, a + 4, b - 4);
}

function polygon(pts, colour, closed, fill) {
  if (!pts.length) return;
  ctx.strokeStyle = colour; ctx.lineWidth = 1.5;
  ctx.beginPath();
  pts.forEach((p, i) => { const [a, b] = toScreen(p[0], p[1]); i ? ctx.lineTo(a, b) : ctx.moveTo(a, b); });
  if (closed) ctx.closePath();
  if (fill) { ctx.fillStyle = fill; ctx.fill(); }
  ctx.stroke();
}

function groupColour(i) { return GROUP_COLOURS[i % GROUP_COLOURS.length]; }

function draw() {
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = '#111'; ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!state.image) return;
  const v = state.view, img = state.image;
  ctx.imageSmoothingEnabled = v.s < 2;
  const shown = state.preview && $('show-preview').checked ? state.preview : img;
  ctx.drawImage(shown, v.ox, v.oy, img.naturalWidth * v.s, img.naturalHeight * v.s);
  const fb = state.feedback;
  // Live feedback underneath the user's marks.
  if (fb && fb.ok) {
    // With a lens distortion (k1) the horizon is a curve of the clicked frame.
    if (fb.horizon_curve) { ctx.setLineDash([6, 4]); polygon(fb.horizon_curve, '#ff40ff', false); ctx.setLineDash([]); }
    else if (fb.horizon && fb.horizon.length === 4) line(...fb.horizon, '#ff40ff', 1, [6, 4]);
    if (fb.room) for (const e of fb.room.edges) line(...e, '#ffffff', 1.5);
    if (fb.lights) for (const l of fb.lights) polygon(l.polygon, '#ffe14d', true, 'rgba(255,225,77,0.15)');
    for (const vp of fb.vanishing_points || []) if (vp.point) {
      dot(vp.point[0], vp.point[1], AXIS_COLOURS[vp.axis], 5);
      label(vp.point[0], vp.point[1], 'VP ' + 'xyz'[vp.axis], AXIS_COLOURS[vp.axis]);
    }
  }
  if ($('show-suggestions').checked)
    for (const sg of state.suggestions) line(...sg.s, sg.axis >= 0 ? AXIS_COLOURS[sg.axis] : '#aaa', 2, [5, 3]);
  // Line groups, with each segment's residual.
  state.ann.lines.forEach((g, gi) => {
    const res = fb && fb.groups ? (fb.groups.find((r) => r.name === g.name) || {}).residuals : null;
    g.segments.forEach((s, si) => {
      const r = res ? res[si] : undefined;
      const bad = r !== undefined && r > fb.outlier_px;
      line(...s, bad ? '#ff2020' : groupColour(gi), gi === state.activeGroup ? 2.5 : 1.8);
      dot(s[0], s[1], groupColour(gi), 3); dot(s[2], s[3], groupColour(gi), 3);
      if (r !== undefined && (bad || v.s >= 1.5)) label((s[0] + s[2]) / 2, (s[1] + s[3]) / 2, r.toFixed(2), bad ? '#ff4040' : '#ddd');
    });
  });
  // Room points.
  const room = state.ann.room;
  for (const [w, pts] of Object.entries(room.floor_edges)) pts.forEach((p) => { dot(p[0], p[1], '#00ffd0'); label(p[0], p[1], 'floor ' + w, '#00ffd0'); });
  for (const [w, pts] of Object.entries(room.ceiling_edges)) pts.forEach((p) => { dot(p[0], p[1], '#ffa0ff'); label(p[0], p[1], 'ceiling ' + w, '#ffa0ff'); });
  for (const c of room.wall_corners) c.points.forEach((p) => { dot(p[0], p[1], '#ffb000'); label(p[0], p[1], c.walls.join('|'), '#ffb000'); });
  state.ann.lights.forEach((l, i) => {
    polygon(l.polygon, '#ffff80', i !== state.activeLight);
    l.polygon.forEach((p) => dot(p[0], p[1], '#ffff80', 3));
  });
  if (state.placement) {
    const [u, w] = state.placement.place;
    dot(u, w, '#ffffff', 5);
    label(u, w, 'object', '#ffffff');
  }
  // The gesture in progress.
  const d = state.drag;
  if (d && d.kind === 'segment' && d.end) line(d.start[0], d.start[1], d.end[0], d.end[1], groupColour(state.activeGroup), 2, [4, 2]);
  drawMagnifier();
}

function drawMagnifier() {
  const m = $('magnifier'), mc = m.getContext('2d');
  mc.fillStyle = '#000'; mc.fillRect(0, 0, m.width, m.height);
  if (!state.image || !state.mouse) { m.style.display = 'none'; return; }
  m.style.display = 'block';
  const zoom = 8, [x, y] = state.mouse, half = m.width / zoom / 2;
  mc.imageSmoothingEnabled = false;
  // Source rectangle in the image's pixel-corner coordinates.
  mc.drawImage(state.image, x + 0.5 - half, y + 0.5 - half, 2 * half, 2 * half, 0, 0, m.width, m.height);
  mc.strokeStyle = '#0f0'; mc.lineWidth = 1;
  mc.beginPath(); mc.moveTo(m.width / 2, 0); mc.lineTo(m.width / 2, m.height);
  mc.moveTo(0, m.height / 2); mc.lineTo(m.width, m.height / 2); mc.stroke();
  $('cursor').textContent = `(${x.toFixed(1)}, ${y.toFixed(1)})  zoom ${state.view.s.toFixed(2)}`;
}

// ---------------------------------------------------------------------------------------------
// Panel

function renderPanel() {
  const a = state.ann;
  const fbGroups = state.feedback && state.feedback.groups ? state.feedback.groups : [];
  const gdiv = $('groups');
  gdiv.innerHTML = '';
  a.lines.forEach((g, i) => {
    const d = document.createElement('div');
    d.className = 'group' + (i === state.activeGroup ? ' active' : '');
    d.dataset.index = i;
    const fg = fbGroups.find((r) => r.name === g.name);
    const axis = fg && fg.axis >= 0 ? ' → world ' + 'xyz'[fg.axis] : '';
    d.innerHTML = `<span class="swatch" style="background:${groupColour(i)}"></span>${i + 1}. ` +
      `<input type="text" value="${g.name.replace(/"/g, '')}"> <select>` +
      ['any', 'horizontal', 'vertical'].map((x) => `<option${x === g.axis ? ' selected' : ''}>${x}</option>`).join('') +
      `</select> ${g.segments.length} seg${axis} <button title="Delete the group">✕</button>` +
      `<div class="res">${fg ? 'residuals ' + fg.residuals.map((r) => `<span class="${r > state.feedback.outlier_px ? 'bad' : ''}">${r.toFixed(2)}</span>`).join(' ') + ' px' : ''}</div>`;
    d.addEventListener('click', (e) => { if (e.target === d || e.target.tagName === 'SPAN') { state.activeGroup = i; setTool('line'); renderPanel(); draw(); } });
    d.querySelector('input').addEventListener('change', (e) => edit(() => { g.name = e.target.value.trim() || g.name; }));
    d.querySelector('select').addEventListener('change', (e) => edit(() => { g.axis = e.target.value; }));
    d.querySelector('button').addEventListener('click', () => edit(() => { a.lines.splice(i, 1); }));
    gdiv.appendChild(d);
  });
  // Room points summary.
  const r = a.room, parts = [];
  for (const [w, p] of Object.entries(r.floor_edges)) if (p.length) parts.push(`floor/${w}: ${p.length}`);
  for (const [w, p] of Object.entries(r.ceiling_edges)) if (p.length) parts.push(`ceiling/${w}: ${p.length}`);
  for (const c of r.wall_corners) parts.push(`corner ${c.walls.join('|')}: ${c.points.length}`);
  $('room-points').textContent = parts.length ? 'points: ' + parts.join(', ') : 'no room points yet';
  for (const k of ['camera_height', 'room_height']) if (document.activeElement !== $(k)) $(k).value = a[k] > 0 ? a[k] : '';
  if (document.activeElement !== $('focal_known')) $('focal_known').value = a.focal > 0 ? a.focal : '';
  for (const inp of document.querySelectorAll('#faces input'))
    if (document.activeElement !== inp) inp.value = r.faces[inp.dataset.face] ?? '';
  // Lights.
  const ldiv = $('lights');
  ldiv.innerHTML = '';
  a.lights.forEach((l, i) => {
    const d = document.createElement('div');
    d.className = 'group' + (i === state.activeLight ? ' active' : '');
    d.innerHTML = `light ${i + 1}: ${l.polygon.length} corners ${i === state.activeLight ? '(drawing: Enter closes)' : ''} ` +
      `<select><option value="">face: auto</option>${['back', 'left', 'right', 'front', 'ceiling', 'floor'].map((f) => `<option${f === l.face ? ' selected' : ''}>${f}</option>`).join('')}</select> <button title="Delete the light">✕</button>`;
    d.querySelector('select').addEventListener('change', (e) => edit(() => { if (e.target.value) l.face = e.target.value; else delete l.face; }));
    d.querySelector('button').addEventListener('click', () => edit(() => { a.lights.splice(i, 1); state.activeLight = -1; }));
    ldiv.appendChild(d);
  });
  if (!a.lights.length) ldiv.textContent = 'none: choose Light (G) and click the corners';
}

function showFeedback() {
  const fb = state.feedback || {};
  if (fb.ok) {
    $('focal').textContent = fb.focal.toFixed(1);
    $('focal').dataset.value = String(fb.focal);
    $('fov').textContent = `${fb.fov_deg[0].toFixed(1)}° × ${fb.fov_deg[1].toFixed(1)}°`;
    const c = fb.camera;
    $('camera').textContent = `(${c.center.map((x) => x.toFixed(2)).join(', ')}) m, heading ${c.heading_deg.toFixed(1)}°, ` +
      `elevation ${c.elevation_deg.toFixed(1)}°, rms ${fb.rms_px.toFixed(2)} px`;
  } else {
    $('focal').textContent = '–'; $('focal').dataset.value = ''; $('fov').textContent = '–'; $('camera').textContent = '–';
  }
  if (fb.room) {
    const [a, b] = [fb.room.min, fb.room.max];
    $('room').textContent = `[${a[0].toFixed(2)}, ${b[0].toFixed(2)}] × [${a[1].toFixed(2)}, ${b[1].toFixed(2)}] × [${a[2].toFixed(2)}, ${b[2].toFixed(2)}] m`;
  } else $('room').textContent = '–';
  const list = (id, items) => { $(id).innerHTML = ''; for (const t of items || []) { const li = document.createElement('li'); li.textContent = t; $(id).appendChild(li); } };
  list('missing', (fb.missing || []).map((m) => 'missing: ' + m));
  list('warnings', fb.warnings);
  renderPanel();
}

// ---------------------------------------------------------------------------------------------
// Editing

function setTool(t) {
  state.tool = t;
  if (t !== 'light') state.activeLight = -1;
  for (const b of document.querySelectorAll('#tools button')) b.classList.toggle('active', b.dataset.tool === t);
  renderPanel();
}

function addGroup() {
  edit(() => {
    const used = new Set(state.ann.lines.map((g) => g.name));
    let i = state.ann.lines.length + 1;
    while (used.has(`group_${i}`)) i++;
    state.ann.lines.push({ name: `group_${i}`, axis: 'any', segments: [] });
    state.activeGroup = state.ann.lines.length - 1;
  });
  setTool('line');
}

const round = (x) => Math.round(x * 100) / 100;

/** Everything the user placed, as handles: { get, set, remove } near an image point. */
function handles() {
  const a = state.ann, out = [];
  a.lines.forEach((g, gi) => g.segments.forEach((s, si) => {
    for (const k of [0, 2]) out.push({ p: [s[k], s[k + 1]], set: (x, y) => { s[k] = x; s[k + 1] = y; }, remove: () => g.segments.splice(si, 1), group: gi });
  }));
  const pts = (arr, remove) => arr.forEach((p, i) => out.push({ p, set: (x, y) => { p[0] = x; p[1] = y; }, remove: () => remove(i) }));
  for (const k of ['floor_edges', 'ceiling_edges'])
    for (const w of Object.keys(a.room[k])) pts(a.room[k][w], (i) => { a.room[k][w].splice(i, 1); if (!a.room[k][w].length) delete a.room[k][w]; });
  a.room.wall_corners.forEach((c, ci) => pts(c.points, (i) => { c.points.splice(i, 1); if (!c.points.length) a.room.wall_corners.splice(ci, 1); }));
  a.lights.forEach((l, li) => pts(l.polygon, (i) => { l.polygon.splice(i, 1); if (!l.polygon.length) a.lights.splice(li, 1); }));
  return out;
}

function handleAt(x, y) {
  const tol = 6 / state.view.s;
  let best = null, bd = tol;
  for (const h of handles()) {
    const d = Math.hypot(h.p[0] - x, h.p[1] - y);
    if (d < bd) { bd = d; best = h; }
  }
  return best;
}

function distToSegment(x, y, s) {
  const dx = s[2] - s[0], dy = s[3] - s[1], L2 = dx * dx + dy * dy;
  const t = L2 ? Math.max(0, Math.min(1, ((x - s[0]) * dx + (y - s[1]) * dy) / L2)) : 0;
  return Math.hypot(s[0] + t * dx - x, s[1] + t * dy - y);
}

function suggestionAt(x, y) {
  if (!$('show-suggestions').checked) return null;
  let best = null, bd = 5 / state.view.s;
  for (const sg of state.suggestions) { const d = distToSegment(x, y, sg.s); if (d < bd) { bd = d; best = sg; } }
  return best;
}

function ensureGroup() {
  if (!state.ann.lines.length) {
    state.ann.lines.push({ name: 'group_1', axis: 'any', segments: [] });
    state.activeGroup = 0;
  }
  return state.ann.lines[state.activeGroup];
}

function click(x, y) {
  const a = state.ann, p = [round(x), round(y)];
  switch (state.tool) {
    case 'line': {
      const sg = suggestionAt(x, y);
      if (sg) edit(() => ensureGroup().segments.push(sg.s.map(round)));
      break;
    }
    case 'floor':
    case 'ceiling': {
      const k = state.tool === 'floor' ? 'floor_edges' : 'ceiling_edges', w = $('wall').value;
      edit(() => { (a.room[k][w] = a.room[k][w] || []).push(p); });
      break;
    }
    case 'corner': {
      const walls = [$('corner-a').value, $('corner-b').value];
      edit(() => {
        let c = a.room.wall_corners.find((c) => c.walls[0] === walls[0] && c.walls[1] === walls[1]);
        if (!c) { c = { walls, points: [] }; a.room.wall_corners.push(c); }
        c.points.push(p);
      });
      break;
    }
    case 'place':
      state.placement = { place: p, scale: +$('object-scale').value || 1, rotate_deg: +$('object-rotate').value || 0 };
      refinePreview();
      break;
    case 'light':
      edit(() => {
        if (state.activeLight < 0) { a.lights.push({ polygon: [] }); state.activeLight = a.lights.length - 1; }
        a.lights[state.activeLight].polygon.push(p);
      });
      break;
  }
}

canvas.addEventListener('contextmenu', (e) => e.preventDefault());

canvas.addEventListener('pointerdown', (e) => {
  canvas.setPointerCapture(e.pointerId);
  const [x, y] = toImage(e.offsetX, e.offsetY);
  if (e.button === 1 || e.button === 2 || state.space) {
    state.drag = { kind: 'pan', sx: e.offsetX, sy: e.offsetY, ox: state.view.ox, oy: state.view.oy };
    return;
  }
  if (e.button !== 0) return;
  if (document.activeElement && document.activeElement !== document.body) document.activeElement.blur();
  const h = handleAt(x, y);
  if (h) {
    // Becomes a move once the pointer travels; a click in place is the tool's click.
    state.undo.push(JSON.stringify(state.ann)); state.redo = [];
    state.drag = { kind: 'move', handle: h, moved: false, start: [x, y], sx: e.offsetX, sy: e.offsetY };
    return;
  }
  state.drag = { kind: state.tool === 'line' ? 'segment' : 'click', start: [x, y], sx: e.offsetX, sy: e.offsetY };
});

canvas.addEventListener('pointermove', (e) => {
  const [x, y] = toImage(e.offsetX, e.offsetY);
  state.mouse = [x, y];
  const d = state.drag;
  if (d && d.kind === 'pan') {
    state.view.ox = d.ox + e.offsetX - d.sx; state.view.oy = d.oy + e.offsetY - d.sy;
  } else if (d && d.kind === 'move') {
    if (d.moved || Math.hypot(e.offsetX - d.sx, e.offsetY - d.sy) > 3) { d.handle.set(round(x), round(y)); d.moved = true; }
  } else if (d && d.kind === 'segment') {
    d.end = [x, y];
  }
  draw();
});

canvas.addEventListener('pointerup', (e) => {
  const d = state.drag;
  state.drag = null;
  if (!d) return;
  const [x, y] = toImage(e.offsetX, e.offsetY);
  if (d.kind === 'move') {
    if (d.moved) { state.redo = []; changed(); } else { state.undo.pop(); click(d.start[0], d.start[1]); }
    return;
  }
  if (d.kind === 'pan') return;
  const screenMove = Math.hypot(e.offsetX - d.sx, e.offsetY - d.sy);
  if (d.kind === 'segment' && screenMove > 4) {
    edit(() => ensureGroup().segments.push([round(d.start[0]), round(d.start[1]), round(x), round(y)]));
  } else if (screenMove <= 4) {
    click(d.start[0], d.start[1]);
  }
  draw();
});

canvas.addEventListener('pointerleave', () => { state.mouse = null; draw(); });

canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  zoomAt(e.offsetX, e.offsetY, Math.pow(1.0015, -e.deltaY));
}, { passive: false });

function deleteUnderCursor() {
  if (!state.mouse) return;
  const [x, y] = state.mouse;
  const h = handleAt(x, y);
  if (h) { edit(() => h.remove()); return; }
  // A segment under the cursor (anywhere along it).
  const tol = 5 / state.view.s;
  for (const g of state.ann.lines)
    for (let i = 0; i < g.segments.length; i++)
      if (distToSegment(x, y, g.segments[i]) < tol) { edit(() => g.segments.splice(i, 1)); return; }
}

window.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT') {
    if (e.key === 'Enter' || e.key === 'Escape') e.target.blur();  // back to the shortcuts
    return;
  }
  const k = e.key.toLowerCase();
  if ((e.ctrlKey || e.metaKey) && k === 'z') { e.preventDefault(); e.shiftKey ? redo() : undo(); return; }
  if ((e.ctrlKey || e.metaKey) && k === 'y') { e.preventDefault(); redo(); return; }
  if ((e.ctrlKey || e.metaKey) && k === 's') { e.preventDefault(); save(); return; }
  if (e.ctrlKey || e.metaKey || e.altKey) return;
  const tools = { l: 'line', f: 'floor', c: 'ceiling', k: 'corner', g: 'light' };
  if (state.info && state.info.object) tools.p = 'place';
  if (tools[k]) setTool(tools[k]);
  else if (k === 'n') addGroup();
  else if (k === ' ') { state.space = true; e.preventDefault(); }
  else if (k === '0') fit();
  else if (k === '+' || k === '=') zoomAt(canvas.width / 2, canvas.height / 2, 1.5);
  else if (k === '-') zoomAt(canvas.width / 2, canvas.height / 2, 1 / 1.5);
  else if (k === 'enter') { state.activeLight = -1; renderPanel(); draw(); }
  else if (k === 'escape') { state.drag = null; state.activeLight = -1; renderPanel(); draw(); }
  else if (k === 'delete' || k === 'backspace') deleteUnderCursor();
  else if (k >= '1' && k <= '9' && +k <= state.ann.lines.length) { state.activeGroup = +k - 1; setTool('line'); draw(); }
});
window.addEventListener('keyup', (e) => { if (e.key === ' ') state.space = false; });
window.addEventListener('resize', fit);

/** Lists the ranked Manhattan-frame proposals; clicking one regroups the suggestions by it. */
function renderProposals() {
  const div = $('proposals');
  div.innerHTML = '';
  state.proposals.forEach((p, k) => {
    const b = document.createElement('button');
    b.className = 'proposal' + (k === state.proposal ? ' active' : '');
    b.dataset.index = k;
    const n = [0, 0, 0];
    for (const a of p.axes) if (a >= 0) n[a] += 1;
    b.innerHTML = `${k + 1}. focal <b>${p.focal.toFixed(0)}</b> px ±${(100 * p.focal_rel_sigma).toFixed(1)} %` +
      ` · confidence <b>${p.confidence.toFixed(2)}</b>${p.ambiguous ? ' · <span class="amb">ambiguous</span>' : ''}` +
      `<span class="res"> x/y/z ${n.join('/')} segments</span>`;
    if (p.note) { const note = document.createElement('span'); note.className = 'note'; note.textContent = p.note; b.appendChild(note); }
    b.title = 'Group the suggested segments by this Manhattan frame';
    b.addEventListener('click', () => chooseProposal(k));
    div.appendChild(b);
  });
  if (!state.proposals.length) div.textContent = 'no Manhattan frame found automatically';
  document.body.dataset.proposal = String(state.proposal);
}

/** Regroups the suggested segments by proposal @p k (their axes in that frame). */
function chooseProposal(k) {
  const p = state.proposals[k];
  if (!p || p.axes.length !== state.suggestions.length) return;
  state.proposal = k;
  state.suggestions.forEach((sg, i) => { sg.axis = p.axes[i]; });
  status(`proposal ${k + 1}: focal ${p.focal.toFixed(1)} px, confidence ${p.confidence.toFixed(2)}; Use suggestions fills the line groups from it`);
  renderProposals();
  draw();
}

/** Fills one group per detected direction with its longest suggested segments. */
function useSuggestions() {
  const byAxis = [[], [], []];
  for (const sg of state.suggestions) if (sg.axis >= 0) byAxis[sg.axis].push(sg.s);
  edit(() => {
    byAxis.forEach((segs, axis) => {
      if (segs.length < 2) return;
      segs.sort((p, q) => Math.hypot(q[2] - q[0], q[3] - q[1]) - Math.hypot(p[2] - p[0], p[3] - p[1]));
      const name = 'detected_' + 'xyz'[axis];
      const g = state.ann.lines.find((l) => l.name === name);
      const chosen = segs.slice(0, 8).map((s) => s.map(round));
      if (g) g.segments = chosen;
      else state.ann.lines.push({ name, axis: axis === 2 ? 'vertical' : 'horizontal', segments: chosen });
    });
  });
}

// ---------------------------------------------------------------------------------------------
// Start

async function loadFrame(i) {
  state.frame = i;
  const img = new Image();
  img.src = `api/frame?i=${i}`;
  await img.decode();
  state.image = img;
  for (const t of document.querySelectorAll('#frames img')) t.classList.toggle('active', +t.dataset.frame === i);
  if (i !== 0) status(`frame ${i}: 'vbme insert' reads the scene as frame 0's; calibrate this one with 'vbme calibrate --video … --frame ${i}'`);
  fit();
  state.suggestions = [];
  state.proposals = [];
  state.proposal = -1;
  renderProposals();
  api(`suggestions?i=${i}`).then((s) => {
    state.suggestions = s.segments;
    state.proposals = s.proposals || [];
    state.proposal = s.selected ?? -1;
    renderProposals();
    if (s.warnings.length) status(s.warnings.join('\n'));
    document.body.dataset.suggestions = String(s.segments.length);
    draw();
  }).catch((e) => status(e.message, true));
  scheduleCalibrate();
}

async function start() {
  const info = await api('info');
  state.info = info;
  $('source').textContent = `${info.video} → ${info.out}${info.scene_out ? ' + ' + info.scene_out : ''}`;
  if (info.annotation) {
    state.ann = normalise(info.annotation);
    status('reopened the annotation');
  }
  if (info.object) {
    $('object').hidden = false;
    $('place-tool').hidden = false;
    $('object-name').textContent = info.object;
    const upd = () => { if (state.placement) { state.placement.scale = +$('object-scale').value || 1; state.placement.rotate_deg = +$('object-rotate').value || 0; refinePreview(); } };
    $('object-scale').addEventListener('change', upd);
    $('object-rotate').addEventListener('change', upd);
    $('show-preview').addEventListener('change', draw);
  }
  for (const f of info.frames) {
    const t = document.createElement('img');
    t.src = `api/frame?i=${f}&thumb=1`; t.dataset.frame = f; t.title = `frame ${f}`;
    t.addEventListener('click', () => loadFrame(f));
    $('frames').appendChild(t);
  }
  for (const b of document.querySelectorAll('#tools button')) b.addEventListener('click', () => setTool(b.dataset.tool));
  $('undo').addEventListener('click', undo);
  $('redo').addEventListener('click', redo);
  $('save').addEventListener('click', save);
  $('add-group').addEventListener('click', addGroup);
  $('use-suggestions').addEventListener('click', useSuggestions);
  $('show-suggestions').addEventListener('change', draw);
  const num = (el, setter) => el.addEventListener('change', () => edit(() => setter(el.value === '' ? 0 : +el.value)));
  num($('camera_height'), (v) => { if (v > 0) state.ann.camera_height = v; else delete state.ann.camera_height; });
  num($('room_height'), (v) => { if (v > 0) state.ann.room_height = v; else delete state.ann.room_height; });
  num($('focal_known'), (v) => { if (v > 0) state.ann.focal = v; else delete state.ann.focal; });
  for (const inp of document.querySelectorAll('#faces input'))
    inp.addEventListener('change', () => edit(() => {
      if (inp.value === '') delete state.ann.room.faces[inp.dataset.face];
      else state.ann.room.faces[inp.dataset.face] = +inp.value;
    }));
  // Corner walls: one of back/front with one of left/right.
  setTool('line');
  changed();
  state.undo = [];
  $('undo').disabled = true;
  await loadFrame(info.frame);
  document.body.dataset.ready = '1';
}

// For tests and the curious: the page's state and view transform.
window.vbmeAnnotate = { state, toScreen, toImage, fit };

start().catch((e) => status(e.message, true));
