// The robot app's page: ext-apps' App on the page's side of the MCP Apps protocol, the live viewer's
// map renderer (assets/viewer/map.js, the one map renderer), and what the host hands over: the robot
// tools' results (structuredContent) and the answers of robot_view, the app's own read-only tool.
// Nothing is templated into the HTML; every name is written as text (textContent, never HTML).
import { App, PostMessageTransport } from "@modelcontextprotocol/ext-apps/app-with-deps";
import "../../viewer/map.js";

const MAX_CALLS = 50;
const MAX_TRAIL = 400;
// Calls after which the last picture no longer shows what the robot's camera sees.
const MOVES = new Set(["move_to", "grab", "place", "open", "close"]);
const $ = (id) => document.getElementById(id);

const view = {
  scene: null, world: null, verdict: null, taskId: null, robotId: null, believed: null,
  trail: [], route: null, calls: 0, lastArgs: null, picture: null, lookAt: -1, movedAt: -1,
  // For the tests and the bench: when each tool result reached the page, and when the map was drawn
  // with the world after it (performance.timeOrigin + performance.now(), milliseconds since the epoch).
  results: [], paints: [],
};
window.robocogApp = view;

const now = () => performance.timeOrigin + performance.now();

function el(tag, cls, content) {
  const e = document.createElement(tag);
  if (cls) e.className = cls;
  if (content !== undefined && content !== null) e.textContent = String(content);
  return e;
}

function text(value) {
  if (value === null || value === undefined) return "";
  return typeof value === "string" ? value : JSON.stringify(value);
}

// Which robot tool a result comes from, by its published output schema (a host hands the page a
// result without the tool's name when it relays more than the call that opened the page).
function toolOf(sc, fallback) {
  if (!sc || typeof sc !== "object") return fallback || "tool";
  if ("path" in sc && "distance_m" in sc) return "move_to";
  if ("direction" in sc && "heading_deg" in sc) return "look";
  if ("record_id" in sc && "episode" in sc) return "end_task";
  if ("locations" in sc && "location" in sc) return "look_around";
  if ("furniture" in sc && "outcome" in sc) {
    return sc.state === "closed" || sc.outcome === "closed" || sc.outcome === "already_closed" ? "close" : "open";
  }
  if ("position" in sc) return "place";
  if ("object" in sc && "holding" in sc) return "grab";
  return fallback || "tool";
}

function argsText(args) {
  if (!args) return "";
  return Object.entries(args).filter(([k]) => k !== "robot_id").map(([k, v]) => `${k}=${text(v)}`).join(", ");
}

function draw() {
  if (!view.scene) return;
  window.RobocogMap.draw($("map"), view.scene, view.world, { trail: view.trail, route: view.route });
}

function showWorld() {
  const r = view.world && view.world.robot;
  if (!r) return;
  $("robot-location").textContent = r.location;
  $("robot-holding").textContent = r.holding || "nothing";
  const map = $("map");
  map.dataset.location = r.location;
  map.dataset.holding = r.holding || "";
  draw();
}

function showVerdict() {
  const box = $("verdict");
  box.replaceChildren();
  if (view.believed) {
    const line = el("div", "line");
    line.append(el("span", "muted", "agent says"), el("span", `tag ${view.believed.status}`, view.believed.status));
    line.append(el("span", "muted", view.believed.summary));
    box.append(line);
  }
  const v = view.verdict;
  if (v) {
    const line = el("div", "line");
    line.append(el("span", "muted", `ground truth ${v.task_id}`));
    line.append(el("span", `tag ${v.success ? "success" : "failure"}`, v.success ? "success" : "failure"));
    line.append(el("span", "muted", v.reason));
    box.append(line);
  }
  if (!view.believed && !v) box.append(el("span", "muted", view.taskId ? "" : "no verdict yet (the task is not known)"));
  box.dataset.truth = v ? String(v.success) : "";
  box.dataset.task = view.taskId || "";
}

function showPicture(image, caption) {
  if (!image || image.mimeType !== "image/png" || typeof image.data !== "string") return;
  view.picture = caption;
  $("camera").src = `data:image/png;base64,${image.data}`;  // data: only: nothing from the network
  $("camera-caption").textContent = caption;
}

function addCall(tool, args, result) {
  const sc = result.structuredContent || {};
  const li = el("li", result.isError ? "error" : "done");
  li.dataset.tool = tool;
  const head = el("div", "head");
  head.append(el("span", "tool", tool), el("span", "args", argsText(args)));
  head.lastChild.title = argsText(args);
  const first = (result.content || []).find((c) => c.type === "text");
  li.append(head, el("div", "message", sc.message !== undefined ? sc.message : first ? first.text : ""));
  const list = $("calls");
  list.prepend(li);
  while (list.children.length > MAX_CALLS) list.lastElementChild.remove();
  view.calls += 1;
  $("call-count").textContent = view.calls;
}

function onResult(result) {
  const received = now();
  const sc = result.structuredContent || {};
  const args = view.lastArgs;
  view.lastArgs = null;
  const tool = toolOf(sc);
  if (typeof sc.robot_id === "string") view.robotId = sc.robot_id;
  addCall(tool, args, result);
  if (tool === "move_to" && Array.isArray(sc.path) && view.scene) {
    const at = window.RobocogMap.locations(view.scene);
    if (view.route) view.trail.push(...view.route);
    if (view.trail.length > MAX_TRAIL) view.trail.splice(0, view.trail.length - MAX_TRAIL);
    view.route = sc.path.filter((n) => at[n]).map((n) => at[n]);
  }
  if (tool === "end_task" && args && args.status) view.believed = { status: args.status, summary: args.summary };
  const picture = (result.content || []).find((c) => c.type === "image");
  if (tool === "look" && picture) showPicture(picture, `what the agent saw: looking ${sc.direction} from ${sc.location}`);
  view.results.push(received);
  if (tool === "look" && picture) view.lookAt = view.results.length;
  if (MOVES.has(tool) && !result.isError) view.movedAt = view.results.length;
  refresh(tool !== "look" && (MOVES.has(tool) || !view.picture));
}

// robot_view through the host: one call at a time; a result meanwhile asks for one more after it.
let busy = false, again = false, againCamera = false;
async function refresh(camera) {
  if (busy) { again = true; againCamera = againCamera || camera; return; }
  busy = true;
  const asked = view.results.length;
  try {
    const args = { scene: !view.scene, camera_frame: Boolean(camera) };
    if (view.robotId) args.robot_id = view.robotId;
    const answer = await app.callServerTool({ name: "robot_view", arguments: args });
    const sc = answer.structuredContent;
    if (answer.isError || !sc) {
      const first = (answer.content || []).find((c) => c.type === "text");
      $("connection").textContent = first ? first.text : "the robot's view is not available";
    } else {
      if (sc.scene) view.scene = sc.scene;
      view.world = sc.world;
      view.verdict = sc.verdict || null;
      view.taskId = sc.task_id || null;
      $("connection").textContent = `episode ${sc.episode}`;
      const frame = (answer.content || []).find((c) => c.type === "image");
      // The live picture, unless the agent's own look is newer than the world's last change.
      if (frame && (view.lookAt < 0 || view.lookAt < view.movedAt)) showPicture(frame, `live, looking ahead from ${sc.world.robot.location}`);
      showWorld();
      showVerdict();
      while (view.paints.length < asked) view.paints.push(now());
      document.body.dataset.ready = "true";
    }
  } catch (e) {
    $("connection").textContent = `no view: ${e && e.message ? e.message : e}`;
  } finally {
    busy = false;
    if (again) { const c = againCamera; again = false; againCamera = false; refresh(c); }
  }
}

const app = new App({ name: "robocog robot", version: "1.0.0" }, {});
app.ontoolinput = (params) => {
  view.lastArgs = params.arguments || {};
  if (typeof view.lastArgs.robot_id === "string") view.robotId = view.lastArgs.robot_id;
};
app.ontoolresult = onResult;
app.ontoolcancelled = () => { view.lastArgs = null; };
app.onhostcontextchanged = () => {};
app.onteardown = async () => ({});
window.addEventListener("resize", draw);

// A host that opened the page for a call hands it that call's input (with the robot's handle, where
// the client has one) and result: the first read waits a moment for them, so that it asks about the
// robot the calls act on (without a handle, a fleet would give the page a robot of its own).
const FIRST_READ_MS = 800;
app.connect(new PostMessageTransport(window.parent, window.parent)).then(
  () => {
    $("connection").textContent = "connected";
    setTimeout(() => { if (!view.world && !busy && view.results.length === 0) refresh(true); }, FIRST_READ_MS);
  },
  (e) => { $("connection").textContent = `not connected: ${e && e.message ? e.message : e}`; },
);
