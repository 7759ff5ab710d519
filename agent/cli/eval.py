"""`robocog eval CONFIG`: run a study from its config (the paper's protocol, or a suite's split), with
a progress bar, and sum it up in one line."""

from __future__ import annotations

import argparse
import asyncio
import gc
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robocog.agent.cli.options import check_server_args, flag_values

if TYPE_CHECKING:
    from robocog.shared.evaluation import EvalConfig


def add_parser(sub: Any) -> argparse.ArgumentParser:
    ev: argparse.ArgumentParser = sub.add_parser("eval", help="run a study (the paper's protocol) from a YAML config")
    ev.add_argument("config", type=Path, help="study config, e.g. assets/eval/scripted.yaml")
    ev.add_argument("--out", type=Path, help="results file (JSONL); default: the config's `out`")
    ev.add_argument(
        "--workers", type=int, help="episodes in flight at once, each on a robot of its own (default: config)"
    )
    ev.add_argument(
        "--isolation",
        choices=["process", "fleet"],
        help="'process': a server process per worker (over stdio); 'fleet': a few fleet servers (HTTP, a robot "
        "per worker, ~29 MB each instead of ~370 MB) (default: config, else process)",
    )
    ev.add_argument(
        "--fleet-processes",
        type=int,
        metavar="P",
        help="fleet servers to spawn with --isolation fleet (default: cores, or one per 16 workers when that is more)",
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
        "--split",
        metavar="SPLIT[@SEED]",
        help="override the config's split; SPLIT@SEED (test@12345) generates a fresh split from SEED (0 to "
        "2147483647), cached, and runs on it",
    )
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
    return ev


def preflight_study(config: EvalConfig, out: Path, *, resume: bool) -> None:
    """What `run_eval` refuses first, checked before anything is drawn: results already in `out` without
    `--resume`, a model whose key is missing (`ConfigError`, `ModelServiceError`)."""
    from robocog.agent.analysis.results_file import read_rows
    from robocog.agent.client.model import check_credentials, resolve_api_key
    from robocog.shared.errors import ConfigError

    held = read_rows(out)
    if held and not resume:
        raise ConfigError(f"{out} already holds {len(held)} results: use --resume to continue, or another --out")
    for spec in config.models:
        check_credentials(spec.model, spec.api_base, resolve_api_key(spec))


def _with_splits(config: EvalConfig) -> EvalConfig:
    """A study of a fresh split ("test@12345"): its servers told where its instances are (--splits)."""
    from robocog.shared.suite import fresh_split

    fresh = None if config.suite is None else fresh_split(config.suite, config.split)
    if fresh is None:
        return config
    _, root = fresh
    return config.model_copy(update={"server_args": [*config.server_args, "--splits", str(root)]})


def main(args: argparse.Namespace) -> int:
    """Run `robocog eval CONFIG`; returns the exit code."""
    import shlex

    from pydantic import ValidationError

    from robocog.shared.errors import ConfigError, ModelServiceError, ServerConnectionError
    from robocog.shared.evaluation import AttemptRow, EvalConfig, load_config

    ray_address = getattr(args, "ray", None)
    if ray_address is not None:
        import importlib.util

        if importlib.util.find_spec("ray") is None:  # the optional extra (robocog.agent.harness.ray_backend.NEEDS_RAY)
            print("robocog: --ray needs Ray: pip install 'robocog[ray]'", file=sys.stderr)
            return 2
    try:
        config = load_config(args.config, split=getattr(args, "split", None))  # the split given, not the file's
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
        flag = "--" + str(problem["loc"][0]).replace("_", "-") if problem["loc"] else "robocog"
        message = str(problem["msg"]).removeprefix("Value error, ")
        print(f"robocog: {flag}: {message}" if problem["loc"] else f"robocog: {message}", file=sys.stderr)
        return 2
    except ConfigError as exc:  # a fresh split that cannot be generated
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    config = _with_splits(config)
    if args.url and "--splits" in config.server_args:  # servers this study does not start
        root = config.server_args[config.server_args.index("--splits") + 1]
        print(
            f"robocog: the fleet servers at --url read the fresh split if started with --splits {root}", file=sys.stderr
        )
    if config.suite is None:  # the paper's tasks: each must be in the catalogue, before any server starts
        from robocog.agent.cli.preflight import unknown_task_id

        unknown = next(filter(None, (unknown_task_id(t, instructions=False) for t in config.tasks)), None)
        if unknown is not None:
            print(f"robocog: {args.config}: tasks: {unknown}", file=sys.stderr)
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
    try:  # what would stop the study at once is said before the progress bar is drawn
        preflight_study(config, out, resume=args.resume)
    except (ConfigError, ModelServiceError) as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    # Imported once the config holds (the MCP client takes seconds to import).
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.progress import Progress as ProgressBar

    from robocog.agent.harness.progress import Progress
    from robocog.agent.harness.study import run_eval, summary_line
    from robocog.agent.harness.units import errored

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

        gc.freeze()  # the imports and the study's set-up live as long as the process (see robocog-server)
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
            bar.live.transient = True  # the bar goes with the study: no empty bar after the error
            bar.stop()
            print(f"robocog: {exc}", file=sys.stderr)
            return 2
    print(f"{len(rows)} attempts in {out}")
    print(summary_line(rows))
    written: dict[str, int] = {}
    for row in rows:
        written[row.model_id or row.model] = written.get(row.model_id or row.model, 0) + row.slips.get(
            "text_tool_calls", 0
        )
    if any(written.values()):
        from robocog.agent.client.slips import text_calls_notice

        for model, count in written.items():
            if count:
                print(f"robocog: {text_calls_notice(model, count)}", file=sys.stderr)
    failed = errored(rows)
    if failed and not args.allow_errors:
        print(
            f"robocog: {len(failed)} attempts errored (model service or server failures, not refusals); "
            "`--resume` reruns their trials, `--allow-errors` accepts them",
            file=sys.stderr,
        )
        return 1
    return 0
