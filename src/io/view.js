"use strict";
// kinechain's page: evaluates the chain from the constants in #model (each joint's child frame is
// parent · origin · M(θ, d) · post, M a rotation by θ about the axis and a translation by d along
// it, eq. 2.119), draws it on a canvas, and writes every link's pose to #poses.
const model = JSON.parse(document.getElementById("model").textContent);
const nq = model.q_names.length;
let q = model.frames[0].slice();
const byChild = new Map(model.joints.map((j) => [j.child, j]));

// 4 × 4 matrices as 16 numbers, row-major.
function mul(a, b) {
  const c = new Array(16).fill(0);
  for (let i = 0; i < 4; i++)
    for (let k = 0; k < 4; k++) {
      const x = a[4 * i + k];
      if (x !== 0) for (let j = 0; j < 4; j++) c[4 * i + j] += x * b[4 * k + j];
    }
  return c;
}
const IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];

function motion(axis, theta, d) {
  // Rodrigues: R = I + sin θ K + (1 − cos θ) K², K the cross-product matrix of the unit axis.
  const [x, y, z] = axis, s = Math.sin(theta), v = 1 - Math.cos(theta);
  return [
    1 - v * (y * y + z * z), -s * z + v * x * y, s * y + v * x * z, d * x,
    s * z + v * x * y, 1 - v * (x * x + z * z), -s * x + v * y * z, d * y,
    -s * y + v * x * z, s * x + v * y * z, 1 - v * (x * x + y * y), d * z,
    0, 0, 0, 1,
  ];
}

function value(j, k) {
  if (j.mimic) return q[j.mimic.q] * j.mimic.multiplier + j.mimic.offset;
  return j.q === null ? 0 : q[j.q + k];
}

function kinematics() {
  const poses = new Map();
  const frames = new Map(); // each moving joint's frame (parent · origin), for its axis
  const pose = (link) => {
    if (poses.has(link)) return poses.get(link);
    const j = byChild.get(link);
    let p = IDENTITY;
    if (j) {
      let theta = j.theta, d = j.d;
      if (j.type === "revolute" || j.type === "continuous") theta += value(j, 0);
      else if (j.type === "prismatic") d += value(j, 0);
      else if (j.type === "cylindrical") { theta += value(j, 0); d += value(j, 1); }
      const f = mul(pose(j.parent), j.origin);
      frames.set(j.name, f);
      p = mul(mul(f, motion(j.axis, theta, d)), j.post);
    }
    poses.set(link, p);
    return p;
  };
  for (const l of model.links) pose(l);
  return { poses, frames };
}

// Camera: orthographic, orbiting about the robot's centre (z up).
const canvas = document.getElementById("view");
const ctx = canvas.getContext("2d");
const camera = { yaw: -0.6, pitch: 0.35, scale: 1, cx: 0, cy: 0, cz: 0 };
let state = kinematics();

function project(p) {
  const x = p[3] - camera.cx, y = p[7] - camera.cy, z = p[11] - camera.cz;
  const cy = Math.cos(camera.yaw), sy = Math.sin(camera.yaw);
  const u = cy * x - sy * y, w = sy * x + cy * y;
  const cp = Math.cos(camera.pitch), sp = Math.sin(camera.pitch);
  const up = cp * z - sp * w;
  return [canvas.width / 2 + camera.scale * u, canvas.height / 2 - camera.scale * up];
}

function fit() {
  const pts = [...state.poses.values()];
  const lo = [0, 1, 2].map((k) => Math.min(...pts.map((p) => p[3 + 4 * k])));
  const hi = [0, 1, 2].map((k) => Math.max(...pts.map((p) => p[3 + 4 * k])));
  [camera.cx, camera.cy, camera.cz] = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2);
  const size = Math.max(0.2, ...[0, 1, 2].map((k) => hi[k] - lo[k]));
  camera.scale = 0.7 * Math.min(canvas.width, canvas.height) / size;
  camera.size = size;
}

function line(a, b, color, width) {
  ctx.strokeStyle = color;
  ctx.lineWidth = width;
  ctx.beginPath();
  ctx.moveTo(...a);
  ctx.lineTo(...b);
  ctx.stroke();
}

function draw() {
  canvas.width = canvas.clientWidth * devicePixelRatio;
  canvas.height = canvas.clientHeight * devicePixelRatio;
  if (!camera.size) fit();
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const triad = 0.08 * camera.size;
  for (const j of model.joints) {
    const a = project(state.poses.get(j.parent)), b = project(state.poses.get(j.child));
    line(a, b, "#555", 4 * devicePixelRatio);
    if (j.type !== "fixed") {
      // The joint axis, at the joint frame's origin.
      const f = state.frames.get(j.name), [x, y, z] = j.axis;
      const dir = [0, 1, 2].map((r) => f[4 * r] * x + f[4 * r + 1] * y + f[4 * r + 2] * z);
      const tip = f.slice();
      for (let r = 0; r < 3; r++) tip[4 * r + 3] += 1.5 * triad * dir[r];
      line(project(f), project(tip), "#d4a017", 2 * devicePixelRatio);
    }
  }
  for (const p of state.poses.values()) {
    const o = project(p);
    ["#e33", "#2a2", "#33e"].forEach((color, c) => {
      const tip = p.slice();
      for (let r = 0; r < 3; r++) tip[4 * r + 3] += triad * p[4 * r + c];
      line(o, project(tip), color, 1.5 * devicePixelRatio);
    });
  }
}

function update() {
  state = kinematics();
  const out = {};
  for (const [link, p] of state.poses) out[link] = p;
  document.getElementById("poses").textContent = JSON.stringify({ q, poses: out });
  document.body.dataset.links = String(state.poses.size);
  for (let i = 0; i < nq; i++) {
    const s = document.getElementById("q" + i);
    if (s && Number(s.value) !== q[i]) s.value = q[i];
    const label = document.getElementById("v" + i);
    if (label) label.textContent = q[i].toFixed(4);
  }
  draw();
}

// Sliders: one per entry of q, within its limits (a full turn where there are none).
const sliders = document.getElementById("sliders");
model.q_names.forEach((name, i) => {
  const [lo, hi] = model.ranges[i];
  const row = document.createElement("div");
  row.className = "row";
  row.innerHTML = `<label for="q${i}"></label><span id="v${i}"></span>` +
    `<input type="range" id="q${i}" min="${lo}" max="${hi}" step="any">`;
  row.querySelector("label").textContent = name;
  const input = row.querySelector("input");
  input.value = q[i];
  input.addEventListener("input", () => { q[i] = Number(input.value); update(); });
  sliders.appendChild(row);
});

// Timeline, for a trajectory.
let frame = 0, playing = false, started = 0;
if (model.frames.length > 1) {
  const t0 = model.times[0];
  const tl = document.getElementById("timeline");
  tl.innerHTML = '<button id="play">play</button> <span id="time"></span>' +
    `<input type="range" id="frame" min="0" max="${model.frames.length - 1}" step="1" value="0" style="width:100%">`;
  const show = (k) => {
    frame = k;
    q = model.frames[k].slice();
    document.getElementById("frame").value = k;
    document.getElementById("time").textContent = ((model.times[k] - t0) / 1e9).toFixed(3) + " s";
    update();
  };
  document.getElementById("frame").addEventListener("input", (e) => show(Number(e.target.value)));
  const step = (now) => {
    if (!playing) return;
    const t = t0 + (now - started) * 1e6;
    let k = frame;
    while (k + 1 < model.frames.length && model.times[k + 1] <= t) k++;
    if (k !== frame) show(k);
    if (k + 1 >= model.frames.length) { playing = false; document.getElementById("play").textContent = "play"; return; }
    requestAnimationFrame(step);
  };
  document.getElementById("play").addEventListener("click", (e) => {
    playing = !playing;
    e.target.textContent = playing ? "pause" : "play";
    if (playing) {
      if (frame + 1 >= model.frames.length) show(0);
      started = performance.now() - (model.times[frame] - t0) / 1e6;
      requestAnimationFrame(step);
    }
  });
  show(0);
}

// Orbit (drag), zoom (wheel), names on hover.
let drag = null;
canvas.addEventListener("mousedown", (e) => { drag = [e.clientX, e.clientY]; });
addEventListener("mouseup", () => { drag = null; });
addEventListener("mousemove", (e) => {
  if (drag) {
    camera.yaw += (e.clientX - drag[0]) * 0.01;
    camera.pitch = Math.max(-1.5, Math.min(1.5, camera.pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    draw();
  }
  const hover = document.getElementById("hover");
  let best = null, dist = 12 * devicePixelRatio;
  for (const [link, p] of state.poses) {
    const [x, y] = project(p);
    const d = Math.hypot(x - e.offsetX * devicePixelRatio, y - e.offsetY * devicePixelRatio);
    if (d < dist && e.target === canvas) { best = link; dist = d; }
  }
  hover.style.display = best ? "block" : "none";
  if (best) {
    hover.textContent = best;
    hover.style.left = e.clientX + 12 + "px";
    hover.style.top = e.clientY + 12 + "px";
  }
});
canvas.addEventListener("wheel", (e) => { e.preventDefault(); camera.scale *= Math.exp(-e.deltaY * 0.001); draw(); });
addEventListener("resize", draw);

// For tests and links: "#q3=0.5" moves slider 3 to 0.5 as a user would.
for (const part of location.hash.slice(1).split("&")) {
  const m = /^q(\d+)=(-?[\d.e+-]+)$/.exec(part);
  if (m) {
    const input = document.getElementById("q" + m[1]);
    if (input) { input.value = m[2]; input.dispatchEvent(new Event("input")); }
  }
}
update();
