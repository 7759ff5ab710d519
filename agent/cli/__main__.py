"""`python -m robocog.agent.cli`: the `robocog` command."""

from robocog.agent.cli.main import run

run()
