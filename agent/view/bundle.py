"""`robocog view results.jsonl --bundle DIR`: the results viewer as a static site, no server.

The bundle is the viewer's own page (`assets/viewer/results.html` and its script), with what the
server would answer written as script files the page loads by `<script>` (so it works opened from
`file://`, where a page may not fetch, and from any static host):

    DIR/index.html             the page (every address in it relative)
    DIR/static/                its script and style sheet
    DIR/data/study.js          the study: title, the report as HTML, the attempts
    DIR/data/traces/N.js       attempt N's trace, step by step
    DIR/files/N/...            the pictures attempt N's trace names (its TRACE.images/ files)
    DIR/report/                the report (`robocog report`): report.md, the figures, the CSVs

It holds only the results file's rows, the traces they name and the pictures those traces name.
"""

from __future__ import annotations

import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robocog.agent.view.serve import attempt_json, report_html, trace_events, trace_path
from robocog.shared.web import VIEWER_STATIC

#: Where the page reads a bundle's data: `window.ROBOCOG_BUNDLE` (set by data/study.js).
GLOBAL = "window.ROBOCOG_BUNDLE"


@dataclass(frozen=True)
class BundleStats:
    """What a bundle holds: its page, its files, their bytes, the traces and pictures in it, and the
    seconds it took to write."""

    index: Path
    files: int
    bytes: int
    traces: int
    pictures: int
    seconds: float


def _script(statement: str, value: Any) -> str:
    """A line of JavaScript assigning `value` as JSON (`</` escaped, so no text can end a script)."""
    text = json.dumps(value, ensure_ascii=False).replace("</", "<\\/")
    return f"{statement} = {text};\n"


def page() -> str:
    """The viewer's page with relative addresses, loading the bundle's data before its script."""
    html = (VIEWER_STATIC / "results.html").read_text(encoding="utf-8")
    html = html.replace('href="/static/', 'href="static/').replace('src="/static/', 'src="static/')
    script = '<script src="static/results.js"></script>'
    if script not in html:
        raise ValueError("the viewer's page does not load static/results.js")
    return html.replace(script, f'<script src="data/study.js"></script>\n{script}')


def _pictures(events: list[dict[str, Any]], folder: Path) -> list[tuple[str, Path]]:
    """The pictures a trace's events name (relative to the trace's folder) that are files inside it."""
    found = []
    for ev in events:
        for name in ev.get("images") or [] if ev.get("type") == "tool_result" else []:
            target = (folder / str(name)).resolve()
            if target.is_relative_to(folder) and target.is_file():
                found.append((str(name), target))
    return found


def write_bundle(results: Path, out: Path, *, title: str | None = None) -> BundleStats:
    """Write the static bundle of the study in `results` into `out` (created; a bundle there is
    replaced); raises FileNotFoundError or ValueError (a row that does not read) before writing."""
    from robocog.agent.analysis.report import render
    from robocog.agent.analysis.results_file import load_rows

    started = time.perf_counter()
    rows = load_rows(results)
    base = results.resolve().parent
    title = title or f"robocog study: {results.name}"
    if out.exists() and not (out / "data" / "study.js").is_file() and any(out.iterdir()):
        raise ValueError(f"{out} is a folder that holds something else than a bundle: give an empty or new one")
    for part in ("data", "files", "report", "static"):
        shutil.rmtree(out / part, ignore_errors=True)
    (out / "data" / "traces").mkdir(parents=True)
    (out / "static").mkdir()
    if rows:
        report = report_html(render(rows, out / "report", title=title).read_text(encoding="utf-8"), prefix="report/")
    else:
        report = "<p>The results file holds no attempts yet.</p>"
    attempts = [attempt_json(i, row, base) for i, row in enumerate(rows)]
    traces = pictures = 0
    for i, row in enumerate(rows):
        path = trace_path(row, base)
        if path is None or not path.is_file():
            continue
        events = trace_events(path)
        trace = {"trace": str(path.relative_to(base)), "events": events}
        (out / "data" / "traces" / f"{i}.js").write_text(_script(f"{GLOBAL}.traces[{i}]", trace), encoding="utf-8")
        traces += 1
        for name, source in _pictures(events, path.parent.resolve()):
            target = out / "files" / str(i) / name
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, target)
            pictures += 1
    study = {"title": title, "file": results.name, "report_html": report, "attempts": attempts}
    (out / "data" / "study.js").write_text(_script(GLOBAL, {"study": study, "traces": {}}), encoding="utf-8")
    for name in ("results.js", "style.css"):
        shutil.copyfile(VIEWER_STATIC / name, out / "static" / name)
    index = out / "index.html"
    index.write_text(page(), encoding="utf-8")
    written = [p for p in out.rglob("*") if p.is_file()]
    return BundleStats(
        index=index,
        files=len(written),
        bytes=sum(p.stat().st_size for p in written),
        traces=traces,
        pictures=pictures,
        seconds=time.perf_counter() - started,
    )
