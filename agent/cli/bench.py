"""`robocog bench`: time a server as an agent sees it (an episode, each tool, the model calls)."""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from typing import Any

from robocog.agent.cli.options import add_connection, add_model, check_options, server_spec, settings


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p: argparse.ArgumentParser = sub.add_parser(
        "bench", help="time a server as an agent sees it (episode, each tool, the model calls)"
    )
    p.add_argument("--task", default="T1", help="task id to run (default T1)")
    p.add_argument("--runs", type=int, default=5, help="episodes, each from a fresh world (default 5)")
    add_model(p)
    add_connection(p)
    return p


def main(args: argparse.Namespace) -> int:
    check_options(args)
    from robocog.agent.client.model import warm_up_litellm
    from robocog.agent.harness.bench import bench
    from robocog.shared.errors import ConfigError, ModelServiceError

    chosen = settings(args)
    warm_up_litellm([chosen.model])  # not part of what is measured
    try:
        figures = asyncio.run(bench(server_spec(args), chosen, args.task, args.runs))
    except (ConfigError, ModelServiceError) as exc:
        print(f"robocog: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(figures, indent=2))
    return 0
