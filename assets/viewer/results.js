// The results page: a study's report, its attempts (filterable) and an attempt's trace, step by step.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const state = { study: null, shown: [], open: null };
  window.robocogResults = state;
  const FILTERS = [["f-model", "model"], ["f-task", "task"], ["f-trial", "trial"], ["f-iteration", "iteration"], ["f-outcome", "outcome"]];
  const MAX_TEXT = 4000;

  function el(tag, cls, content) {
    const e = document.createElement(tag);
    if (cls) e.className = cls;
    if (content !== undefined && content !== null) e.textContent = content;
    return e;
  }
  const tag = (value, text) => el("span", `tag ${value}`, text === undefined ? String(value) : text);
  const cut = (s) => (s.length > MAX_TEXT ? s.slice(0, MAX_TEXT) + ` … (${s.length - MAX_TEXT} more characters)` : s);
  const text = (v) => (v === null || v === undefined ? "" : typeof v === "string" ? v : JSON.stringify(v, null, 1));

  function tab(name) {
    for (const b of document.querySelectorAll(".tabs button")) b.classList.toggle("active", b.dataset.tab === name);
    $("pane-attempts").hidden = name !== "attempts";
    $("pane-report").hidden = name !== "report";
  }

  function fillFilters(attempts) {
    for (const [id, key] of FILTERS) {
      const values = [...new Set(attempts.map((a) => a[key]))].sort((a, b) => (a < b ? -1 : a > b ? 1 : 0));
      for (const v of values) { const o = el("option", null, String(v)); o.value = String(v); $(id).append(o); }
      $(id).addEventListener("change", list);
    }
    $("f-truth").addEventListener("change", list);
  }

  function belief(a) {
    if (a.believed_success === null) return tag("stopped", "never ended");
    return tag(a.believed_success ? "success" : "failure", a.believed_success ? "success" : "failure");
  }

  function list() {
    const body = $("attempts").tBodies[0];
    body.replaceChildren();
    const want = FILTERS.map(([id, key]) => [key, $(id).value]);
    const truth = $("f-truth").value;
    state.shown = state.study.attempts.filter(
      (a) => want.every(([key, v]) => v === "" || String(a[key]) === v) && (truth === "" || String(a.true_success) === truth)
    );
    for (const a of state.shown) {
      const tr = el("tr", a.has_trace ? "" : "notrace");
      tr.dataset.index = a.index;
      if (state.open === a.index) tr.classList.add("selected");
      const cells = [a.index, a.model, a.task, a.trial, a.iteration];
      for (const c of cells) tr.append(el("td", null, String(c)));
      const outcome = el("td"); outcome.append(tag(a.outcome)); tr.append(outcome);
      const b = el("td"); b.append(belief(a)); tr.append(b);
      const t = el("td"); t.append(tag(a.true_success ? "success" : "failure")); tr.append(t);
      tr.append(el("td", null, String(a.tool_calls)));
      tr.append(el("td", null, a.has_trace ? "open ›" : a.trace ? "missing" : "–"));
      tr.title = a.error || a.reason || "";
      if (a.has_trace) tr.addEventListener("click", () => openTrace(a.index));
      body.append(tr);
    }
    $("shown-count").textContent = `${state.shown.length} of ${state.study.attempts.length} attempts`;
  }

  function step(ev, index) {
    const li = el("li");
    li.dataset.type = ev.type;
    const head = el("div");
    const kind = el("span", "kind", ev.type.replace("_", " "));
    head.append(kind);
    li.append(head);
    const pre = (s) => li.append(el("pre", null, cut(s)));
    switch (ev.type) {
      case "run_started":
        head.append(el("b", null, ev.task));
        li.append(el("div", "small muted", `model ${ev.model} · protocol ${ev.protocol} · tools ${ev.tools.join(", ")}`));
        break;
      case "model_turn": {
        head.append(el("span", "small muted", `invocation ${ev.invocation}, step ${ev.step} · ${ev.latency_s.toFixed(2)} s · ${ev.tokens_in}/${ev.tokens_out} tokens`));
        const content = ev.message && ev.message.content;
        if (content) pre(text(content));
        break;
      }
      case "tool_call":
        head.append(el("b", "tool", ev.name));
        head.append(el("span", "small", ` ${ev.arguments ? Object.entries(ev.arguments).map(([k, v]) => `${k}=${text(v)}`).join(", ") : ev.raw_arguments}`));
        break;
      case "tool_result": {
        head.append(el("b", "tool", ev.name), document.createTextNode(" "), tag(ev.is_error ? "error" : "success", ev.is_error ? "error" : "ok"));
        head.append(el("span", "small muted", ` ${(1000 * ev.latency_s).toFixed(0)} ms`));
        const s = ev.structured || {};
        pre(s.message || s.reason || ev.content);
        for (const path of ev.images || []) {
          const img = el("img");
          img.src = `/api/attempts/${index}/files/${path.split("/").map(encodeURIComponent).join("/")}`;
          img.alt = `${ev.name}: ${path}`;
          img.loading = "lazy";
          li.append(img);
        }
        break;
      }
      case "reinvoked":
        head.append(el("span", null, `invocation ${ev.invocation}: ${ev.reason}`));
        break;
      case "verdict":
        head.append(el("span", null, `ground truth ${ev.task_id} `), tag(ev.success ? "success" : "failure"));
        li.append(el("div", "small", ev.reason));
        break;
      case "run_finished":
        head.append(tag(ev.outcome));
        li.append(el("div", "small muted",
          `believed ${ev.believed_success} · true ${ev.true_success} · ${ev.tool_calls} tool calls · ${ev.invocations} invocations · ${ev.wall_s.toFixed(1)} s` +
          (ev.error ? ` · ${ev.error}` : "")));
        break;
      default:
        head.append(el("span", null, `line ${ev.line}: ${ev.reason}`));
    }
    return li;
  }

  async function openTrace(index) {
    state.open = index;
    for (const tr of $("attempts").tBodies[0].rows) tr.classList.toggle("selected", Number(tr.dataset.index) === index);
    history.replaceState(null, "", `#attempt=${index}`);
    const pane = $("trace-pane");
    pane.replaceChildren(el("div", "muted", "loading the trace…"));
    const a = state.study.attempts[index];
    const r = await fetch(`/api/attempts/${index}/trace`);
    const body = await r.json();
    pane.replaceChildren();
    const head = el("div", "trace-head");
    head.append(el("h2", null, `${a.model} · ${a.task} · trial ${a.trial} · iteration ${a.iteration}`));
    const line = el("div");
    line.append(tag(a.outcome), document.createTextNode(" believed "), belief(a), document.createTextNode(" truth "),
      tag(a.true_success ? "success" : "failure"), el("span", "small muted", ` ${a.reason || ""}`));
    head.append(line);
    pane.append(head);
    if (!r.ok) { pane.append(el("div", "muted", body.error)); return; }
    head.append(el("div", "small muted", body.trace));
    const steps = el("ol", "steps");
    steps.id = "steps";
    for (const ev of body.events) steps.append(step(ev, index));
    pane.append(steps);
    pane.dataset.open = String(index);
  }

  async function start() {
    const r = await fetch("/api/study", { cache: "no-store" });
    const study = await r.json();
    state.study = study;
    document.title = `robocog · ${study.title}`;
    $("study-title").textContent = study.title;
    $("study-count").textContent = `${study.attempts.length} attempts`;
    $("pane-report").innerHTML = study.report_html; // rendered on the server from markdown, raw HTML escaped
    fillFilters(study.attempts);
    list();
    for (const b of document.querySelectorAll(".tabs button")) b.addEventListener("click", () => tab(b.dataset.tab));
    const m = /attempt=(\d+)/.exec(location.hash);
    if (m && study.attempts[Number(m[1])] && study.attempts[Number(m[1])].has_trace) await openTrace(Number(m[1]));
    document.body.dataset.ready = "true";
  }
  start();
})();
