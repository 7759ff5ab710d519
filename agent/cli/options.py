"""The options the model-driving commands share (`run`, `chat`, `bench`): the model, how to reach
the server, the live viewer; their checks before anything starts; and the checks of the arguments of
a server robocog spawns (`--server-cmd`, a study's `server_args`)."""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.agent.study_protocols import PROTOCOLS
from robocog.shared.errors import ConfigError

if TYPE_CHECKING:  # only for the annotations: the CLI starts without importing the MCP SDK or LiteLLM
    from robocog.agent.client.connection import ServerSpec
    from robocog.agent.client.settings import AgentSettings

DEFAULT_MODEL = "scripted/planner"

EPILOG = """\
models: any LiteLLM model string, e.g. gpt-4.1, anthropic/claude-sonnet-4-20250514, ollama/qwen3,
openai/<name> with --api-base for a local OpenAI-compatible server (llama.cpp, vLLM, LM Studio; a
placeholder key is sent when none is given). Offline and without a key: scripted/planner (the
default), scripted/overconfident, scripted/refuser, replay/TRACE.jsonl.
"""


def add_connection(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("server")
    g.add_argument("--url", help="connect to a running server over streamable HTTP, e.g. http://127.0.0.1:8765/mcp")
    g.add_argument("--server-cmd", help="command line that starts the server over stdio (default: robocog-server)")
    g.add_argument("--data-dir", help="memory directory for the spawned server")
    g.add_argument("--memory-namespace", help="memory namespace for the spawned server")
    g.add_argument("--seed", type=int, default=None, help="seed for the spawned world and for the model")
    g.add_argument("--scene", help="scene YAML for the spawned server")


def add_model(p: argparse.ArgumentParser) -> None:
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


def add_view(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--view",
        nargs="?",
        type=int,
        const=8766,
        default=None,
        metavar="PORT",
        help="the spawned server also serves the live viewer on http://127.0.0.1:PORT/ (default port: 8766)",
    )


def params(items: list[str]) -> dict[str, Any]:
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


def check_options(args: argparse.Namespace) -> None:
    """The options of `run`, `chat` and `bench`, checked before anything starts (as a study config's
    same fields are); a spawned server's scene is checked here too. `ConfigError` names the option."""
    import shlex

    params(args.param)
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


def settings(args: argparse.Namespace) -> AgentSettings:
    """The model options of `run`, `chat` and `bench` as the loop's settings."""
    from robocog.agent.client.settings import AgentSettings

    return AgentSettings(
        model=args.model,
        max_invocations=args.max_invocations,
        max_steps=args.max_steps,
        timeout_s=args.timeout,
        api_base=args.api_base,
        api_key=args.api_key,
        seed=args.seed,
        temperature=args.temperature,
        params=params(args.param),
        vision=args.vision,
    )


def server_spec(args: argparse.Namespace) -> ServerSpec:
    """How to reach the server for `run`, `chat` and `bench`: a URL, else a spawned eval-profile server."""
    from robocog.agent.client.connection import ServerSpec

    extra = ["--profile", "eval"]  # the client checks ground truth; the model never sees those tools
    for flag, value in (
        ("--data-dir", args.data_dir),
        ("--memory-namespace", args.memory_namespace),
        ("--seed", args.seed),
        ("--scene", args.scene),
        ("--search-k", PROTOCOLS[args.protocol].search_k if args.protocol != "robocog" else None),
        ("--view", getattr(args, "view", None)),
        ("--observe", getattr(args, "observe", None)),
    ):
        if value is not None:
            extra += [flag, str(value)]
    return ServerSpec.from_options(args.url, args.server_cmd, extra if not args.url else [])


def flag_values(argv: Sequence[str], flag: str) -> list[str]:
    """The values given to `flag` in a command line (`--flag VALUE` or `--flag=VALUE`)."""
    values = []
    for i, arg in enumerate(argv):
        if arg == flag and i + 1 < len(argv):
            values.append(argv[i + 1])
        elif arg.startswith(flag + "="):
            values.append(arg.partition("=")[2])
    return values


def check_chroma_reachable(url: str, where: str) -> None:
    """A ConfigError unless something listens at the Chroma server's address `url` (checked before
    any server is spawned: each would otherwise fail on its first memory call)."""
    import socket

    from robocog.shared.memory_names import parse_chroma_url

    try:
        host, port, _ = parse_chroma_url(url)
    except ValueError as exc:
        raise ConfigError(f"{where}: --memory-url: {exc}") from None
    try:
        socket.create_connection((host, port), timeout=3).close()
    except OSError as exc:
        raise ConfigError(
            f"{where}: --memory-url {url}: no Chroma server answers there ({exc.strerror or exc}); start one "
            f"(chroma run --port {port}) or drop --memory-url for embedded memory"
        ) from None


def check_server_args(argv: Sequence[str], *, data_dir: bool, where: str) -> None:
    """Check the robocog-server arguments of a server the client will spawn, before spawning it:
    its `--scene` (and the files that scene names), no `--memory-url` where a `--data-dir` is also
    given, and a Chroma server listening at `--memory-url`. `where` names the arguments' origin in
    the error ("--server-cmd", "study.yaml: server_args")."""
    from robocog.shared.scene_files import load_scene, scene_path

    for scene in flag_values(argv, "--scene"):
        load_scene(scene_path(scene))  # a shipped scene's name, or a path
    if data_dir and flag_values(argv, "--memory-url"):
        raise ConfigError(
            f"{where}: --memory-url cannot be used together with --data-dir: the server either keeps "
            "embedded memory in a directory or uses a Chroma server; give one"
        )
    for url in flag_values(argv, "--memory-url"):
        check_chroma_reachable(url, where)
