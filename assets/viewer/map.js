// The top-down map, drawn on a canvas from the scene's geometry (GET /api/scene) and a world
// snapshot (the ground truth: robot, objects). No library; world metres to pixels, y up.
"use strict";

window.RobocogMap = (function () {
  function rgb(c, alpha) {
    const a = alpha === undefined ? (c[3] === undefined ? 1 : c[3]) : alpha;
    return `rgba(${Math.round(c[0] * 255)},${Math.round(c[1] * 255)},${Math.round(c[2] * 255)},${a})`;
  }

  function transform(canvas, bounds) {
    const [x0, y0, x1, y1] = bounds;
    const pad = 10;
    const s = Math.min((canvas.width - 2 * pad) / (x1 - x0), (canvas.height - 2 * pad) / (y1 - y0));
    const ox = (canvas.width - s * (x1 - x0)) / 2, oy = (canvas.height - s * (y1 - y0)) / 2;
    return { s, px: (x) => ox + (x - x0) * s, py: (y) => canvas.height - oy - (y - y0) * s };
  }

  // Fit the canvas's backing store to its displayed size (sharp on any screen).
  function fit(canvas) {
    const r = canvas.getBoundingClientRect(), d = window.devicePixelRatio || 1;
    const w = Math.max(200, Math.round(r.width * d)), h = Math.max(150, Math.round(r.height * d));
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    return d;
  }

  // draw(canvas, scene, world, {trail: [[x,y],...], route: [[x,y],...]})
  function draw(canvas, scene, world, extra) {
    const d = fit(canvas);
    const ctx = canvas.getContext("2d");
    const T = transform(canvas, scene.bounds);
    const font = (px, weight) => `${weight || ""} ${Math.round(px * d)}px system-ui, sans-serif`;
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    for (const r of scene.rooms) {
      ctx.fillStyle = rgb(r.color);
      ctx.fillRect(T.px(r.x[0]), T.py(r.y[1]), (r.x[1] - r.x[0]) * T.s, (r.y[1] - r.y[0]) * T.s);
      ctx.fillStyle = "#888"; ctx.font = font(12, "italic");
      ctx.fillText(r.name, T.px(r.x[0]) + 6 * d, T.py(r.y[1]) + 16 * d);
    }
    ctx.strokeStyle = "#555"; ctx.lineCap = "butt";
    for (const w of scene.walls) {
      ctx.lineWidth = Math.max(2 * d, w.thickness * T.s);
      ctx.beginPath(); ctx.moveTo(T.px(w.start[0]), T.py(w.start[1])); ctx.lineTo(T.px(w.end[0]), T.py(w.end[1])); ctx.stroke();
    }
    for (const f of scene.furniture) for (const p of f.parts) {
      ctx.fillStyle = rgb(p.color, 0.6);
      ctx.fillRect(T.px(p.center[0] - p.size[0] / 2), T.py(p.center[1] + p.size[1] / 2), p.size[0] * T.s, p.size[1] * T.s);
    }
    ctx.setLineDash([4 * d, 3 * d]); ctx.strokeStyle = "#777"; ctx.lineWidth = d;
    for (const p of scene.positions) {
      ctx.strokeRect(T.px(p.center[0] - p.size[0] / 2), T.py(p.center[1] + p.size[1] / 2), p.size[0] * T.s, p.size[1] * T.s);
    }
    ctx.setLineDash([]);
    const loc = {};
    for (const l of scene.locations) loc[l.name] = l;
    ctx.strokeStyle = "rgba(43,138,62,0.6)"; ctx.lineWidth = 1.5 * d;
    for (const [a, b] of scene.edges) {
      if (!loc[a] || !loc[b]) continue;
      ctx.beginPath(); ctx.moveTo(T.px(loc[a].x), T.py(loc[a].y)); ctx.lineTo(T.px(loc[b].x), T.py(loc[b].y)); ctx.stroke();
    }
    const line = (pts, color, width, dash) => {
      if (!pts || pts.length < 2) return;
      ctx.strokeStyle = color; ctx.lineWidth = width * d; ctx.setLineDash(dash ? dash.map((v) => v * d) : []);
      ctx.beginPath(); ctx.moveTo(T.px(pts[0][0]), T.py(pts[0][1]));
      for (const p of pts.slice(1)) ctx.lineTo(T.px(p[0]), T.py(p[1]));
      ctx.stroke(); ctx.setLineDash([]);
    };
    extra = extra || {};
    line(extra.trail, "rgba(232,89,12,0.35)", 3, [6, 4]);
    line(extra.route, "rgba(232,89,12,0.95)", 3.5);
    // A corridor blocked by a perturbation: a thick red line crossed out at its middle.
    canvas.dataset.blocked = JSON.stringify(extra.blocked || []);
    for (const [a, b] of extra.blocked || []) {
      if (!loc[a] || !loc[b]) continue;
      line([[loc[a].x, loc[a].y], [loc[b].x, loc[b].y]], "rgba(201,42,42,0.9)", 4, [8, 4]);
      const mx = T.px((loc[a].x + loc[b].x) / 2), my = T.py((loc[a].y + loc[b].y) / 2), k = 7 * d;
      ctx.strokeStyle = "#c92a2a"; ctx.lineWidth = 3 * d;
      ctx.beginPath(); ctx.moveTo(mx - k, my - k); ctx.lineTo(mx + k, my + k); ctx.moveTo(mx + k, my - k); ctx.lineTo(mx - k, my + k); ctx.stroke();
    }
    for (const l of scene.locations) {
      ctx.fillStyle = "#2b8a3e"; ctx.beginPath(); ctx.arc(T.px(l.x), T.py(l.y), 4.5 * d, 0, 2 * Math.PI); ctx.fill();
    }
    // Location names start past the robot's footprint (the circle around it, whatever its yaw) and
    // are drawn last, with a halo: the robot standing at a location never hides the start of its name.
    // The canvas keeps the boxes it drew (dataset.labels, dataset.robot: canvas pixels), so a test can
    // hold that no name starts under the robot.
    const reach = (Math.hypot(...scene.robot.size) / 2) * T.s;
    const clear = Math.max(7 * d, reach + 4 * d);
    const labels = () => {
      ctx.font = font(11); ctx.lineJoin = "round"; ctx.lineWidth = 3 * d; ctx.strokeStyle = "rgba(255,255,255,0.85)";
      ctx.fillStyle = "#1e6b2f";
      const boxes = [];
      for (const l of scene.locations) {
        const x = T.px(l.x) + clear, y = T.py(l.y) + 14 * d;
        ctx.strokeText(l.name, x, y);
        ctx.fillText(l.name, x, y);
        boxes.push({ name: l.name, x0: x, x1: x + ctx.measureText(l.name).width, y0: y - 11 * d, y1: y });
      }
      canvas.dataset.labels = JSON.stringify(boxes);
    };
    if (!world) { labels(); return; }
    // Furniture that opens: its carcass outlined by its state (green open, red closed), the state above
    // it; what a closed one holds is drawn all the same (the map is ground truth), labelled "(inside)".
    canvas.dataset.furniture = JSON.stringify((world.furniture || []).map((f) => [f.name, f.state, f.contents]));
    for (const f of world.furniture || []) {
      const body = scene.furniture.find((g) => g.name === f.name);
      if (!body) continue;
      const p = body.parts[0], open = f.state === "open";
      ctx.strokeStyle = open ? "#2b8a3e" : "#c92a2a"; ctx.lineWidth = 3 * d; ctx.setLineDash(open ? [5 * d, 3 * d] : []);
      ctx.strokeRect(T.px(p.center[0] - p.size[0] / 2), T.py(p.center[1] + p.size[1] / 2), p.size[0] * T.s, p.size[1] * T.s);
      ctx.setLineDash([]);
      ctx.font = font(10, "bold"); ctx.fillStyle = open ? "#2b8a3e" : "#c92a2a"; ctx.textAlign = "center";
      ctx.fillText(f.state, T.px(p.center[0]), T.py(p.center[1] + p.size[1] / 2) - 3 * d);
      ctx.textAlign = "start";
    }
    const robot = world.robot;
    const stacked = [];  // label anchors: objects within 0.4 m of one (a shelf's layers) share it, a line each
    const objects = world.objects.slice().sort((a, b) => b.xyz[2] - a.xyz[2]);
    for (const o of objects) {
      const spec = scene.objects[o.object] || { color: [0.5, 0.5, 0.5, 1], size: [0.1, 0.1] };
      let x = o.xyz[0], y = o.xyz[1];
      if (o.state === "held") { x = robot.xyz[0]; y = robot.xyz[1]; }
      let anchor = stacked.find((a) => Math.abs(a.x - x) < 0.4 && Math.abs(a.y - y) < 0.4);
      if (!anchor) { anchor = { x, y, n: 0 }; stacked.push(anchor); }
      const slot = anchor.n++;
      const half = Math.max(5 * d, (spec.size[0] * T.s) / 2);
      ctx.fillStyle = rgb(spec.color, 1); ctx.strokeStyle = "#000"; ctx.lineWidth = d;
      if (o.state !== "held") {
        ctx.fillRect(T.px(x) - half, T.py(y) - half, 2 * half, 2 * half);
        ctx.strokeRect(T.px(x) - half, T.py(y) - half, 2 * half, 2 * half);
        ctx.fillStyle = "#111"; ctx.font = font(11, "bold");
        ctx.fillText(o.object + (o.position ? ` (${o.position})` : ""), T.px(anchor.x) + half + 3 * d, T.py(anchor.y) - half + (4 + 12 * slot) * d);
      }
    }
    const [sx, sy] = scene.robot.size;
    const rx = T.px(robot.xyz[0]), ry = T.py(robot.xyz[1]);
    ctx.save(); ctx.translate(rx, ry); ctx.rotate(-robot.yaw);
    ctx.fillStyle = "rgba(31,111,235,0.9)"; ctx.fillRect((-sx / 2) * T.s, (-sy / 2) * T.s, sx * T.s, sy * T.s);
    ctx.strokeStyle = "#fff"; ctx.lineWidth = 2 * d;
    ctx.beginPath(); ctx.moveTo(0, 0); ctx.lineTo((sx / 2) * T.s, 0); ctx.stroke();
    ctx.restore();
    if (robot.holding) {
      const spec = scene.objects[robot.holding] || { color: [0.5, 0.5, 0.5, 1] };
      ctx.fillStyle = rgb(spec.color, 1); ctx.strokeStyle = "#fff"; ctx.lineWidth = 2 * d;
      ctx.beginPath(); ctx.arc(rx, ry, 7 * d, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    }
    // Its own name above the circle it turns in (not above the square: turned, a corner passes it).
    const name = robot.holding ? `robot holding ${robot.holding}` : "robot", baseline = ry - reach - 4 * d;
    ctx.font = font(12, "bold"); ctx.textAlign = "center"; ctx.lineJoin = "round"; ctx.lineWidth = 3 * d;
    ctx.strokeStyle = "rgba(255,255,255,0.85)"; ctx.strokeText(name, rx, baseline);
    ctx.fillStyle = "#1f6feb"; ctx.fillText(name, rx, baseline);
    ctx.textAlign = "start";
    canvas.dataset.robot = JSON.stringify({ x: rx, y: ry, r: reach, label: baseline });
    labels();
  }

  function locations(scene) {
    const out = {};
    for (const l of scene.locations) out[l.name] = [l.x, l.y];
    return out;
  }

  return { draw, locations };
})();
