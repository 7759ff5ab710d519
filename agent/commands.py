"""`robocog eval` and `robocog report`: run a study from its config, and render its results."""

from __future__ import annotations

import argparse
import asyncio
import sys


def eval_command(args: argparse.Namespace) -> int:
    """Run `robocog eval CONFIG`; returns the exit code."""
    import shlex

    from pydantic import ValidationError
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )
    from rich.progress import Progress as ProgressBar

    from robocog.agent.evaluation import Progress, errored, run_eval, summary_line
    from robocog.shared.errors import ConfigError, ModelServiceError, ServerConnectionError
    from robocog.shared.evaluation import AttemptRow, EvalConfig, load_config

    try:
        config = load_config(args.config)
    except ConfigError as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    overrides = {"trials": args.trials, "memory_iterations": args.memory_iterations, "protocol": args.protocol}
    updates = {k: v for k, v in overrides.items() if v is not None}
    try:  # validated exactly as the same values in the file would be
        config = EvalConfig.model_validate({**config.model_dump(), **updates})
    except ValidationError as exc:
        problem = exc.errors()[0]
        flag = "--" + str(problem["loc"][0]).replace("_", "-")
        print(f"robocog: {flag}: {problem['msg']}", file=sys.stderr)
        return 2
    if args.workers is not None and args.workers < 1:
        print("robocog: --workers: must be at least 1", file=sys.stderr)
        return 2
    if args.out is not None:
        out = args.out
    elif config.out is not None:
        out = (args.config.parent / config.out).resolve()
    else:
        print("robocog: no results file: give --out or set `out` in the config", file=sys.stderr)
        return 2
    server = shlex.split(args.server_cmd) if args.server_cmd else None
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
                    workers=args.workers,
                    resume=args.resume,
                    server_command=server,
                    on_progress=show,
                    on_error=warn,
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
        print(f"robocog: {args.results}: {exc}", file=sys.stderr)
        return 2
    print(f"report: {path}")
    return 0
