"""`robocog`: drive the robot with any model through LiteLLM (`run`, `chat`), evaluate, report."""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import sys
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # only for the annotations: the CLI starts without importing LiteLLM
    from robocog.agent.connection import ServerSpec
    from robocog.agent.loop import AgentSettings

from robocog.agent.protocols import PROTOCOLS

DEFAULT_MODEL = "scripted/planner"

EPILOG = """\
models: any LiteLLM model string, e.g. gpt-4.1, anthropic/claude-sonnet-4-20250514, ollama/qwen3,
openai/<name> with --api-base for a local OpenAI-compatible server (llama.cpp, vLLM, LM Studio; a
placeholder key is sent when none is given). Offline and without a key: scripted/planner (the
default), scripted/overconfident, scripted/refuser, replay/TRACE.jsonl.
"""


def _add_connection(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("server")
    g.add_argument("--url", help="connect to a running server over streamable HTTP, e.g. http://127.0.0.1:8765/mcp")
    g.add_argument("--server-cmd", help="command line that starts the server over stdio (default: robocog-server)")
    g.add_argument("--data-dir", help="memory directory for the spawned server")
    g.add_argument("--memory-namespace", help="memory namespace for the spawned server")
    g.add_argument("--seed", type=int, default=None, help="seed for the spawned world and for the model")
    g.add_argument("--scene", help="scene YAML for the spawned server")


def _add_model(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("model")
    g.add_argument("--model", default=DEFAULT_MODEL, help=f"LiteLLM model string (default: {DEFAULT_MODEL})")
    g.add_argument(
        "--api-base", help="base URL of the model server, e.g. http://127.0.0.1:8000/v1 (llama.cpp, vLLM, a proxy)"
    )
    g.add_argument(
        "--api-key",
        help="the model service's key (default: the provider's usual variable, e.g. OPENAI_API_KEY; "
        "with --api-base and no key, a placeholder for keyless local servers)",
    )
    g.add_argument("--temperature", type=float, default=None)
    g.add_argument(
        "--protocol",
        choices=["robocog", "paper"],
        default="robocog",
        help="'paper': the paper's messages, system prompt, one conversation across the tasks, the scratchpad "
        "kept, top-5 retrieval; 'robocog' (default): the improved protocol",
    )
    g.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="extra completion parameter (JSON value), repeatable, e.g. --param p=0.5",
    )
    g.add_argument(
        "--vision",
        action="store_true",
        help="the model takes images: show it the pictures tools return (look's camera view); "
        "without it, a one-line note stands in for each picture",
    )
    g.add_argument("--max-invocations", type=int, default=10, help="re-invocations before a refusal (default 10)")
    g.add_argument("--max-steps", type=int, default=60, help="model turns per invocation (default 60)")
    g.add_argument("--timeout", type=float, default=180.0, help="seconds per model or tool call (default 180)")
    g.add_argument("--trace", type=Path, help="append every event as JSON lines to this file")
    g.add_argument("--quiet", action="store_true", help="print only the verdicts")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="robocog",
        description="Drive the robocog household robot with any model, over MCP.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser(
        "run",
        help="run one or more tasks in order, in one world",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.add_argument("tasks", nargs="+", metavar="TASK", help="an instruction, or a task id such as T1")
    _add_model(run)
    _add_connection(run)
    _add_view(run)
    chat = sub.add_parser(
        "chat",
        help="type tasks one after another to the same robot",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    _add_model(chat)
    _add_connection(chat)
    _add_view(chat)
    ev = sub.add_parser("eval", help="run a study (the paper's protocol) from a YAML config")
    ev.add_argument("config", type=Path, help="study config, e.g. assets/eval/scripted.yaml")
    ev.add_argument("--out", type=Path, help="results file (JSONL); default: the config's `out`")
    ev.add_argument(
        "--workers", type=int, help="episodes in flight at once, each on a robot of its own (default: config)"
    )
    ev.add_argument(
        "--isolation",
        choices=["process", "fleet"],
        help="'process': a server process per worker (over stdio); 'fleet': a few fleet servers (HTTP, a robot "
        "per worker, ~37 MB each instead of ~370 MB) (default: config, else process)",
    )
    ev.add_argument(
        "--fleet-processes",
        type=int,
        metavar="P",
        help="fleet servers to spawn with --isolation fleet (default: cores)",
    )
    ev.add_argument(
        "--url",
        metavar="URL[,URL...]",
        help="drive the robots of running fleet servers (robocog-server --transport http --profile eval --robots N; "
        "worker i on the i-th URL mod their number, each with robots for its share) instead of spawning servers",
    )
    ev.add_argument("--resume", action="store_true", help="continue an interrupted run")
    ev.add_argument("--trials", type=int, help="override the config's number of trials")
    ev.add_argument("--memory-iterations", type=int, help="override the config's memory iterations")
    ev.add_argument("--server-cmd", help="command line that starts a server over stdio (default: robocog-server)")
    ev.add_argument("--protocol", choices=["robocog", "paper"], help="override the config's protocol")
    ev.add_argument(
        "--allow-errors",
        action="store_true",
        help="exit 0 even when attempts errored (a model service or server failure; --resume reruns them)",
    )
    ev.add_argument("--quiet", action="store_true", help="no progress bar")
    ev.add_argument(
        "--ray",
        nargs="?",
        const="",
        default=None,
        metavar="ADDRESS",
        help="run the units on a Ray cluster, e.g. --ray 10.0.0.5:6379 (no address: $RAY_ADDRESS, else the "
        "cluster `ray start` began here); --workers actors each own a robot (needs robocog[ray])",
    )
    b = sub.add_parser("bench", help="time a server as an agent sees it (episode, each tool, the model calls)")
    b.add_argument("--task", default="T1", help="task id to run (default T1)")
    b.add_argument("--runs", type=int, default=5, help="episodes, each from a fresh world (default 5)")
    _add_model(b)
    _add_connection(b)
    rep = sub.add_parser("report", help="tables, figures and a CSV from a results file")
    rep.add_argument("results", type=Path, help="results file written by robocog eval")
    rep.add_argument("--out", type=Path, required=True, help="directory for report.md, the figures and the CSV")
    rep.add_argument("--title", default=None, help="the report's title")
    rep.add_argument(
        "--csv",
        choices=("ours", "upstream"),
        default="ours",
        help="results.csv: our values (default) or the published encoding (0/1, tasks 1/2, trials from 1)",
    )
    vw = sub.add_parser("view", help="browse a study in a web page: tables, figures, attempts and their traces")
    vw.add_argument("results", type=Path, help="results file written by robocog eval")
    vw.add_argument("--port", type=int, default=8767, help="port on 127.0.0.1 (default: 8767; 0 picks a free one)")
    vw.add_argument("--title", default=None, help="the report's title")
    st = sub.add_parser("suite", help="the robocog suite: generate a split's instances, list families and instances")
    from robocog.agent.suite import add_arguments as add_suite_arguments

    add_suite_arguments(st)
    con = sub.add_parser(
        "contract", help="dump a server's MCP contract, or check it against a baseline (any MCP server)"
    )
    from robocog.agent.contract import add_arguments as add_contract_arguments

    add_contract_arguments(con)
    return parser


def _add_view(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--view",
        nargs="?",
        type=int,
        const=8766,
        default=None,
        metavar="PORT",
        help="the spawned server also serves the live viewer on http://127.0.0.1:PORT/ (default port: 8766)",
    )


def _params(items: list[str]) -> dict[str, Any]:
    from robocog.shared.errors import ConfigError

    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"--param: wants KEY=VALUE, got {item!r}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
        if isinstance(out[key], float) and not math.isfinite(out[key]):
            raise ConfigError(f"--param: {key}: must be a finite number, not {value}")
    return out


def _check_options(args: argparse.Namespace) -> None:
    """The options of `run`, `chat` and `bench`, checked before anything starts (as a study config's
    same fields are); a spawned server's scene is checked here too. `ConfigError` names the option."""
    import shlex

    from robocog.agent.commands import check_server_args
    from robocog.shared.errors import ConfigError

    _params(args.param)
    for flag, value in (("--max-invocations", args.max_invocations), ("--max-steps", args.max_steps)):
        if value < 1:
            raise ConfigError(f"{flag}: must be at least 1, not {value}")
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise ConfigError(f"--timeout: must be a positive number of seconds, not {args.timeout}")
    if args.temperature is not None and not (math.isfinite(args.temperature) and args.temperature >= 0):
        raise ConfigError(f"--temperature: must be a finite number, at least 0, not {args.temperature}")
    if getattr(args, "runs", 1) < 1:
        raise ConfigError(f"--runs: must be at least 1, not {args.runs}")
    if getattr(args, "view", None) is not None and not 0 <= args.view <= 65535:
        raise ConfigError(f"--view: {args.view} is not a port number (0-65535)")
    if args.url:
        for flag, value in (
            ("--server-cmd", args.server_cmd),
            ("--scene", args.scene),
            ("--data-dir", args.data_dir),
            ("--memory-namespace", args.memory_namespace),
            ("--view", getattr(args, "view", None)),
        ):
            if value is not None:
                raise ConfigError(
                    f"--url and {flag} cannot be used together: {flag} configures a server robocog starts, "
                    "--url connects to one already running"
                )
        return
    try:
        command = shlex.split(args.server_cmd) if args.server_cmd else []
    except ValueError as exc:
        raise ConfigError(f"--server-cmd: {exc}") from None
    scene = ["--scene", args.scene] if args.scene is not None else []
    check_server_args(command + scene, data_dir=args.data_dir is not None, where="--server-cmd")


def _settings(args: argparse.Namespace) -> AgentSettings:
    """The model options of `run`, `chat` and `bench` as the loop's settings."""
    from robocog.agent.loop import AgentSettings

    return AgentSettings(
        model=args.model,
        max_invocations=args.max_invocations,
        max_steps=args.max_steps,
        timeout_s=args.timeout,
        api_base=args.api_base,
        api_key=args.api_key,
        seed=args.seed,
        temperature=args.temperature,
        params=_params(args.param),
        vision=args.vision,
    )


def _server_spec(args: argparse.Namespace) -> ServerSpec:
    """How to reach the server for `run`, `chat` and `bench`: a URL, else a spawned eval-profile server."""
    from robocog.agent.connection import ServerSpec

    extra = ["--profile", "eval"]  # the client checks ground truth; the model never sees those tools
    for flag, value in (
        ("--data-dir", args.data_dir),
        ("--memory-namespace", args.memory_namespace),
        ("--seed", args.seed),
        ("--scene", args.scene),
        ("--search-k", PROTOCOLS[args.protocol].search_k if args.protocol != "robocog" else None),
        ("--view", getattr(args, "view", None)),
    ):
        if value is not None:
            extra += [flag, str(value)]
    return ServerSpec.from_options(args.url, args.server_cmd, extra if not args.url else [])


def _preload_litellm(model: str) -> threading.Thread:
    """Import LiteLLM and what the model's route loads (seconds) on a thread while the server starts."""

    from robocog.agent.model import warm_up_litellm

    thread = threading.Thread(target=warm_up_litellm, args=([model],), daemon=True)
    thread.start()
    return thread


async def _run_tasks(args: argparse.Namespace, tasks: Sequence[str] | None, loader: threading.Thread | None) -> int:
    """Run `tasks` in order (or, when None, the tasks typed at the prompt) in one world."""
    from robocog.agent.connection import connect
    from robocog.agent.loop import finish, run_episode
    from robocog.agent.model import check_credentials
    from robocog.agent.trace import Trace, make_console
    from robocog.shared.errors import ModelServiceError
    from robocog.shared.trace import Verdict

    settings = _settings(args)
    protocol = PROTOCOLS[args.protocol]
    console = make_console()
    ok = True
    conversation: list[dict[str, Any]] = []  # carried from task to task under the paper's protocol
    if getattr(args, "view", None):
        print(f"robocog: live viewer at http://127.0.0.1:{args.view}/", file=sys.stderr)
    async with connect(_server_spec(args)) as robot:
        if loader is not None:
            await asyncio.to_thread(loader.join)
        try:
            check_credentials(settings.model, settings.api_base, settings.api_key)
        except ModelServiceError as exc:
            print(f"robocog: {exc}", file=sys.stderr)
            return 2
        pending = list(tasks) if tasks is not None else None
        while True:
            task: str | None
            if pending is not None:
                task = pending.pop(0) if pending else None
            else:
                task = await asyncio.to_thread(_ask)
            if task is None:
                break
            prompt = robot.tasks.get(task, task)
            task_id = robot.task_id_for(prompt)
            if robot.can_check and task_id is not None:  # the task's own episode, judged on its own
                await robot.client.call_tool(
                    "begin_task", {"task_id": task_id, "keep_scratchpad": protocol.keep_scratchpad}
                )
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
                checked = await robot.client.call_tool("check_task", {"task_id": task_id})
                data = checked.structured_content or {}
                verdict = Verdict(
                    t=trace.now(),
                    task_id=task_id,
                    success=bool(data.get("success")),
                    reason=str(data.get("reason", "")),
                )
            finished = finish(trace, result, verdict)
            trace.close()
            if args.quiet:
                truth = "unknown" if verdict is None else ("success" if verdict.success else "failure")
                believed = {True: "success", False: "failure", None: "never ended"}[result.believed_success]
                print(f"{task_id or prompt}: believed {believed}, ground truth {truth}, {result.tool_calls} tool calls")
            if result.error:
                print(f"robocog: {result.error}", file=sys.stderr)
            ok = ok and finished.ended and bool(finished.believed_success) and finished.true_success is not False
    return 0 if ok else 1


def _ask() -> str | None:
    try:
        text = input("task> ").strip()
    except EOFError:
        return None
    if text in ("", "/quit", "/exit", "quit", "exit"):
        return None if text else _ask()
    return text


def _bench(args: argparse.Namespace) -> int:
    from robocog.agent.bench import bench
    from robocog.agent.model import warm_up_litellm
    from robocog.shared.errors import ConfigError, ModelServiceError

    settings = _settings(args)
    warm_up_litellm([settings.model])  # not part of what is measured
    try:
        figures = asyncio.run(bench(_server_spec(args), settings, args.task, args.runs))
    except (ConfigError, ModelServiceError) as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(figures, indent=2))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from robocog.shared.errors import ConfigError, ServerConnectionError

    try:
        if args.command in ("run", "chat", "bench"):
            _check_options(args)
    except ConfigError as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    loader = _preload_litellm(args.model) if args.command in ("run", "chat") else None  # seconds: start at once
    try:
        if args.command == "run":
            return asyncio.run(_run_tasks(args, args.tasks, loader))
        if args.command == "chat":
            print("Type a task (or a task id such as T1); an empty line or /quit ends the session.")
            return asyncio.run(_run_tasks(args, None, loader))
        if args.command == "eval":
            from robocog.agent.commands import eval_command

            return eval_command(args)
        if args.command == "report":
            from robocog.agent.commands import report_command

            return report_command(args)
        if args.command == "bench":
            return _bench(args)
        if args.command == "view":
            from robocog.agent.view import view_command

            return view_command(args)
        if args.command == "suite":
            from robocog.agent.suite import suite_command

            return suite_command(args)
        if args.command == "contract":
            from robocog.agent.contract import main as contract_main

            return contract_main(args)
    except KeyboardInterrupt:
        return 130
    except (ConfigError, ServerConnectionError) as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    except (OSError, BaseExceptionGroup) as exc:
        from robocog.agent.connection import leaf_message

        leaf = exc
        while isinstance(leaf, BaseExceptionGroup) and leaf.exceptions:
            leaf = leaf.exceptions[0]
        if isinstance(leaf, ConfigError | ServerConnectionError):  # it says what happened itself
            print(f"robocog: {leaf}", file=sys.stderr)
        else:
            print(f"robocog: cannot reach the robot server: {leaf_message(exc)}", file=sys.stderr)
        return 2
    return 2


def run() -> None:
    """Console-script entry point: exit as soon as the work is done and written (traces and results
    are closed by then), instead of waiting for LiteLLM's logging worker to wind down (about 2 s)."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    run()
