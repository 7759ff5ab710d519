"""`python -m robocog.agent.cli`: the `robocog` command."""

import sys

from robocog.agent.cli.main import run

sys.exit(run())
