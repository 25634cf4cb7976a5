// masonry's live view: draws the layout (/layout.json) and the mission's state (/events, or /state.json?at=T).
"use strict";
const NS = "http://www.w3.org/2000/svg";
let layout = null;
let lastState = null;

function el(name, attrs, parent, text) {
  const e = document.createElementNS(NS, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  if (parent) parent.appendChild(e);
  return e;
}

// a view box over the points, with a margin, mapping world (a, b) to svg (x, y) with b up
function frame(points, width, height, margin) {
  let a0 = Infinity, a1 = -Infinity, b0 = Infinity, b1 = -Infinity;
  for (const [a, b] of points) { a0 = Math.min(a0, a); a1 = Math.max(a1, a); b0 = Math.min(b0, b); b1 = Math.max(b1, b); }
  if (!isFinite(a0)) { a0 = -1; a1 = 1; b0 = -1; b1 = 1; }
  a0 -= margin; a1 += margin; b0 -= margin; b1 += margin;
  const s = Math.min(width / (a1 - a0), height / (b1 - b0));
  const ox = (width - s * (a1 - a0)) / 2, oy = (height - s * (b1 - b0)) / 2;
  return { s, x: (a) => ox + (a - a0) * s, y: (b) => height - oy - (b - b0) * s };
}

function wallAxis() {
  // the side view looks across the wall: along its longer horizontal extent
  let xs = [], ys = [];
  for (const t of layout.tasks) if (t.kind === "brick") { xs.push(t.position_m[0]); ys.push(t.position_m[1]); }
  const spread = (v) => v.length ? Math.max(...v) - Math.min(...v) : 0;
  return spread(xs) >= spread(ys) ? 0 : 1;
}

function drawTop(state) {
  const svg = document.getElementById("top");
  svg.replaceChildren();
  const pts = [];
  for (const t of layout.tasks) pts.push(t.kind === "brick" ? t.position_m : t.start_m, t.kind === "brick" ? t.position_m : t.end_m);
  for (const u of layout.uavs) pts.push(u.home_m);
  const f = frame(pts, 800, 420, 0.6);
  for (const u of state.uavs) for (const v of u.volumes || []) {
    const [ax, ay, bx, by, , , slack] = v;
    const len = Math.hypot(bx - ax, by - ay), ang = Math.atan2(by - ay, bx - ax) * 180 / Math.PI;
    const w = Math.max(len + 2 * slack, 0.05) * f.s, h = Math.max(2 * slack, 0.05) * f.s;
    const cx = f.x((ax + bx) / 2), cy = f.y((ay + by) / 2);
    el("rect", { class: "vol", x: cx - w / 2, y: cy - h / 2, width: w, height: h, transform: `rotate(${-ang} ${cx} ${cy})` }, svg);
  }
  // lower courses first, so that the top view shows the highest brick at each place
  const byHeight = layout.tasks.filter((t) => t.kind === "brick").sort((a, b) => a.position_m[2] - b.position_m[2]);
  for (const t of byHeight) {
    const st = state.tasks[t.id] || (t.done ? "done" : "todo");
    {
      const w = t.size_m[0] * f.s, h = t.size_m[1] * f.s, cx = f.x(t.position_m[0]), cy = f.y(t.position_m[1]);
      const r = el("rect", { class: st, x: cx - w / 2, y: cy - h / 2, width: w, height: h, "data-task": t.id,
        transform: `rotate(${-t.yaw_rad * 180 / Math.PI} ${cx} ${cy})` }, svg);
      deviation(r, state, t.id, st);
    }
  }
  drawUavs(svg, state, (p) => [f.x(p[0]), f.y(p[1])]);
}

function drawSide(state) {
  const svg = document.getElementById("side");
  svg.replaceChildren();
  const k = wallAxis();
  const pts = [];
  for (const t of layout.tasks) if (t.kind === "brick") pts.push([t.position_m[k], t.position_m[2]], [t.position_m[k], 0]);
  for (const u of layout.uavs) pts.push([u.home_m[k], 0], [u.home_m[k], 2.5]);
  const f = frame(pts, 800, 260, 0.3);
  el("line", { class: "axis", x1: 0, x2: 800, y1: f.y(0), y2: f.y(0) }, svg);
  for (const u of state.uavs) for (const v of u.volumes || []) {
    const a = Math.min(v[k], v[2 + k]) - v[6], b = Math.max(v[k], v[2 + k]) + v[6];
    el("rect", { class: "vol", x: f.x(a), y: f.y(v[5]), width: Math.max((b - a) * f.s, 1), height: Math.max((v[5] - v[4]) * f.s, 1) }, svg);
  }
  // bricks further from the viewer first, so that the nearer ones cover them
  const bricks = layout.tasks.filter((t) => t.kind === "brick");
  for (const t of bricks) {
    const st = state.tasks[t.id] || (t.done ? "done" : "todo");
    const w = (k === 0 ? t.size_m[0] : t.size_m[1]) * f.s, h = t.size_m[2] * f.s;
    const r = el("rect", { class: st, x: f.x(t.position_m[k]) - w / 2, y: f.y(t.position_m[2]) - h / 2, width: w, height: h, "data-task": t.id }, svg);
    deviation(r, state, t.id, st);
  }
  for (const t of layout.tasks) if (t.kind === "adhesion") {
    const st = state.tasks[t.id] || (t.done ? "done" : "todo");
    el("line", { class: "adh " + st, x1: f.x(t.start_m[k]), y1: f.y(t.start_m[2]), x2: f.x(t.end_m[k]), y2: f.y(t.end_m[2]), "stroke-width": 2 }, svg);
  }
  drawUavs(svg, state, (p) => [f.x(p[k]), f.y(p[2])]);
}

// A placed brick whose as-built pose is known is coloured by its deviation from the design: green on the design,
// red at the blueprint's placement_tolerance_m and beyond (issue 30); its title says by how much.
function deviation(rect, state, id, st) {
  const a = state.as_built && state.as_built[id];
  if (!a || st !== "done") return;
  const frac = a.tolerance_m > 0 ? Math.min(1, a.deviation_m / a.tolerance_m) : 0;
  rect.style.fill = `hsl(${Math.round(120 * (1 - frac))}, 70%, 45%)`;
  rect.dataset.deviation = a.deviation_m;
  if (a.deviation_m > a.tolerance_m) rect.classList.add("beyond");
  el("title", {}, rect, `${id}: ${(a.deviation_m * 100).toFixed(1)} cm from its design (tolerance ${(a.tolerance_m * 100).toFixed(1)} cm)`);
}

function drawUavs(svg, state, at) {
  const roles = Object.fromEntries(layout.uavs.map((u) => [u.name, u.role]));
  for (const u of state.uavs) {
    if (!u.position_m) continue;
    const [x, y] = at(u.position_m);
    el("circle", { class: "uav " + (roles[u.name] || ""), cx: x, cy: y, r: 6, "data-uav": u.name }, svg);
    el("text", { class: "label", x: x + 8, y: y - 6 }, svg, `${u.name} ${u.state || ""}${u.task_id ? " " + u.task_id : ""}`);
  }
}

// the Gantt's and the reserved windows' time axis: to now, the last bar's end or the last window planned
function chartEnd(state) {
  let end = Math.max(10, state.time_s, ...state.bars.map((b) => b.end_s || state.time_s));
  for (const r of state.reservations || []) if (r.t1_s !== null) end = Math.max(end, r.t1_s);
  return end;
}

function timeTicks(svg, sx, end, height) {
  const step = Math.pow(10, Math.floor(Math.log10(end))) / (end / Math.pow(10, Math.floor(Math.log10(end))) < 3 ? 2 : 1);
  for (let t = 0; t <= end; t += step) {
    el("line", { class: "axis", x1: sx(t), x2: sx(t), y1: 0, y2: height - 20 }, svg);
    el("text", { class: "label", x: sx(t) - 8, y: height - 6 }, svg, `${Math.round(t)} s`);
  }
}

// One row per UAV on the mission's time axis (the Gantt and the reservation table share it): the cleared svg, the
// UAV names labelled down its left, and sx, a time in seconds to an x.
function uavRows(id, state) {
  const svg = document.getElementById(id);
  svg.replaceChildren();
  const names = layout.uavs.map((u) => u.name);
  const rowH = 24, left = 90, width = 1600 - left - 10;
  const end = chartEnd(state);
  const height = names.length * rowH + 30;
  svg.setAttribute("viewBox", `0 0 1600 ${height}`);
  const sx = (t) => left + (t / end) * width;
  names.forEach((n, i) => el("text", { class: "label", x: 4, y: 18 + i * rowH }, svg, n));
  return { svg, names, rowH, end, height, sx };
}

function drawGantt(state) {
  const { svg, names, rowH, end, height, sx } = uavRows("gantt", state);
  for (const b of state.bars) {
    const i = names.indexOf(b.uav);
    if (i < 0) continue;
    const e = b.end_s === null ? state.time_s : b.end_s;
    const r = el("rect", { class: "bar " + b.status, x: sx(b.start_s), y: 6 + i * rowH, width: Math.max(sx(e) - sx(b.start_s), 1), height: rowH - 8 }, svg);
    el("title", {}, r, `${b.task_id} (${b.uav}, attempt ${b.attempt}): ${b.start_s.toFixed(1)}-${e.toFixed(1)} s ${b.status}`);
    if (sx(e) - sx(b.start_s) > 28) el("text", { class: "label", x: sx(b.start_s) + 3, y: 20 + i * rowH }, svg, b.task_id);
  }
  timeTicks(svg, sx, end, height);
}

// The reservation table (--airspace table) under the Gantt: one row per UAV, a box per reserved window on the
// same time axis (flights and work full height, the stays it waits in on a lower band; open-ended ones run to
// the axis' end), behind them the holds on its take-offs. Without a table (the columns airspace) it stays hidden.
function drawReserved(state) {
  const box = document.getElementById("reserved-box");
  box.hidden = state.reservations === undefined;
  if (box.hidden) return;
  const { svg, names, rowH, end, height, sx: along } = uavRows("reserved", state);
  const sx = (t) => along(Math.min(Math.max(t, 0), end));
  // the holds on take-offs (the operator's, the wind's) behind the windows, over each row of a UAV they hold
  for (const h of state.holds || []) {
    const t1 = h.t1_s === null ? end : h.t1_s;
    const who = h.uavs.length ? h.uavs.join(", ") : "every UAV";
    for (const u of h.uavs.length ? h.uavs : names) {
      const i = names.indexOf(u);
      if (i < 0) continue;
      const rect = el("rect", { class: `hold ${h.cause}` + (h.released ? " released" : "") + (h.t1_s === null ? " open" : ""), x: sx(h.t0_s), y: 2 + i * rowH, width: Math.max(sx(t1) - sx(h.t0_s), 1), height: rowH - 4, "data-uav": u, "data-cause": h.cause }, svg);
      el("title", {}, rect, `${h.cause} holds ${who} on the ground: ${h.t0_s.toFixed(1)} s to ${h.t1_s === null ? "until lifted" : h.t1_s.toFixed(1) + " s"}`);
    }
  }
  for (const r of state.reservations) {
    const i = names.indexOf(r.uav);
    if (i < 0) continue;
    const t1 = r.t1_s === null ? end : r.t1_s;
    const low = r.purpose === "stay" || r.purpose === "lost";
    const h = (rowH - 8) * (low ? 0.35 : 0.65);
    const cls = `res ${r.purpose}` + (r.released ? " released" : "") + (r.t1_s === null ? " open" : "");
    const rect = el("rect", { class: cls, x: sx(r.t0_s), y: 6 + i * rowH + (rowH - 8) - h, width: Math.max(sx(t1) - sx(r.t0_s), 1), height: h, "data-uav": r.uav, "data-purpose": r.purpose }, svg);
    el("title", {}, rect, `${r.uav} ${r.purpose}${r.task ? " for " + r.task : ""}: ${r.t0_s.toFixed(1)} s to ${r.t1_s === null ? "open-ended" : r.t1_s.toFixed(1) + " s"}${r.released ? " (released)" : ""}`);
  }
  el("line", { class: "now", x1: sx(state.time_s), x2: sx(state.time_s), y1: 0, y2: height - 20 }, svg);
  timeTicks(svg, sx, end, height);
}

function render(state) {
  lastState = state;
  const c = state.counts;
  const total = Object.values(c).reduce((a, b) => a + b, 0);
  document.getElementById("clock").textContent = `t = ${state.time_s.toFixed(1)} s`;
  const counts = document.getElementById("counts");
  counts.textContent = `tasks: ${c.done}/${total} done, ${c.running} running, ${c.todo} to do` + (c.stuck ? `, ${c.stuck} stuck` : "");
  counts.dataset.done = c.done;
  const status = state.completed === null ? (state.paused ? "paused" : "running") : (state.completed ? "completed" : "NOT completed");
  document.getElementById("status").textContent = status;
  const stall = document.getElementById("stall");
  stall.hidden = !state.stall;
  stall.textContent = state.stall || "";
  drawTop(state); drawSide(state); drawGantt(state); drawReserved(state);
  const body = document.querySelector("#uavs tbody");
  body.replaceChildren();
  for (const u of state.uavs) {
    const tr = document.createElement("tr");
    for (const v of [u.name, u.state || "-", u.task_id || "-", u.battery === undefined ? "-" : Math.round(u.battery * 100) + " %", (u.volumes || []).length, u.status || "ok"]) {
      const td = document.createElement("td"); td.textContent = v; tr.appendChild(td);
    }
    body.appendChild(tr);
  }
  drawGlue(state);
  const recent = document.getElementById("recent");
  recent.replaceChildren();
  for (const line of [...state.recent, ...state.operator.slice(-3)]) { const li = document.createElement("li"); li.textContent = line; recent.appendChild(li); }
}

// Each bead waiting for its brick (an adhesive's open time): its age and the open time left, the first to
// expire first; within a minute of expiring it is marked, and a paused mission says which will expire.
const GLUE_SOON_S = 60;
function drawGlue(state) {
  const box = document.getElementById("glue");
  box.hidden = state.glue === undefined;
  if (box.hidden) return;
  const body = box.querySelector("tbody");
  body.replaceChildren();
  for (const g of state.glue) {
    const tr = document.createElement("tr");
    tr.className = g.left_s < 0 ? "expired" : (g.left_s < GLUE_SOON_S ? "soon" : "");
    for (const v of [g.bead, g.brick, g.age_s.toFixed(0), g.left_s.toFixed(0)]) {
      const td = document.createElement("td"); td.textContent = v; tr.appendChild(td);
    }
    body.appendChild(tr);
  }
  const warn = document.getElementById("glue-warning");
  const soon = state.glue.filter((g) => g.left_s < GLUE_SOON_S).map((g) => `${g.bead} (${Math.max(0, g.left_s).toFixed(0)} s)`);
  warn.hidden = !(state.paused && state.glue.length);
  warn.textContent = `paused: the open time runs on; ${soon.length ? "expiring within a minute: " + soon.join(", ") : "first to expire: " + state.glue[0]?.bead + " in " + state.glue[0]?.left_s.toFixed(0) + " s"}`;
}

async function command(body) {
  const r = await fetch("/command", { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });
  const a = await r.json();
  document.getElementById("answer").textContent = `${body.command}${body.uav ? " " + body.uav : ""}: ${a.accepted ? "accepted" : "refused"}${a.reason ? " (" + a.reason + ")" : ""}`;
}

function setupControls() {
  const box = document.getElementById("controls");
  box.hidden = false;
  for (const b of box.querySelectorAll("button[data-command]")) b.onclick = () => command({ command: b.dataset.command });
  const sel = document.getElementById("recall-uav");
  for (const u of layout.uavs) { const o = document.createElement("option"); o.value = o.textContent = u.name; sel.appendChild(o); }
  document.getElementById("recall").onclick = () => command({ command: "recall", uav: sel.value });
}

function setupReplay(end) {
  document.getElementById("replay").hidden = false;
  const slider = document.getElementById("slider");
  slider.max = end;
  const show = async () => render(await (await fetch(`/state.json?at=${slider.value}`)).json());
  slider.oninput = show;
  let timer = null;
  document.getElementById("play").onclick = () => {
    if (timer) { clearInterval(timer); timer = null; return; }
    timer = setInterval(() => { slider.value = Math.min(end, Number(slider.value) + end / 200); show(); if (Number(slider.value) >= end) { clearInterval(timer); timer = null; } }, 100);
  };
  show();
}

async function main() {
  layout = await (await fetch("/layout.json")).json();
  document.getElementById("title").textContent = `masonry: ${layout.name || "mission"}`;
  document.title = `masonry: ${layout.name || "mission"}`;
  if (layout.commands) setupControls();
  if (layout.replay_s !== null && layout.replay_s !== undefined) { setupReplay(layout.replay_s); return; }
  const source = new EventSource("/events");
  source.addEventListener("state", (e) => render(JSON.parse(e.data)));
  source.onerror = () => { document.getElementById("status").textContent = lastState && lastState.completed !== null ? "ended (server closed)" : "disconnected"; };
}

main();
