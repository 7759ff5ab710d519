// The live page: the world's state and the tool calls as server-sent events (GET /api/events).
// Bounded: at most MAX_ROWS rows in the stream, MAX_TRAIL points of the robot's path.
"use strict";

(function () {
  const MAX_ROWS = 200;
  const MAX_TRAIL = 400;
  const MAX_TIMES = 2000;
  // Calls after which the last picture the agent got no longer shows the world as it is.
  const MOVES = new Set(["move_to", "grab", "place", "reset_world", "begin_task"]);
  // The eval profile's controls (robocog.shared.protocol.CONTROL_TOOLS): a harness's, not the agent's.
  const CONTROLS = new Set(["reset_world", "begin_task", "check_task", "clear_memory"]);
  const $ = (id) => document.getElementById(id);
  const view = {
    scene: null, world: null, seq: 0, stateSeq: 0, calls: 0,
    trail: [], route: null, blocked: [], rows: new Map(), source: null, look: null, lastMove: 0,
    // For tests and the bench: when each result reached the page (Date.now(), in order).
    resultTimes: [], stateTimes: [],
  };
  window.robocog = view;

  function status(text, kind) {
    const el = $("connection");
    el.textContent = text; el.className = `pill ${kind}`;
  }

  function text(value) {
    if (value === null || value === undefined) return "";
    return typeof value === "string" ? value : JSON.stringify(value);
  }

  function argsText(args) {
    if (!args) return "";
    return Object.entries(args).map(([k, v]) => `${k}=${text(v)}`).join(", ");
  }

  function el(tag, cls, content) {
    const e = document.createElement(tag);
    if (cls) e.className = cls;
    if (content !== undefined) e.textContent = content;
    return e;
  }

  function addCall(ev) {
    const li = el("li", "call pending");
    li.dataset.seq = ev.seq; li.dataset.tool = ev.tool;
    const head = el("div", "call-head");
    head.append(el("span", "tool", ev.tool), el("span", "args", argsText(ev.arguments)), el("span", "ms", ""));
    head.querySelector(".args").title = argsText(ev.arguments);
    li.append(head, el("div", "summary", ""));
    if (ev.client) li.title = `called by ${ev.client}`;
    const list = $("stream");
    list.prepend(li);
    view.rows.set(ev.seq, li);
    while (list.children.length > MAX_ROWS) {
      const last = list.lastElementChild;
      view.rows.delete(Number(last.dataset.seq));
      last.remove();
    }
    return li;
  }

  function addResult(ev) {
    let li = view.rows.get(ev.call);
    if (!li) li = addCall({ seq: ev.call, tool: ev.tool, arguments: null });
    li.classList.remove("pending");
    li.classList.add(ev.is_error ? "error" : "done");
    li.dataset.result = ev.seq;
    li.querySelector(".ms").textContent = `${Math.round(ev.duration_ms)} ms`;
    const summary = li.querySelector(".summary");
    summary.textContent = text(ev.summary);
    summary.title = text(ev.summary);
    if (ev.image) {
      const img = el("img", "thumb");
      img.src = `/api/images/${ev.seq}.png`; img.alt = `${ev.tool} image`;
      li.append(img);
    }
    if (ev.tool === "move_to" && ev.structured && Array.isArray(ev.structured.path) && view.scene) {
      const at = RobocogMap.locations(view.scene);
      if (view.route) view.trail.push(...view.route);
      if (view.trail.length > MAX_TRAIL) view.trail.splice(0, view.trail.length - MAX_TRAIL);
      view.route = ev.structured.path.filter((n) => at[n]).map((n) => at[n]);
    }
    if (Array.isArray(ev.perturbations)) for (const p of ev.perturbations) addPerturbation(p);
    if (ev.verdicts) verdict(ev.verdicts);
    if (ev.image) view.look = { seq: ev.seq, tool: ev.tool, what: ev.structured ? ev.structured.direction : "" };
    else if (MOVES.has(ev.tool) && !ev.is_error) view.lastMove = ev.seq;
    if (ev.tool === "reset_world" || ev.tool === "begin_task") { view.trail = []; view.route = null; }
    if (ev.tool === "reset_world") { view.blocked = []; draw(); }
    if (!CONTROLS.has(ev.tool)) view.calls += 1; // the agent's calls: a harness's begin_task or check_task is not one
    $("call-count").textContent = view.calls;
    view.resultTimes.push(Date.now());
    if (view.resultTimes.length > MAX_TIMES) view.resultTimes.splice(0, view.resultTimes.length - MAX_TIMES);
  }

  // Something went wrong in the world during a call (a slip, an object moved, a door closed, a way
  // blocked): a marked row above the call's, saying whether the agent was told.
  function addPerturbation(p) {
    const li = el("li", "perturbation");
    li.dataset.kind = p.kind;
    const head = el("div", "call-head");
    head.append(el("span", "tool", "\u26a0 world"), el("span", "args", p.kind),
      el("span", `tag ${p.announced ? "announced" : "silent"}`, p.announced ? "announced" : "silent"));
    li.append(head, el("div", "summary", `${text(p.description)} (call ${p.call})`));
    $("stream").prepend(li);
    if (p.kind === "block_edge" && Array.isArray(p.edge)) {  // the map crosses out a blocked corridor
      const key = p.edge.slice().sort().join("|");
      view.blocked = view.blocked.filter((e) => e.slice().sort().join("|") !== key);
      if (!p.ended) view.blocked.push(p.edge);
      draw();
    }
  }

  function verdict(v) {
    const box = $("verdict");
    box.replaceChildren();
    if (v.believed) {
      const line = el("div", "line");
      line.append(el("span", "muted", "agent says"), el("span", `tag ${v.believed.status}`, v.believed.status || "?"));
      line.append(el("span", "small", text(v.believed.summary)));
      box.append(line);
    }
    if (v.truth) {
      const ok = v.truth.success;
      const line = el("div", "line");
      line.append(el("span", "muted", `ground truth${v.truth.task_id ? " " + v.truth.task_id : ""}`));
      line.append(el("span", `tag ${ok ? "success" : "failure"}`, ok ? "success" : "failure"));
      line.append(el("span", "small", text(v.truth.reason)));
      box.append(line);
    }
    if (!v.believed && !v.truth) box.append(el("span", "muted", "no verdict yet"));
    box.dataset.truth = v.truth ? String(v.truth.success) : "";
    box.dataset.believed = v.believed ? String(v.believed.status) : "";
  }

  function setWorld(world) {
    view.world = world;
    const r = world.robot;
    $("robot-location").textContent = r.location;
    $("robot-holding").textContent = r.holding || "nothing";
    const map = $("map");
    map.dataset.robotX = r.xyz[0].toFixed(3); map.dataset.robotY = r.xyz[1].toFixed(3);
    map.dataset.location = r.location;
    draw();
    camera();
  }

  function draw() {
    if (view.scene) RobocogMap.draw($("map"), view.scene, view.world, { trail: view.trail, route: view.route, blocked: view.blocked });
  }

  // The camera: one request at a time; a newer world while one loads asks again once it is done.
  let cameraBusy = false, cameraAgain = false;
  function camera() {
    if (cameraBusy) { cameraAgain = true; return; }
    cameraBusy = true; cameraAgain = false;
    const img = $("camera");
    let dir = $("camera-direction").value;
    const where = view.world ? view.world.robot.location : "?";
    const done = () => { cameraBusy = false; if (cameraAgain) camera(); };
    let caption = `live, looking ${dir} from ${where}`, src;
    if (dir === "agent" && view.look && view.look.seq > view.lastMove) {
      caption = `what the agent saw: ${view.look.tool} ${view.look.what || ""} (call #${view.look.seq})`;
      src = `/api/images/${view.look.seq}.png`;
    } else {
      if (dir === "agent") {
        dir = "ahead";
        caption = `live, looking ahead from ${where}` + (view.look ? " (the world changed since the agent's last look)" : "");
      }
      src = `/api/camera.png?direction=${encodeURIComponent(dir)}&v=${view.stateSeq}`;
    }
    img.onload = () => { $("camera-caption").textContent = caption; img.dataset.shows = src; done(); };
    img.onerror = () => { $("camera-caption").textContent = "no camera image"; done(); };
    if (img.dataset.shows === src) { done(); return; }
    img.src = src;
  }

  function handle(ev) {
    view.seq = Math.max(view.seq, ev.seq);
    if (ev.kind === "call") addCall(ev);
    else if (ev.kind === "result") addResult(ev);
    else if (ev.kind === "state") {
      view.stateSeq = ev.seq;
      if (ev.verdicts) verdict(ev.verdicts);
      setWorld(ev.world);
      view.stateTimes.push(Date.now());
      if (view.stateTimes.length > MAX_TIMES) view.stateTimes.splice(0, view.stateTimes.length - MAX_TIMES);
    }
    else if (ev.kind === "gap") { restart(); }
  }

  function listen() {
    if (view.source) view.source.close();
    const source = new EventSource(`/api/events?after=${view.seq}`);
    view.source = source;
    for (const kind of ["call", "result", "state", "gap"]) {
      source.addEventListener(kind, (e) => handle(JSON.parse(e.data)));
    }
    source.onopen = () => status("live", "ok");
    source.onerror = () => status("reconnecting…", "wait");
  }

  async function fetchJson(url) {
    for (;;) {
      try {
        const r = await fetch(url, { cache: "no-store" });
        const body = await r.json();
        if (r.ok) return body;
        status(body.reason || `error ${r.status}`, "wait");
      } catch (e) {
        status("server unreachable", "bad");
      }
      await new Promise((ok) => setTimeout(ok, 700));
    }
  }

  async function restart() {
    if (view.source) { view.source.close(); view.source = null; }
    const now = await fetchJson("/api/state");
    if (!view.scene) view.scene = await fetchJson("/api/scene");
    $("stream").replaceChildren(); view.rows.clear();
    view.seq = now.seq; view.calls = now.calls - now.events.filter((e) => e.kind === "result").length;
    for (const ev of now.events) handle(ev);
    view.seq = now.seq;
    $("call-count").textContent = now.calls;
    view.calls = now.calls;
    verdict(now.verdicts || {});
    setWorld(now.world);
    listen();
    document.body.dataset.ready = "true";
  }

  $("camera-direction").addEventListener("change", camera);
  window.addEventListener("resize", draw);
  restart();
})();
