"""`robocog run TASK...` (tasks in order, in one world) and what `robocog chat` shares with it: the
episode loop over a spawned or running server, each task judged by the server where it can be."""

from __future__ import annotations

import argparse
import asyncio
import sys
import threading
from collections.abc import Sequence
from typing import Any

from robocog.agent.cli.options import (
    EPILOG,
    add_connection,
    add_model,
    add_view,
    check_options,
    server_spec,
)
from robocog.agent.cli.options import (
    settings as agent_settings,
)
from robocog.agent.cli.preflight import check_model, check_task_words, free_viewer_port, memory_line, unknown_task_id
from robocog.agent.study_protocols import PROTOCOLS

#: What a run under a protocol other than robocog's says at its start.
PROTOCOL_NOTES = {
    "paper": "the paper's messages and system prompt, one conversation across the tasks, the scratchpad kept, "
    "top-5 memory retrieval (numbers comparable with the paper's)",
}


#: What `robocog chat` says before its first prompt.
CHAT_GREETING = "Type a task (or a task id such as T1); an empty line, /quit or Ctrl-D ends the session."


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p = add_session_parser(sub, "run", "run one or more tasks in order, in one world")
    p.add_argument("tasks", nargs="+", metavar="TASK", help="an instruction, or a task id such as T1")
    return p


def main(args: argparse.Namespace) -> int:
    return start(args, args.tasks)


def add_session_parser(sub: Any, name: str, help: str) -> argparse.ArgumentParser:
    """The subcommand `name` of a session with one robot (`run`, `chat`): the model, the connection
    and the live viewer's options."""
    p: argparse.ArgumentParser = sub.add_parser(
        name, help=help, epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_model(p)
    add_connection(p)
    add_view(p)
    p.add_argument(
        "--observe",
        choices=("location", "room", "house"),
        default=None,
        help="what look_around shows: the robot's location, its room, or the whole house (the server's "
        "default: house); with --url the world is reset to set it (an eval-profile server)",
    )
    return p


def start(args: argparse.Namespace, tasks: Sequence[str] | None) -> int:
    """What `run` and `chat` do: check the options (and the tasks' words), say what the run uses,
    import LiteLLM while the server starts, then run `tasks` (None: those typed at the prompt)."""
    check_model(args.model, args.api_base, args.api_key)  # first: a wrong model is the likeliest mistake
    check_options(args)
    if tasks is not None:
        check_task_words(tasks)
    prepare(args)
    loader = preload_litellm(args.model)  # seconds: start at once
    if tasks is None:
        print(CHAT_GREETING)
    return asyncio.run(run_tasks(args, tasks, loader))


def prepare(args: argparse.Namespace) -> None:
    """What `run` and `chat` check and say before the server starts: the model (LiteLLM must know
    its provider), the live viewer's port (free; 0 picks one), then which memory the run uses and
    how many records it holds, and the protocol when it is the paper's."""
    check_model(args.model, args.api_base, args.api_key)
    if getattr(args, "view", None) is not None:
        args.view = free_viewer_port(args.view)
    if not args.url:
        print(memory_line(args.data_dir, args.memory_namespace, args.server_cmd), file=sys.stderr)
    if args.protocol != "robocog":
        print(f"robocog: protocol {args.protocol}: {PROTOCOL_NOTES[args.protocol]}", file=sys.stderr)


def preload_litellm(model: str) -> threading.Thread:
    """Import LiteLLM and what the model's route loads (seconds) on a thread while the server starts."""

    from robocog.agent.client.model import warm_up_litellm

    thread = threading.Thread(target=warm_up_litellm, args=([model],), daemon=True)
    thread.start()
    return thread


async def run_tasks(args: argparse.Namespace, tasks: Sequence[str] | None, loader: threading.Thread | None) -> int:
    """Run `tasks` in order (or, when None, the tasks typed at the prompt) in one world."""
    from robocog.agent.client.connection import connect
    from robocog.agent.client.loop import finish, run_episode
    from robocog.agent.client.model import check_credentials
    from robocog.agent.client.trace_sinks import Trace, make_console
    from robocog.shared.controls import EvalControls, mcp_call
    from robocog.shared.errors import ModelServiceError, ServerConnectionError
    from robocog.shared.trace import Verdict

    settings = agent_settings(args)
    protocol = PROTOCOLS[args.protocol]
    console = make_console()
    ok = True
    conversation: list[dict[str, Any]] = []  # carried from task to task under the paper's protocol
    async with connect(server_spec(args)) as robot:
        if getattr(args, "view", None):  # announced once the page answers, not before
            viewer = f"http://127.0.0.1:{args.view}/"
            answered = await asyncio.to_thread(page_answers, viewer)
            print(
                f"robocog: live viewer at {viewer}"
                if answered
                else f"robocog: the live viewer at {viewer} "
                f"did not answer within {VIEWER_WAIT_S:g} s; the run goes on without it",
                file=sys.stderr,
            )
        controls = EvalControls(mcp_call(robot.client, ServerConnectionError))
        await robot.claim()  # a full fleet: one line and exit 2, before the model starts
        if loader is not None:
            await asyncio.to_thread(loader.join)
        try:
            check_credentials(settings.model, settings.api_base, settings.api_key)
        except ModelServiceError as exc:
            print(f"robocog: {exc}", file=sys.stderr)
            return 2
        observe = getattr(args, "observe", None)
        if observe is not None and args.url:  # a running server: its reset_world sets it
            if not robot.can_check:
                print("robocog: --observe with --url needs a server with --profile eval", file=sys.stderr)
                return 2
            await controls.reset_world(observe=observe)
        if not robot.can_check:
            print(
                f"robocog: the server at {robot.label} has no ground truth for the client (it runs without "
                "--profile eval): no task is checked, and no 'Test results' line follows",
                file=sys.stderr,
            )
        pending = list(tasks) if tasks is not None else None
        while True:
            task: str | None
            if pending is not None:
                task = pending.pop(0) if pending else None
            else:
                task = await asyncio.to_thread(_ask)
            if task is None:
                break
            problem = unknown_task_id(task, robot.tasks) if pending is None and robot.tasks else None
            if problem is not None:  # typed at the prompt: say so, and ask again
                print(f"robocog: {problem}", file=sys.stderr)
                continue
            prompt = robot.tasks.get(task, task)
            task_id = robot.task_id_for(prompt)
            if robot.can_check and task_id is not None:  # the task's own episode, judged on its own
                await controls.begin_task(task_id, keep_scratchpad=protocol.keep_scratchpad)
            trace = Trace(args.trace, console=None if args.quiet else console)
            result = await run_episode(
                robot.client,
                prompt,
                settings,
                trace,
                system_prompt=await robot.prompt(protocol.system_prompt),
                tools=robot.tools,
                server_label=robot.label,
                protocol=protocol,
                conversation=conversation if protocol.continue_conversation else [],
            )
            verdict = None
            if robot.can_check and task_id is not None:
                checked = await controls.check_task(task_id)
                verdict = Verdict(t=trace.now(), task_id=task_id, success=checked.success, reason=checked.reason)
            finished = finish(trace, result, verdict)
            trace.close()
            if args.quiet and result.error:
                print(f"{task_id or prompt}: error, {result.tool_calls} tool calls")
            elif args.quiet:
                truth = "unknown" if verdict is None else ("success" if verdict.success else "failure")
                believed = {True: "success", False: "failure", None: "never ended"}[result.believed_success]
                print(f"{task_id or prompt}: believed {believed}, ground truth {truth}, {result.tool_calls} tool calls")
            if result.text_tool_calls:
                from robocog.agent.client.slips import text_calls_notice

                print(f"robocog: {text_calls_notice(settings.model, result.text_tool_calls)}", file=sys.stderr)
            if result.error:
                print(f"robocog: {result.error}", file=sys.stderr)
            ok = ok and finished.ended and bool(finished.believed_success) and finished.true_success is not False
        if getattr(args, "view", None):
            await keep_viewing(f"http://127.0.0.1:{args.view}/")
    return 0 if ok else 1


#: How long `robocog run --view` waits for the viewer's page to answer before it says so.
VIEWER_WAIT_S = 20.0


def page_answers(url: str, timeout_s: float = VIEWER_WAIT_S) -> bool:
    """Whether `url` (the live viewer's page, on loopback) answers 200 within `timeout_s`."""
    import time
    import urllib.error
    import urllib.request

    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(url, timeout=2) as answer:
                if answer.status == 200:
                    return True
        except (OSError, urllib.error.URLError):
            pass
        time.sleep(0.1)
    return False


async def keep_viewing(url: str) -> None:
    """After the run, keep the server (and its live viewer) up until Ctrl-C or SIGTERM."""
    import signal

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    print(f"robocog: the run is over; the live viewer stays at {url} until Ctrl-C", file=sys.stderr, flush=True)
    try:
        await stop.wait()
    finally:
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.remove_signal_handler(sig)


def _ask() -> str | None:
    try:
        text = input("task> ").strip()
    except EOFError:
        return None
    if text in ("", "/quit", "/exit", "quit", "exit"):
        return None  # an empty line ends the session, as the banner says
    return text
