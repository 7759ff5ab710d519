"""`robocog eval` and `robocog report`: run a study from its config, and render its results."""

from __future__ import annotations

import argparse
import asyncio
import sys
from collections.abc import Sequence


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

    from robocog.server.memory.names import parse_chroma_url
    from robocog.shared.errors import ConfigError

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
    from robocog.shared.errors import ConfigError
    from robocog.shared.scene import load_scene, scene_path

    for scene in flag_values(argv, "--scene"):
        load_scene(scene_path(scene))  # a shipped scene's name, or a path
    if data_dir and flag_values(argv, "--memory-url"):
        raise ConfigError(
            f"{where}: --memory-url cannot be used together with --data-dir: the server either keeps "
            "embedded memory in a directory or uses a Chroma server; give one"
        )
    for url in flag_values(argv, "--memory-url"):
        check_chroma_reachable(url, where)


def eval_command(args: argparse.Namespace) -> int:
    """Run `robocog eval CONFIG`; returns the exit code."""
    import shlex

    from pydantic import ValidationError

    from robocog.shared.errors import ConfigError, ModelServiceError, ServerConnectionError
    from robocog.shared.evaluation import AttemptRow, EvalConfig, load_config

    ray_address = getattr(args, "ray", None)
    if ray_address is not None:
        import importlib.util

        if importlib.util.find_spec("ray") is None:  # the optional extra (robocog.agent.distributed.NEEDS_RAY)
            print("robocog: --ray needs Ray: pip install 'robocog[ray]'", file=sys.stderr)
            return 2
    try:
        config = load_config(args.config)
    except ConfigError as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    overrides = {
        "trials": args.trials,
        "memory_iterations": args.memory_iterations,
        "protocol": args.protocol,
        "workers": args.workers,
        "isolation": args.isolation,
        "fleet_processes": args.fleet_processes,
    }
    updates = {k: v for k, v in overrides.items() if v is not None}
    try:  # validated exactly as the same values in the file would be
        config = EvalConfig.model_validate({**config.model_dump(), **updates})
    except ValidationError as exc:
        problem = exc.errors()[0]
        flag = "--" + str(problem["loc"][0]).replace("_", "-")
        print(f"robocog: {flag}: {problem['msg']}", file=sys.stderr)
        return 2
    try:  # every worker's server gets these: a bad one would fail each of them at start
        command = shlex.split(args.server_cmd or "")
        origins = ((config.server_args, f"{args.config}: server_args"), (command, "--server-cmd"))
        for argv, where in origins:
            # The harness gives each server its own --data-dir (unless --memory-url names a Chroma server).
            check_server_args(argv, data_dir=False, where=where)
            if flag_values(argv, "--data-dir"):
                raise ConfigError(f"{where}: --data-dir is set per worker by the harness; drop it")
    except ValueError as exc:  # ConfigError, or shlex's unbalanced quotes
        print(f"robocog: {exc if isinstance(exc, ConfigError) else f'--server-cmd: {exc}'}", file=sys.stderr)
        return 2
    if args.out is not None:
        out, origin = args.out, "--out"
    elif config.out is not None:
        out, origin = (args.config.parent / config.out).resolve(), f"{args.config}: out"
    else:
        print("robocog: no results file: give --out or set `out` in the config", file=sys.stderr)
        return 2
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"robocog: {origin}: cannot create {out.parent}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    server = command or None  # split above, where it was checked
    # Imported once the config holds (the MCP client takes seconds to import).
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.progress import Progress as ProgressBar

    from robocog.agent.evaluation import Progress, errored, run_eval, summary_line

    with ProgressBar(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        disable=args.quiet,
    ) as bar:
        task = bar.add_task(config.name, total=None, rate="")

        def show(p: Progress) -> None:
            rate = f"success {p.successes}/{p.attempts} ({p.successes / p.attempts:.0%})" if p.attempts else ""
            rate += f", {p.errors} errored" if p.errors else ""
            bar.update(task, completed=p.done, total=p.total, rate=rate)

        def warn(row: AttemptRow) -> None:
            where = f"{row.model} trial {row.trial} iteration {row.memory_iteration} {row.task}"
            bar.console.print(f"robocog: warning: {where} errored: {row.error}", markup=False, highlight=False)

        try:
            rows = asyncio.run(
                run_eval(
                    config,
                    out,
                    workers=config.workers,
                    resume=args.resume,
                    server_command=server,
                    on_progress=show,
                    on_error=warn,
                    ray_address=ray_address,
                    urls=[u.strip() for u in (args.url or "").split(",") if u.strip()],
                )
            )
        except (ConfigError, ModelServiceError, ServerConnectionError) as exc:
            print(f"robocog: {exc}", file=sys.stderr)
            return 2
    print(f"{len(rows)} attempts in {out}")
    print(summary_line(rows))
    failed = errored(rows)
    if failed and not args.allow_errors:
        print(
            f"robocog: {len(failed)} attempts errored (model service or server failures, not refusals); "
            "`--resume` reruns their trials, `--allow-errors` accepts them",
            file=sys.stderr,
        )
        return 1
    return 0


def report_command(args: argparse.Namespace) -> int:
    """Run `robocog report RESULTS`; returns the exit code."""
    from pydantic import ValidationError

    from robocog.agent.report import load_rows, render

    try:
        rows = load_rows(args.results)
        path = render(
            rows, args.out, title=args.title or f"robocog evaluation: {args.results.name}", csv_format=args.csv
        )
    except (FileNotFoundError, ValueError, ValidationError) as exc:
        problem = " ".join(str(exc).split())  # one line
        named = problem.startswith(f"{args.results}: ")  # read_rows' errors name the file already
        print(f"robocog: {problem if named else f'{args.results}: {problem}'}", file=sys.stderr)
        return 2
    print(f"report: {path}")
    return 0
