"""`robocog view results.jsonl`: browse a study in a web page on loopback.

The page (`robocog.server.viewer`'s `static/results.html`, plain HTML/JS/CSS, offline) shows the
report's tables and figures (rendered once at start by `robocog.agent.analysis.report`, the same as
`robocog report` writes), a filterable list of the attempts (model, task, trial, memory iteration,
outcome), and an attempt's trace step by step, with the pictures its tool results carried (files
next to the trace, `TRACE.images/`). Traces are named relative to the results file; the page can
read only the results file, the traces its rows name, and the files in those traces' folders.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from starlette.applications import Starlette
from starlette.middleware import Middleware
from starlette.middleware.trustedhost import TrustedHostMiddleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from robocog.shared.evaluation import AttemptRow, achieved
from robocog.shared.web import LOOPBACK_HOSTS, VIEWER_STATIC

HOST = "127.0.0.1"
DEFAULT_PORT = 8767
#: Longest trace the page is given whole (bytes); a longer one is cut, with a note.
MAX_TRACE_BYTES = 20_000_000


def report_html(markdown_text: str, prefix: str = "/report/") -> str:
    """The report's markdown as HTML (raw HTML in it is escaped), its figures at `prefix` (served from
    /report/; a static bundle's are in its report/ folder)."""
    from markdown_it import MarkdownIt

    md = MarkdownIt("js-default")
    tokens = md.parse(markdown_text)
    for token in tokens:
        for child in token.children or []:
            src = child.attrGet("src") if child.type == "image" else None
            if isinstance(src, str) and "/" not in src and ":" not in src:
                child.attrSet("src", f"{prefix}{src}")
    return str(md.renderer.render(tokens, md.options, {}))


def attempt_json(index: int, row: AttemptRow, results_dir: Path) -> dict[str, Any]:
    trace = trace_path(row, results_dir)
    return {
        "index": index,
        "model": row.model,
        "task": row.task,
        "family": row.family,
        "trial": row.trial,
        "iteration": row.memory_iteration,
        "outcome": row.outcome,
        "believed_success": row.believed_success,
        "true_success": row.true_success,
        "feasible": row.feasible,
        "achieved": achieved(row),  # the request carried out: never on an infeasible instance
        "agreement": row.agreement,
        "tool_calls": row.tool_calls,
        "invocations": row.invocations,
        "tokens_in": row.tokens_in,
        "tokens_out": row.tokens_out,
        "cost": row.cost,
        "wall_s": row.wall_s,
        "protocol": row.protocol,
        "reason": row.reason,
        "error": row.error,
        "trace": row.trace,
        "has_trace": trace is not None and trace.is_file(),
    }


def trace_path(row: AttemptRow, results_dir: Path) -> Path | None:
    if not row.trace:
        return None
    path = (results_dir / row.trace).resolve()
    return path if path.is_relative_to(results_dir.resolve()) else None


def trace_events(path: Path) -> list[dict[str, Any]]:
    """A trace's events as JSON; a line that is not an event becomes an `unreadable` one."""
    from robocog.shared.trace import parse_event

    events: list[dict[str, Any]] = []
    with path.open(encoding="utf-8", errors="replace") as f:
        text = f.read(MAX_TRACE_BYTES + 1)
    lines = text.splitlines()
    if len(text) > MAX_TRACE_BYTES:
        lines = lines[:-1]
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            events.append(parse_event(line).model_dump(mode="json"))
        except ValueError as exc:
            events.append({"type": "unreadable", "line": number, "reason": str(exc).splitlines()[0]})
    if len(text) > MAX_TRACE_BYTES:
        events.append({"type": "unreadable", "line": len(lines) + 1, "reason": "the trace is cut here (too long)"})
    return events


class ResultsViewer:
    """The web app of one results file; `prepare` renders the report first."""

    def __init__(self, results: Path, *, title: str | None = None) -> None:
        from robocog.agent.analysis.results_file import load_rows

        self.results = results.resolve()
        self.dir = self.results.parent
        self.rows = load_rows(self.results)
        self.title = title or f"robocog study: {results.name}"
        self._tmp = tempfile.TemporaryDirectory(prefix="robocog-view-")
        self.report_dir = Path(self._tmp.name)
        self._report = ""

    def prepare(self) -> None:
        """Render the report's tables and figures (seconds: matplotlib) into a temporary folder."""
        from robocog.agent.analysis.report import render

        if self.rows:
            report = render(self.rows, self.report_dir, title=self.title)
            self._report = report_html(report.read_text(encoding="utf-8"))
        else:
            self._report = "<p>The results file holds no attempts yet.</p>"

    def close(self) -> None:
        self._tmp.cleanup()

    def app(self) -> Starlette:

        routes = [
            Route(
                "/", lambda request: FileResponse(VIEWER_STATIC / "results.html", headers={"Cache-Control": "no-store"})
            ),
            Route("/api/study", self.study),
            Route("/api/attempts/{index:int}/trace", self.trace),
            Route("/api/attempts/{index:int}/files/{path:path}", self.trace_file),
            Mount("/report", StaticFiles(directory=self.report_dir), name="report"),
            Mount("/static", StaticFiles(directory=VIEWER_STATIC), name="static"),
        ]
        middleware = [Middleware(TrustedHostMiddleware, allowed_hosts=LOOPBACK_HOSTS)]
        return Starlette(routes=routes, middleware=middleware)

    async def study(self, request: Request) -> Response:
        return JSONResponse(
            {
                "title": self.title,
                "file": str(self.results),
                "report_html": self._report,
                "attempts": [attempt_json(i, row, self.dir) for i, row in enumerate(self.rows)],
            }
        )

    def _row_trace(self, request: Request) -> Path | None:
        index = request.path_params["index"]
        if not 0 <= index < len(self.rows):
            return None
        path = trace_path(self.rows[index], self.dir)
        return path if path is not None and path.is_file() else None

    async def trace(self, request: Request) -> Response:
        path = self._row_trace(request)
        if path is None:
            return JSONResponse({"error": "this attempt has no trace file"}, status_code=404)
        return JSONResponse({"trace": str(path.relative_to(self.dir)), "events": trace_events(path)})

    async def trace_file(self, request: Request) -> Response:
        """A file in the trace's folder (its pictures), nothing outside it."""
        path = self._row_trace(request)
        if path is None:
            return JSONResponse({"error": "this attempt has no trace file"}, status_code=404)
        folder = path.parent.resolve()
        target = (folder / request.path_params["path"]).resolve()
        if not target.is_relative_to(folder) or not target.is_file():
            return JSONResponse({"error": "no such file next to the trace"}, status_code=404)
        return FileResponse(target)
