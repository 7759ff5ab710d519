// The results page: a study's report, its attempts (filterable) and an attempt's trace, step by step.
// Served by `robocog view` it asks the server (/api/...); in a static bundle (`robocog view --bundle`)
// it reads window.ROBOCOG_BUNDLE (data/study.js) and loads each trace as a script (data/traces/N.js),
// which works opened from file:// too, where a page may not fetch.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const bundle = window.ROBOCOG_BUNDLE || null;
  const pathOf = (path) => path.split("/").map(encodeURIComponent).join("/");
  const fileUrl = (index, path) => (bundle ? `files/${index}/${pathOf(path)}` : `/api/attempts/${index}/files/${pathOf(path)}`);

  // An attempt's trace: {ok, body} as the server's answer would be.
  async function loadTrace(index) {
    if (!bundle) {
      const r = await fetch(`/api/attempts/${index}/trace`);
      return { ok: r.ok, body: await r.json() };
    }
    if (!(index in bundle.traces)) {
      await new Promise((resolve) => {
        const s = document.createElement("script");
        s.src = `data/traces/${index}.js`;
        s.onload = resolve;
        s.onerror = resolve;
        document.head.append(s);
      });
    }
    const body = bundle.traces[index];
    return body ? { ok: true, body } : { ok: false, body: { error: "this attempt has no trace file in the bundle" } };
  }
  const state = { study: null, shown: [], open: null };
  window.robocogResults = state;
  const FILTERS = [["f-model", "model"], ["f-family", "family"], ["f-task", "task"], ["f-trial", "trial"], ["f-iteration", "iteration"], ["f-outcome", "outcome"]];
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

  const sorted = (values) => [...new Set(values)].sort((a, b) => (a < b ? -1 : a > b ? 1 : 0));
  function options(id, values) {
    const keep = $(id).value;
    $(id).replaceChildren(el("option", null, "all"));
    $(id).firstChild.value = "";
    for (const v of values) { const o = el("option", null, String(v)); o.value = String(v); $(id).append(o); }
    $(id).value = values.map(String).includes(keep) ? keep : "";
  }

  // The task filter lists the tasks of the family chosen (a suite study has tens of instances).
  function taskOptions() {
    const family = $("f-family").value;
    options("f-task", sorted(state.study.attempts.filter((a) => family === "" || a.family === family).map((a) => a.task)));
  }

  function fillFilters(attempts) {
    const families = sorted(attempts.map((a) => a.family).filter((f) => f));
    $("family-filter").hidden = families.length === 0;
    for (const [id, key] of FILTERS) {
      if (id === "f-task") taskOptions();
      else options(id, key === "family" ? families : sorted(attempts.map((a) => a[key])));
      $(id).addEventListener("change", () => { if (id === "f-family") taskOptions(); list(); });
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
      const cells = [[a.index, ""], [a.model, "name"], [a.task, "name task"], [a.trial, ""], [a.iteration, ""]];
      for (const [c, cls] of cells) {
        const td = el("td", cls || null, String(c));
        if (cls) td.title = String(c); // a long model or instance id is cut to fit; the full name on hover
        tr.append(td);
      }
      const outcome = el("td"); outcome.append(tag(a.outcome)); tr.append(outcome);
      const b = el("td"); b.append(belief(a)); tr.append(b);
      const t = el("td"); t.append(tag(a.true_success ? "success" : "failure")); tr.append(t);
      const done = el("td");
      if (a.feasible === false) done.append(tag("infeasible", "infeasible"));
      else done.append(tag(a.achieved ? "success" : "failure", a.achieved ? "yes" : "no"));
      tr.append(done);
      tr.append(el("td", null, String(a.tool_calls)));
      tr.append(el("td", null, a.has_trace ? "open ›" : a.trace ? "missing" : "–"));
      tr.title = a.error || a.reason || "";
      if (a.has_trace) tr.addEventListener("click", () => openTrace(a.index));
      body.append(tr);
    }
    $("shown-count").textContent = `${state.shown.length} of ${state.study.attempts.length} attempts`;
    if (state.open !== null && !state.shown.some((a) => a.index === state.open)) closeTrace();
  }

  // The trace shown belongs to a row the filters hide: the pane goes back to its hint.
  function closeTrace() {
    state.open = null;
    const pane = $("trace-pane");
    pane.replaceChildren(el("div", "muted", "Pick an attempt with a trace to see it step by step."));
    delete pane.dataset.open;
    history.replaceState(null, "", location.pathname + location.search);
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
        details(li, ev.name, s);
        for (const path of ev.images || []) {
          const img = el("img");
          img.src = fileUrl(index, path);
          img.alt = `${ev.name}: ${path}`;
          img.loading = "lazy";
          li.append(img);
        }
        break;
      }
      case "perturbation": {
        const p = ev.event || {};
        li.classList.add("perturbation");
        head.append(el("b", null, `\u26a0 ${p.kind}`), document.createTextNode(" "),
          tag(p.announced ? "announced" : "silent"), el("span", "small muted", ` during call ${p.call}`));
        li.append(el("div", "small", text(p.description)));
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

  // What a tool result holds beyond its message: search_memory's records as a list, any other
  // fields (look_around's state, a place's positions) as JSON under "details".
  function details(li, name, s) {
    if (name === "search_memory" && Array.isArray(s.results)) {
      const ul = el("ul", "records");
      for (const r of s.results) {
        const item = el("li");
        item.append(tag(r.status || "unknown"), el("b", null, ` ${r.task_description || ""}`));
        if (r.summary) item.append(el("div", "small", cut(String(r.summary))));
        ul.append(item);
      }
      if (s.results.length) li.append(ul);
    }
    const rest = Object.fromEntries(Object.entries(s).filter(([k]) => !["status", "message", "reason"].includes(k) &&
      !(name === "search_memory" && k === "results")));
    if (Object.keys(rest).length === 0) return;
    const box = el("details", "fields");
    box.append(el("summary", "small muted", `details: ${Object.keys(rest).join(", ")}`), el("pre", null, cut(JSON.stringify(rest, null, 1))));
    li.append(box);
  }

  async function openTrace(index) {
    state.open = index;
    for (const tr of $("attempts").tBodies[0].rows) tr.classList.toggle("selected", Number(tr.dataset.index) === index);
    history.replaceState(null, "", `#attempt=${index}`);
    const pane = $("trace-pane");
    pane.replaceChildren(el("div", "muted", "loading the trace…"));
    const a = state.study.attempts[index];
    const r = await loadTrace(index);
    const body = r.body;
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

  // The attempt the address names (#attempt=N), on load and whenever the address changes.
  async function fromHash() {
    const m = /attempt=(\d+)/.exec(location.hash);
    const index = m ? Number(m[1]) : null;
    if (index !== null && index !== state.open && state.study.attempts[index] && state.study.attempts[index].has_trace) {
      await openTrace(index);
    }
  }

  async function start() {
    const study = bundle ? bundle.study : await (await fetch("/api/study", { cache: "no-store" })).json();
    state.study = study;
    document.title = `robocog · ${study.title}`;
    $("study-title").textContent = study.title;
    $("study-count").textContent = `${study.attempts.length} attempts`;
    $("pane-report").innerHTML = study.report_html; // rendered on the server from markdown, raw HTML escaped
    fillFilters(study.attempts);
    list();
    for (const b of document.querySelectorAll(".tabs button")) b.addEventListener("click", () => tab(b.dataset.tab));
    window.addEventListener("hashchange", fromHash);
    await fromHash();
    document.body.dataset.ready = "true";
  }
  start();
})();
