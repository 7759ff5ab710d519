"""Where trace events go: a JSONL file, the terminal (in the paper's [SYSTEM]/[TOOL] style), a list."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import IO, Any

from rich.console import Console
from rich.markup import escape

from robocog.shared.trace import (
    ModelTurn,
    Perturbed,
    Reinvoked,
    RunFinished,
    RunStarted,
    ToolCall,
    ToolResult,
    TraceEvent,
    Verdict,
    dump_event,
)


def images_dir(trace_path: Path) -> Path:
    """Where the pictures of the trace file `trace_path` are kept: `DIR/run.images/` beside `DIR/run.jsonl`."""
    return trace_path.with_name(trace_path.stem + ".images")


class Trace:
    """Collects a run's events; optionally appends them to a JSONL file and prints them live."""

    def __init__(self, path: Path | None = None, *, console: Console | None = None) -> None:
        self.events: list[TraceEvent] = []
        self.start = time.monotonic()
        self.console = console
        self.path = path
        #: The pictures of this run's tool results, by the reference their `ToolResult.images` holds.
        self.images: dict[str, bytes] = {}
        self._verdict: Verdict | None = None  # printed with the run's outcome, which follows it
        self._file: IO[str] | None = None
        if path is not None:
            path.parent.mkdir(parents=True, exist_ok=True)
            self._file = path.open("a", encoding="utf-8")

    def save_image(self, data: bytes, *, tool: str, mime_type: str = "image/png") -> str:
        """Keep a picture a tool returned and give its reference for the trace: with a trace file
        `DIR/run.jsonl`, the file `DIR/run.images/NNNN-TOOL.png` (the reference is the path relative
        to DIR; numbering goes on from the files there, as the trace file is appended to); without
        one, an in-memory name. The trace itself never holds the bytes."""
        suffix = {"image/png": ".png", "image/jpeg": ".jpg"}.get(mime_type, ".bin")
        if self.path is None:
            reference = f"memory/{len(self.images) + 1:04d}-{tool}{suffix}"
        else:
            folder = images_dir(self.path)
            folder.mkdir(parents=True, exist_ok=True)
            number = sum(1 for _ in folder.iterdir()) + 1
            target = folder / f"{number:04d}-{tool}{suffix}"
            target.write_bytes(data)
            reference = target.relative_to(self.path.parent).as_posix()
        self.images[reference] = data
        return reference

    def now(self) -> float:
        return round(time.monotonic() - self.start, 4)

    def emit(self, event: TraceEvent) -> None:
        self.events.append(event)
        if self._file is not None:
            self._file.write(dump_event(event) + "\n")
            self._file.flush()
        if self.console is not None:
            self._print(event)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    # --- the paper's log style ---------------------------------------------------------------------

    def _line(self, tag: str, style: str, text: str) -> None:
        assert self.console is not None
        self.console.print(f"[{style}]\\[{tag}][/{style}] {escape(text)}", highlight=False, soft_wrap=True)

    def _print(self, event: TraceEvent) -> None:
        if isinstance(event, RunStarted):
            protocol = f" under the {event.protocol} protocol" if event.protocol not in (None, "robocog") else ""
            self._line("SYSTEM", "bold dark_orange", f'Executing prompt: "{event.task}" with {event.model}{protocol}')
        elif isinstance(event, ModelTurn):
            content = event.message.get("content")
            if content:
                self._line("MODEL", "bold magenta", str(content).strip())
        elif isinstance(event, ToolCall):
            args = ", ".join(f"{k}={v!r}" for k, v in (event.arguments or {}).items())
            self._line(
                "TOOL", "bold blue", f"{event.name}({args if event.arguments is not None else event.raw_arguments})"
            )
        elif isinstance(event, ToolResult):
            text = _summarise(event)
            if event.images:
                text += f" [picture{'s' if len(event.images) > 1 else ''}: {', '.join(event.images)}]"
            self._line("TOOL-RESPONSE", "bold red" if event.is_error else "bold green", text)
        elif isinstance(event, Perturbed):
            told = "announced" if event.event.announced else "silent"
            self._line("WORLD", "bold yellow", f"{event.event.description} ({told}, call {event.event.call})")
        elif isinstance(event, Reinvoked):
            self._line("SYSTEM", "bold dark_orange", f"Re-invoking the agent ({event.invocation}): {event.reason}")
        elif isinstance(event, Verdict):
            self._verdict = event
        elif isinstance(event, RunFinished):
            self._finished(event)

    def _finished(self, event: RunFinished) -> None:
        """The verdict (an errored attempt's is "error", never "failure": the model did not fail) and
        the run's counts. The error itself is the caller's to print, once."""
        verdict, self._verdict = self._verdict, None
        if verdict is not None:
            word = "error" if event.outcome == "error" else "success" if verdict.success else "failure"
            why = "the attempt did not finish" if event.outcome == "error" else verdict.reason
            self._line("SYSTEM", "bold dark_orange", f"Test results for task {verdict.task_id}: {word} ({why})")
        if event.outcome == "error":
            head = "Outcome: error (the model service or the server failed)."
        else:
            believed = {True: "success", False: "failure", None: "none (the task was never ended)"}
            head = f"Believed: {believed[event.believed_success]}."
        self._line(
            "SYSTEM",
            "bold dark_orange",
            f"{head} {event.tool_calls} tool calls, {event.invocations} invocation(s), {event.wall_s:.2f} s.",
        )


def _summarise(event: ToolResult) -> str:
    data: dict[str, Any] | None = event.structured
    if data is None:
        return event.content
    message = data.get("message")
    if event.name == "search_memory" and "results" in data:
        lines = [str(message)] + [
            f"  - {r['task_description']} -> {r['status']}: {r['summary']}" for r in data["results"]
        ]
        return "\n".join(lines)
    if event.name == "view_scratchpad":
        return f"{message}\n{data.get('content', '')}"
    if message is not None:
        return f"{data.get('status', '')}: {message}"
    return json.dumps(data)


def make_console(stream: IO[str] | None = None) -> Console:
    """Coloured on a terminal, plain when piped."""
    return Console(file=stream or sys.stdout, highlight=False, soft_wrap=True)
